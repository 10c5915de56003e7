// unoccluded_pdf (concepts/sampler.hpp, point 9) for every sampler of SPEC 1.6: it equals pdf
// on visible segments, stays > 0 where pdf is 0 only because the ends do not see each other,
// and the static density pieces pooled callers use (direction_pdf, ray_pdf, emission_pdf,
// area_jacobian) compose to it.
#include <segpath/kernels/dirac.hpp>
#include <segpath/kernels/disk.hpp>
#include <segpath/samplers/approximate.hpp>
#include <segpath/samplers/bridge.hpp>
#include <segpath/samplers/bsdf_directed.hpp>
#include <segpath/samplers/light_next.hpp>
#include <segpath/samplers/light_start.hpp>
#include <segpath/samplers/next_segment.hpp>
#include <segpath/samplers/raytraced.hpp>
#include <segpath/samplers/sensor_start.hpp>
#include <segpath/samplers/uniform.hpp>
#include <typeinfo>

#include "sampler_test_support.hpp"
#include "support/catch.hpp"

using namespace sampler_test;

namespace {

template <class T>
using Sphere = st::SphereInterior<T>;

/// Relative tolerance between two evaluations of the same density (the same operations; only
/// V differs between the scenes).
constexpr double same_density = 1e-6;

/// For segments the sampler draws in `base` (a WithOccluder without a ball; visible there):
/// unoccluded_pdf == pdf; then, with an opaque ball put across the segment, pdf is 0 (or, for
/// a sampler that draws occluded segments too, still unoccluded_pdf) while unoccluded_pdf
/// keeps its value. Returns the number of segments checked.
template <class T, class Smp, class Base>
int check_unoccluded(const Smp& smp, const Base& base, const typename Smp::Technique& t, int n,
                     std::uint64_t seed, bool draws_occluded = false) {
  Pcg32 rng(seed, 5);
  int checked = 0, not_positive = 0, differs = 0, not_blocked = 0, occluded_pdf = 0,
      occluded_unoccluded = 0;
  for (int i = 0; i < n; ++i) {
    const auto sample = smp.sample(base, t, rng);
    if (!sample) continue;
    const Segment<T>& s = sample->segment;
    if (!base.visible(VisibilityQuery<T>{s.x, s.y})) continue;  // drawn occluded (uniform)
    ++checked;
    const T open = smp.pdf(base, t, s);
    not_positive += open > T(0) ? 0 : 1;
    differs +=
        relative_difference(double(smp.unoccluded_pdf(base, t, s)), double(open)) < same_density
            ? 0
            : 1;
    // A ball of radius 1/20 of the segment at its midpoint (a unit step along a ray to infinity).
    const bool ray = s.y.kind == PointKind::direction;
    const Vec3<T> d = ray ? s.y.position : (s.y.position - s.x.position);
    const Vec3<T> centre = s.x.position + (ray ? d : d * T(0.5));
    const T radius = ray ? T(0.05) : T(0.05) * glm::length(d);
    const Base occluded = base.with_ball(centre, radius);
    if (occluded.visible(VisibilityQuery<T>{s.x, s.y})) {
      ++not_blocked;
      continue;
    }
    const T unoccluded = smp.unoccluded_pdf(occluded, t, s);
    occluded_unoccluded +=
        relative_difference(double(unoccluded), double(open)) < same_density ? 0 : 1;
    const T closed = smp.pdf(occluded, t, s);
    occluded_pdf += (draws_occluded ? closed == unoccluded : closed == T(0)) ? 0 : 1;
  }
  INFO(typeid(Smp).name() << ": " << checked << " segments of " << n << " draws");
  CHECK(checked > n / 4);
  CHECK(not_positive == 0);
  CHECK(differs == 0);  // unoccluded_pdf == pdf on visible segments
  CHECK(not_blocked == 0);
  CHECK(occluded_pdf == 0);         // pdf = unoccluded_pdf * V (or = unoccluded_pdf: uniform)
  CHECK(occluded_unoccluded == 0);  // unoccluded_pdf does not see the occluder
  return checked;
}

}  // namespace

TEMPLATE_TEST_CASE("unoccluded_pdf: equal to pdf when visible, kept when occluded, sphere samplers",
                   "[samplers]", float, double) {
  using T = TestType;
  using Scn = WithOccluder<Sphere<T>>;
  const Scn scene(make_sphere<T>());
  const auto at = [&](Vec3<T> u) { return scene.point_at(glm::normalize(u)); };
  const Segment<T> s{at(Vec3<T>(T(0.2), T(0.3), T(-0.9))), at(Vec3<T>(T(-0.5), T(0.1), T(0.8)))};
  const Segment<T> u{at(Vec3<T>(T(0.9), T(-0.1), T(0.1))), at(Vec3<T>(T(-0.3), T(-0.8), T(0.2)))};
  const DiskKernel<T> kernel(T(0.2));
  check_unoccluded<T>(UniformSegmentSampler<Scn>{}, scene, {}, 200, 1, true);
  check_unoccluded<T>(RaytracedSegmentSampler<Scn>{}, scene, {}, 200, 2);
  check_unoccluded<T>(BsdfDirectedSegmentSampler<Scn>{}, scene,
                      {glm::normalize(Vec3<T>(T(0.1), T(0.2), T(1)))}, 400, 3);
  check_unoccluded<T>(LightStartSampler<Scn>{}, scene, {}, 200, 4);
  check_unoccluded<T>(NextSegmentSampler<Scn, DiracKernel<T>>{DiracKernel<T>{}}, scene, {s}, 200,
                      5);
  check_unoccluded<T>(ApproximateNextSegmentSampler<Scn, DiskKernel<T>>{kernel}, scene, {s}, 200,
                      6);
  check_unoccluded<T>(LightNextSegmentSampler<Scn, DiracKernel<T>>{DiracKernel<T>{}}, scene, {s},
                      200, 7);
  check_unoccluded<T>(ApproximateLightNextSegmentSampler<Scn, DiskKernel<T>>{kernel}, scene, {s},
                      200, 8);
  check_unoccluded<T>(KernelBridgeSampler<Scn, DiracKernel<T>>{DiracKernel<T>{}}, scene, {s, u}, 10,
                      9);
  check_unoccluded<T>(LightBridgeSampler<Scn, DiracKernel<T>>{DiracKernel<T>{}}, scene, {s}, 200,
                      10);
}

TEMPLATE_TEST_CASE(
    "unoccluded_pdf: equal to pdf when visible, kept when occluded, slab and point-light samplers",
    "[samplers]", float, double) {
  using T = TestType;
  {
    using Scn = WithOccluder<SlabWithCamera<T>>;
    const Scn scene(SlabWithCamera<T>{});
    const DiskKernel<T> kernel(T(0.3));
    const Segment<T> camera{scene.point_on(st::SlabSide::b, T(0.7), T(0.1)),
                            scene.point_on(st::SlabSide::a, T(0.2), T(0.3))};
    const Segment<T> light{scene.point_on(st::SlabSide::b, T(-0.4), T(0.6)),
                           scene.point_on(st::SlabSide::a, T(1.5), T(-0.5))};
    const Segment<T> up{scene.point_on(st::SlabSide::a, T(0.5), T(0.4)),
                        scene.point_on(st::SlabSide::b, T(-0.3), T(0.2))};
    check_unoccluded<T>(SensorStartSampler<Scn>{}, scene, {0}, 200, 11);
    check_unoccluded<T>(SensorStartSampler<Scn>{}, scene, {1}, 200, 12);
    check_unoccluded<T>(NextSegmentSampler<Scn, DiskKernel<T>>{kernel}, scene, {camera}, 200, 13);
    check_unoccluded<T>(LightNextSegmentSampler<Scn, DiskKernel<T>>{kernel}, scene, {light}, 200,
                        14);
    check_unoccluded<T>(KernelBridgeSampler<Scn, DiskKernel<T>>{kernel}, scene, {camera, light},
                        200, 15);
    check_unoccluded<T>(LightBridgeSampler<Scn, DiskKernel<T>>{kernel}, scene, {camera}, 200, 16);
    check_unoccluded<T>(SensorBridgeSampler<Scn, DiskKernel<T>>{kernel}, scene, {up}, 200, 17);
  }
  {
    // Point-light ends (PointKind::point): emitted and next-event segments.
    using Scn = WithOccluder<st::PointLitPlane<T>>;
    const Scn scene(st::PointLitPlane<T>(st::PointLitPlaneParameters<T>{T(2), T(1), T(3), T(0.5)},
                                         {Vec2<T>(0, 0)}));
    const Segment<T> camera{
        SurfacePoint<T>::at_point(Vec3<T>(T(0.3), 0, T(0.5))),
        SurfacePoint<T>::on_surface(Vec3<T>(T(0.6), T(-0.2), 0), Vec3<T>(0, 0, 1), 0, 0)};
    check_unoccluded<T>(LightStartSampler<Scn>{}, scene, {}, 400, 18);
    check_unoccluded<T>(LightBridgeSampler<Scn, DiracKernel<T>>{DiracKernel<T>{}}, scene, {camera},
                        10, 19);
  }
}

TEMPLATE_TEST_CASE(
    "unoccluded_pdf through the disk-lit plane's own occluder: the disk hides the sky",
    "[samplers]", float, double) {
  using T = TestType;
  using Scn = st::DiskLitPlane<T>;
  const Scn scene(st::DiskLitPlaneParameters<T>{}, {Vec2<T>(0, 0)});
  // x on the square under the disk (radius 0.5 at height 1): straight up the disk blocks the
  // escape; a shallow direction escapes past its rim.
  const auto x = SurfacePoint<T>::on_surface(Vec3<T>(T(0.1), 0, 0), Vec3<T>(0, 0, 1), 0, 0);
  const Segment<T> up{x, SurfacePoint<T>::at_infinity(Vec3<T>(0, 0, 1))};
  const Vec3<T> shallow = glm::normalize(Vec3<T>(1, 0, T(0.3)));
  const Segment<T> away{x, SurfacePoint<T>::at_infinity(shallow)};
  REQUIRE_FALSE(scene.visible(VisibilityQuery<T>{up.x, up.y}));
  REQUIRE(scene.visible(VisibilityQuery<T>{away.x, away.y}));
  // Lambertian direction densities cos / pi; a direction end takes no area conversion.
  const double up_density = double(inv_pi<T>), away_density = double(shallow.z * inv_pi<T>);
  const auto check = [&](const auto& smp, const auto& t, double scale) {
    INFO(typeid(smp).name());
    CHECK(smp.pdf(scene, t, up) == T(0));
    CHECK(double(smp.unoccluded_pdf(scene, t, up)) == Approx(scale * up_density).epsilon(1e-5));
    CHECK(double(smp.pdf(scene, t, away)) == Approx(scale * away_density).epsilon(1e-5));
    CHECK(smp.unoccluded_pdf(scene, t, away) == smp.pdf(scene, t, away));
  };
  const Segment<T> previous{SurfacePoint<T>::at_point(Vec3<T>(T(0.3), T(0.2), T(0.5))), x};
  const DiskKernel<T> kernel(T(0.2));
  check(NextSegmentSampler<Scn, DiracKernel<T>>{DiracKernel<T>{}},
        typename NextSegmentSampler<Scn, DiracKernel<T>>::Technique{previous}, 1.0);
  check(ApproximateNextSegmentSampler<Scn, DiskKernel<T>>{kernel},
        typename ApproximateNextSegmentSampler<Scn, DiskKernel<T>>::Technique{previous},
        1 / (std::numbers::pi * 0.04));
  check(BsdfDirectedSegmentSampler<Scn>{},
        typename BsdfDirectedSegmentSampler<Scn>::Technique{
            glm::normalize(previous.x.position - x.position)},
        1 / double(scene.area()));
}

TEMPLATE_TEST_CASE("density pieces for pooled callers compose to unoccluded_pdf", "[samplers]",
                   float, double) {
  using T = TestType;
  // Every segment of this slab is occluded (a ball around all of them): the pieces, like
  // unoccluded_pdf, ignore V, as they must for pooled segments whose V the caller knows.
  using Scn = WithOccluder<SlabWithCamera<T>>;
  const Scn scene(SlabWithCamera<T>{}, Vec3<T>(0, 0, T(0.5)), T(100));
  const auto a = [&](T x, T y) { return scene.point_on(st::SlabSide::a, x, y); };
  const auto b = [&](T x, T y) { return scene.point_on(st::SlabSide::b, x, y); };
  const Segment<T> t{b(T(0.7), T(0.1)),
                     a(T(0.2), T(0.3))};  // camera technique: ends at y_t on plane a
  const Segment<T> s{a(T(0.2), T(0.3)), b(T(-0.6), T(0.9))};  // its successor, from y_t
  const Segment<T> u{b(T(-0.6), T(0.9)),
                     a(T(1.1), T(-0.4))};  // light technique: starts at x_u = s.y
  const Vec3<T> ts = t.direction(), ss = s.direction(), us = u.direction();
  // The raw expressions segment filtering evaluates today, and the sampler pieces: identical.
  const T camera_raw = scene.bsdf().pdf(BsdfQuery<T>{t.y, -ts, ss, Transport::radiance});
  using Next = ApproximateNextSegmentSampler<Scn, DiracKernel<T>>;
  CHECK(Next::direction_pdf(scene, t.y, -ts, ss) == camera_raw);
  CHECK(Next::area_jacobian(s) == solid_angle_to_area(T(1), s.x, s.y));
  const T light_raw = scene.bsdf().pdf(BsdfQuery<T>{u.x, -ss, us, Transport::importance});
  using Prev = ApproximateLightNextSegmentSampler<Scn, DiracKernel<T>>;
  CHECK(Prev::direction_pdf(scene, u.x, -ss, us) == light_raw);
  CHECK(Prev::area_jacobian(s) == solid_angle_to_area(T(1), s.y, s.x));
  // They compose to the samplers' unoccluded densities (up to rounding: grouped differently).
  CHECK(camera_raw > T(0));
  CHECK(light_raw > T(0));
  const NextSegmentSampler<Scn, DiracKernel<T>> next{DiracKernel<T>{}};
  CHECK(next.pdf(scene, {t}, s) == T(0));
  CHECK(double(next.unoccluded_pdf(scene, {t}, s)) ==
        Approx(double(Next::direction_pdf(scene, t.y, -ts, ss) * Next::area_jacobian(s)))
            .epsilon(1e-6));
  const LightNextSegmentSampler<Scn, DiracKernel<T>> previous{DiracKernel<T>{}};
  CHECK(double(previous.unoccluded_pdf(scene, {u}, s)) ==
        Approx(double(Prev::direction_pdf(scene, u.x, -ss, us) * Prev::area_jacobian(s)))
            .epsilon(1e-6));
  // Sensor start: the sensor's ray density times the area conversion.
  const Segment<T> first{SurfacePoint<T>::at_point(Vec3<T>(T(0.1), T(-0.2), T(0.5))),
                         a(T(0.4), T(0.1))};
  const SensorPdf<T> sp = scene.sensor().pdf(SensorQuery<T>{first.x, first.direction()});
  CHECK(SensorStartSampler<Scn>::ray_pdf(scene, first.x, first.direction()) ==
        sp.position * sp.direction);
  CHECK(SensorStartSampler<Scn>::area_jacobian(first) ==
        solid_angle_to_area(T(1), first.x, first.y));
  CHECK(double(SensorStartSampler<Scn>{}.unoccluded_pdf(scene, {0}, first)) ==
        Approx(double(SensorStartSampler<Scn>::ray_pdf(scene, first.x, first.direction()) *
                      SensorStartSampler<Scn>::area_jacobian(first)))
            .epsilon(1e-6));
  // Light start: the emitter's densities times the area conversion at x.
  const Segment<T> last{a(T(0.3), T(-0.2)), b(T(0.8), T(0.5))};
  const Vec3<T> ls = last.direction();
  const EmissionPdf<T> e = scene.emitter().pdf_emission(EmissionPdfQuery<T>{last.y, -ls});
  CHECK(LightStartSampler<Scn>::emission_pdf(scene, last.y, -ls) == e.position * e.direction);
  CHECK(LightStartSampler<Scn>::area_jacobian(last, ls) ==
        solid_angle_to_area(T(1), last.y, last.x));
  CHECK(e.position * e.direction > T(0));
  CHECK(double(LightStartSampler<Scn>{}.unoccluded_pdf(scene, {}, last)) ==
        Approx(double(LightStartSampler<Scn>::emission_pdf(scene, last.y, -ls) *
                      LightStartSampler<Scn>::area_jacobian(last, ls)))
            .epsilon(1e-6));
}
