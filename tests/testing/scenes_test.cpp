#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <segpath/core/geometry.hpp>
#include <segpath/core/rng.hpp>
#include <segpath/testing/integrate.hpp>
#include <segpath/testing/lit_plane.hpp>
#include <segpath/testing/periodic_slab.hpp>
#include <segpath/testing/statistics.hpp>
#include <stdexcept>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;
using segpath::testing::DiskLitPlane;
using segpath::testing::DiskLitPlaneParameters;
using segpath::testing::PeriodicSlab;
using segpath::testing::PeriodicSlabParameters;
using segpath::testing::PointLitPlane;
using segpath::testing::PointLitPlaneParameters;
using segpath::testing::RunningStats;
using segpath::testing::SlabProbe;
using segpath::testing::SlabSide;

static_assert(LightSampledScene<PeriodicSlab<float>>);
static_assert(LightSampledScene<PeriodicSlab<double>>);
static_assert(LightSampledScene<PointLitPlane<float>>);
static_assert(LightSampledScene<PointLitPlane<double>>);
static_assert(LightSampledScene<DiskLitPlane<float>>);
static_assert(LightSampledScene<DiskLitPlane<double>>);

namespace {

/// Every [stat] test case below runs at most this many t-tests; together they keep the
/// chance of a spurious failure of a correct implementation at 1%.
const double stat_alpha = segpath::testing::sidak_alpha(0.01, 16);

/// Relative tolerance for comparing closed forms evaluated in T with double references.
template <Real T>
constexpr double closed_form_tolerance =
    std::max(1e-6, 32.0 * static_cast<double>(std::numeric_limits<T>::epsilon()));

template <Real T>
PeriodicSlabParameters<T> slab_parameters() {
  PeriodicSlabParameters<T> p;
  p.height = T(0.5);
  p.period = T(1.5);
  p.emission_a = T(1);
  p.emission_b = T(2);
  p.albedo_a = T(0.6);
  p.albedo_b = T(0.3);
  return p;
}

template <Real T>
PeriodicSlab<T> make_slab() {
  return PeriodicSlab<T>(
      slab_parameters<T>(),
      {SlabProbe<T>{Vec3<T>(T(0.3), T(0.2), T(0.2)), SlabSide::a, Vec2<T>(T(0.1), T(0.9))},
       SlabProbe<T>{Vec3<T>(T(-1), T(4), T(0.1)), SlabSide::b, Vec2<T>(T(2), T(3.5))}});
}

template <Real T>
PointLitPlane<T> make_point_lit() {
  PointLitPlaneParameters<T> p;
  p.half_size = T(2);
  p.height = T(1.5);
  p.intensity = T(3);
  p.albedo = T(0.7);
  return PointLitPlane<T>(p, {Vec2<T>(0, 0), Vec2<T>(T(0.7), T(-0.2))});
}

template <Real T>
DiskLitPlane<T> make_disk_lit() {
  DiskLitPlaneParameters<T> p;
  p.half_size = T(2);
  p.height = T(1);
  p.disk_radius = T(0.6);
  p.radiance = T(2);
  p.albedo = T(0.8);
  return DiskLitPlane<T>(p, {Vec2<T>(0, 0), Vec2<T>(T(0.7), 0)});
}

template <Real T>
Hit<T> probe_hit(const auto& scene, std::uint32_t pixel) {
  const auto ray = scene.sensor().sample_ray(SensorSampleQuery<T>{pixel, {}, {}});
  REQUIRE(ray);
  const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{ray->origin.position, ray->direction}});
  REQUIRE(hit);
  return *hit;
}

/// A hit must lie on the ray at its distance, carry a unit normal facing the ray's origin and
/// a shading normal equal to it.
template <Real T>
void check_hit(const Ray<T>& ray, const Hit<T>& hit) {
  const double eps = 1e-4;
  CHECK(hit.distance > T(0));
  CHECK(glm::length(hit.point.position - ray.at(hit.distance)) ==
        Approx(0).margin(eps * (1 + hit.distance)));
  CHECK(glm::length(hit.point.normal) == Approx(1).epsilon(1e-5));
  CHECK(glm::dot(hit.point.normal, ray.origin - hit.point.position) > T(0));
  CHECK(glm::dot(hit.point.shading_normal, hit.point.normal) == Approx(1).epsilon(1e-5));
  CHECK(glm::dot(hit.point.shading_frame().tangent, hit.point.normal) == Approx(0).margin(1e-5));
}

}  // namespace

// ---- PeriodicSlab ----------------------------------------------------------------------

TEMPLATE_TEST_CASE("PeriodicSlab closed forms satisfy their balance equations", "[testing][scenes]",
                   float, double) {
  using T = TestType;
  const auto slab = make_slab<T>();
  const T la = slab.radiance(SlabSide::a);
  const T lb = slab.radiance(SlabSide::b);
  CHECK(la == Approx(T(2.2) / T(0.82)));
  CHECK(la == Approx(slab.emission(SlabSide::a) + slab.albedo(SlabSide::a) * lb));
  CHECK(lb == Approx(slab.emission(SlabSide::b) + slab.albedo(SlabSide::b) * la));
  CHECK(slab.bounce_radiance(SlabSide::a, 0) == T(1));
  CHECK(slab.bounce_radiance(SlabSide::a, 1) == Approx(T(0.6) * T(2)));
  CHECK(slab.bounce_radiance(SlabSide::a, 2) == Approx(T(0.6) * T(0.3) * T(1)));
  CHECK(slab.bounce_radiance(SlabSide::b, 3) == Approx(T(0.3) * T(0.18) * T(1)));
  CHECK(slab.radiance_up_to(SlabSide::a, 2) == Approx(T(1) + T(1.2) + T(0.18)));
  CHECK(slab.radiance_up_to(SlabSide::b, 60) == Approx(lb));
  CHECK(slab.probe_radiance(0) == la);
  CHECK(slab.probe_radiance(1) == lb);
}

TEMPLATE_TEST_CASE("PeriodicSlab intersect hits the other plane at the true distance",
                   "[testing][scenes]", float, double) {
  using T = TestType;
  const auto slab = make_slab<T>();
  const T h = slab.parameters().height;
  Pcg32 rng(3, 0);
  for (int i = 0; i < 200; ++i) {
    const Vec3<T> origin((rng.uniform<T>() - T(0.5)) * T(10), rng.uniform<T>() * T(3),
                         (T(0.05) + T(0.9) * rng.uniform<T>()) * h);
    const Vec3<T> d = square_to_uniform_sphere(rng.uniform2<T>());
    const Ray<T> ray{origin, d};
    const auto hit = slab.intersect(IntersectQuery<T>{ray});
    REQUIRE(hit);
    check_hit(ray, *hit);
    CHECK(hit->point.position.z == (d.z > 0 ? h : T(0)));
    CHECK(hit->point.primitive_id == (d.z > 0 ? 1u : 0u));
    CHECK_FALSE(slab.intersect(IntersectQuery<T>{ray, hit->distance * T(0.999)}));
    // From the hit, a ray back into the slab reaches the other plane, never the start one.
    const Ray<T> back{hit->point.position, -d};
    const auto next = slab.intersect(IntersectQuery<T>{back});
    REQUIRE(next);
    CHECK(next->point.primitive_id != hit->point.primitive_id);
    CHECK(next->distance == Approx(h / std::abs(d.z)).epsilon(1e-4));
    // Leaving the slab through the plane the ray starts on hits nothing.
    CHECK_FALSE(slab.intersect(IntersectQuery<T>{Ray<T>{hit->point.position, d}}));
  }
  CHECK_FALSE(slab.intersect(IntersectQuery<T>{Ray<T>{Vec3<T>(0, 0, T(0.25)), Vec3<T>(1, 0, 0)}}));
}

TEMPLATE_TEST_CASE("PeriodicSlab visibility and area sampling", "[testing][scenes]", float,
                   double) {
  using T = TestType;
  const auto slab = make_slab<T>();
  const T h = slab.parameters().height;
  const T period = slab.parameters().period;
  const auto a1 = slab.point_on(SlabSide::a, 0, 0);
  const auto a2 = slab.point_on(SlabSide::a, T(5), T(-3));
  const auto b1 = slab.point_on(SlabSide::b, T(7), T(1));
  const auto inside = SurfacePoint<T>::at_point(Vec3<T>(T(0.1), T(0.1), h / 2));
  const auto above = SurfacePoint<T>::at_point(Vec3<T>(0, 0, h * 2));
  using Q = VisibilityQuery<T>;
  CHECK(slab.visible(Q{a1, b1}));
  CHECK(slab.visible(Q{b1, a1}));
  CHECK_FALSE(slab.visible(Q{a1, a2}));
  CHECK_FALSE(slab.visible(Q{b1, b1}));
  CHECK(slab.visible(Q{inside, a2}));
  CHECK(slab.visible(Q{b1, inside}));
  CHECK_FALSE(slab.visible(Q{above, a1}));

  Pcg32 rng(5, 0);
  int on_a = 0;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const auto s = slab.sample_area(AreaSampleQuery<T>{rng.uniform2<T>()});
    REQUIRE(s);
    CHECK(s->pdf == Approx(T(1) / (T(2) * period * period)));
    CHECK(s->pdf == Approx(T(1) / slab.area()));
    const Vec3<T>& x = s->point.position;
    CHECK((x.x >= T(0) && x.x <= period && x.y >= T(0) && x.y <= period));
    CHECK((x.z == T(0) || x.z == h));
    CHECK(s->point.normal.z == (x.z == T(0) ? T(1) : T(-1)));
    on_a += x.z == T(0);
  }
  // Binomial(4000, 1/2): 5 standard deviations are 158.
  CHECK(std::abs(on_a - n / 2) < 158);
}

TEMPLATE_TEST_CASE("PeriodicSlab emitter sampling densities agree", "[testing][scenes]", float,
                   double) {
  using T = TestType;
  const auto slab = make_slab<T>();
  const auto emitter = slab.emitter();
  const T h = slab.parameters().height;
  const auto receivers = std::vector<SurfacePoint<T>>{
      slab.point_on(SlabSide::a, T(0.4), T(0.2)), slab.point_on(SlabSide::b, T(3), T(-1)),
      SurfacePoint<T>::at_point(Vec3<T>(T(0.2), T(0.3), h / 3))};
  Pcg32 rng(9, 0);
  for (const auto& r : receivers) {
    for (int i = 0; i < 200; ++i) {
      const auto s = emitter.sample_towards(EmitterTowardsQuery<T>{r, rng.uniform2<T>()});
      if (!s) continue;
      CHECK(s->pdf ==
            Approx(emitter.pdf_towards(EmitterPdfTowardsQuery<T>{r, s->point})).epsilon(1e-4));
      CHECK(slab.visible(VisibilityQuery<T>{r, s->point}));
      const T le = slab.emission(s->point.primitive_id == 0 ? SlabSide::a : SlabSide::b);
      CHECK(s->radiance == le);
      // The draw is proportional to the projected solid angle, so L_e G / p is constant:
      // pi L_e from a plane, 4 pi L_e from a point between the planes.
      const T expected = (r.kind == PointKind::point ? T(4) : T(1)) * pi<T> * le;
      CHECK(s->radiance * geometry_term(Segment<T>{r, s->point}) / s->pdf ==
            Approx(expected).epsilon(1e-3));
      if (r.kind == PointKind::surface) CHECK(s->point.primitive_id != r.primitive_id);
    }
    CHECK(emitter.pdf_towards(EmitterPdfTowardsQuery<T>{receivers[0], receivers[0]}) == T(0));
  }
  for (int i = 0; i < 200; ++i) {
    const auto s =
        emitter.sample_emission(EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>()});
    REQUIRE(s);
    const auto pdf = emitter.pdf_emission(EmissionPdfQuery<T>{s->point, s->direction});
    CHECK(pdf.position == Approx(s->pdf_position));
    CHECK(pdf.direction == Approx(s->pdf_direction).epsilon(1e-4));
    CHECK(glm::dot(s->direction, s->point.normal) > T(0));
    CHECK(emitter.radiance(EmissionQuery<T>{s->point, s->direction}) == s->radiance);
    CHECK(emitter.radiance(EmissionQuery<T>{s->point, -s->direction}) == T(0));
  }
}

TEMPLATE_TEST_CASE("PeriodicSlab probes look at their targets", "[testing][scenes]", float,
                   double) {
  using T = TestType;
  const auto slab = make_slab<T>();
  for (std::uint32_t pixel = 0; pixel < 2; ++pixel) {
    const Hit<T> hit = probe_hit<T>(slab, pixel);
    CHECK(glm::length(hit.point.position - slab.probe_target(pixel)) == Approx(0).margin(1e-5));
    CHECK(hit.point.primitive_id == static_cast<std::uint32_t>(slab.probe_side(pixel)));
  }
}

TEMPLATE_TEST_CASE("PeriodicSlab rejects bad parameters", "[testing][scenes]", float, double) {
  using T = TestType;
  const T nan = std::numeric_limits<T>::quiet_NaN();
  const T inf = std::numeric_limits<T>::infinity();
  const std::vector<SlabProbe<T>> probes{
      SlabProbe<T>{Vec3<T>(0, 0, T(0.25)), SlabSide::a, Vec2<T>(0, 0)}};
  const auto rejects = [&](auto modify) {
    auto p = slab_parameters<T>();
    modify(p);
    return [p, &probes] { PeriodicSlab<T>(p, probes); };
  };
  CHECK_NOTHROW(rejects([](auto&) {})());
  CHECK_THROWS_AS(rejects([&](auto& p) { p.height = T(0); })(), std::invalid_argument);
  CHECK_THROWS_AS(rejects([&](auto& p) { p.height = -T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(rejects([&](auto& p) { p.height = inf; })(), std::invalid_argument);
  CHECK_THROWS_AS(rejects([&](auto& p) { p.period = T(0); })(), std::invalid_argument);
  CHECK_THROWS_AS(rejects([&](auto& p) { p.period = nan; })(), std::invalid_argument);
  CHECK_THROWS_AS(rejects([&](auto& p) { p.emission_a = -T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(rejects([&](auto& p) { p.emission_b = inf; })(), std::invalid_argument);
  CHECK_THROWS_AS(rejects([&](auto& p) { p.albedo_a = T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(rejects([&](auto& p) { p.albedo_b = -T(0.1); })(), std::invalid_argument);
  CHECK_THROWS_AS(rejects([&](auto& p) { p.albedo_b = nan; })(), std::invalid_argument);
  const auto p = slab_parameters<T>();
  CHECK_THROWS_AS(PeriodicSlab<T>(p, {}), std::invalid_argument);
  CHECK_THROWS_AS(PeriodicSlab<T>(p, {SlabProbe<T>{Vec3<T>(0, 0, 0), SlabSide::b, Vec2<T>(0, 0)}}),
                  std::invalid_argument);
  CHECK_THROWS_AS(
      PeriodicSlab<T>(p, {SlabProbe<T>{Vec3<T>(0, 0, p.height), SlabSide::a, Vec2<T>(0, 0)}}),
      std::invalid_argument);
  CHECK_THROWS_AS(
      PeriodicSlab<T>(p, {SlabProbe<T>{Vec3<T>(0, 0, T(0.1)), SlabSide::a, Vec2<T>(nan, 0)}}),
      std::invalid_argument);
}

namespace {

/// A hand-written random walk from probe `pixel`: cosine (BSDF) sampling, Russian roulette
/// with survival probability q, emission added at every hit. `compensate_roulette` = false
/// is the classic bug (throughput not divided by q), which the t-test must reject.
template <Real T>
T slab_walk(const PeriodicSlab<T>& slab, std::uint32_t pixel, Pcg32& rng, T q,
            bool compensate_roulette) {
  const auto ray = slab.sensor().sample_ray(SensorSampleQuery<T>{pixel, {}, {}});
  auto hit = slab.intersect(IntersectQuery<T>{Ray<T>{ray->origin.position, ray->direction}});
  Vec3<T> to_sensor = -ray->direction;
  const auto emitter = slab.emitter();
  const auto bsdf = slab.bsdf();
  T estimate = 0;
  T throughput = 1;
  while (hit) {
    estimate += throughput * emitter.radiance(EmissionQuery<T>{hit->point, to_sensor});
    if (!(rng.uniform<T>() < q)) break;
    if (compensate_roulette) throughput /= q;
    const auto s = bsdf.sample(BsdfSampleQuery<T>{hit->point, to_sensor, rng.uniform2<T>()});
    if (!s) break;
    throughput *= s->value * glm::dot(s->direction, hit->point.normal) / s->pdf;
    hit = slab.intersect(IntersectQuery<T>{Ray<T>{hit->point.position, s->direction}});
    to_sensor = -s->direction;
  }
  return estimate;
}

/// The same walk with next-event estimation through Emission::sample_towards at every
/// vertex; emission found by the BSDF-sampled rays counts only at the first hit.
template <Real T>
T slab_walk_nee(const PeriodicSlab<T>& slab, std::uint32_t pixel, Pcg32& rng, T q) {
  const auto ray = slab.sensor().sample_ray(SensorSampleQuery<T>{pixel, {}, {}});
  auto hit = slab.intersect(IntersectQuery<T>{Ray<T>{ray->origin.position, ray->direction}});
  if (!hit) return T(0);
  Vec3<T> to_sensor = -ray->direction;
  const auto emitter = slab.emitter();
  const auto bsdf = slab.bsdf();
  T estimate = emitter.radiance(EmissionQuery<T>{hit->point, to_sensor});
  T throughput = 1;
  while (hit) {
    const SurfacePoint<T>& x = hit->point;
    if (const auto light = emitter.sample_towards(EmitterTowardsQuery<T>{x, rng.uniform2<T>()});
        light && slab.visible(VisibilityQuery<T>{x, light->point})) {
      const Vec3<T> to_light = glm::normalize(light->point.position - x.position);
      const T f = bsdf.eval(BsdfQuery<T>{x, to_sensor, to_light});
      estimate += throughput * f * geometry_term(Segment<T>{x, light->point}) * light->radiance /
                  light->pdf;
    }
    if (!(rng.uniform<T>() < q)) break;
    throughput /= q;
    const auto s = bsdf.sample(BsdfSampleQuery<T>{x, to_sensor, rng.uniform2<T>()});
    if (!s) break;
    throughput *= s->value * glm::dot(s->direction, x.normal) / s->pdf;
    to_sensor = -s->direction;
    hit = slab.intersect(IntersectQuery<T>{Ray<T>{x.position, s->direction}});
  }
  return estimate;
}

}  // namespace

TEMPLATE_TEST_CASE("PeriodicSlab random walks converge to L_A and L_B", "[testing][scenes][stat]",
                   float, double) {
  using T = TestType;
  const auto slab = make_slab<T>();
  const int n = 40000;
  const T q = T(0.7);
  for (std::uint32_t pixel = 0; pixel < 2; ++pixel) {
    RunningStats plain, nee, wrong;
    for (int i = 0; i < n; ++i) {
      Pcg32 rng = Pcg32::for_sample(2024, pixel, static_cast<std::uint64_t>(i));
      plain.add(slab_walk(slab, pixel, rng, q, true));
      nee.add(slab_walk_nee(slab, pixel, rng, q));
      wrong.add(slab_walk(slab, pixel, rng, q, false));
    }
    const double expected = slab.probe_radiance(pixel);
    INFO("pixel " << pixel << ": expected " << expected << ", walk " << plain.mean() << " +- "
                  << plain.standard_error() << ", NEE " << nee.mean() << " +- "
                  << nee.standard_error() << ", uncompensated " << wrong.mean());
    CHECK_FALSE(segpath::testing::student_t_test(plain, expected).rejects(stat_alpha));
    CHECK_FALSE(segpath::testing::student_t_test(nee, expected).rejects(stat_alpha));
    CHECK(segpath::testing::student_t_test(wrong, expected).rejects(stat_alpha));
  }
}

// ---- PointLitPlane ---------------------------------------------------------------------

TEMPLATE_TEST_CASE("PointLitPlane geometry, sampling and visibility", "[testing][scenes]", float,
                   double) {
  using T = TestType;
  const auto scene = make_point_lit<T>();
  const T s = scene.parameters().half_size;
  const T h = scene.parameters().height;
  Pcg32 rng(13, 0);
  for (int i = 0; i < 200; ++i) {
    const auto a = scene.sample_area(AreaSampleQuery<T>{rng.uniform2<T>()});
    REQUIRE(a);
    CHECK(a->pdf == Approx(T(1) / (T(4) * s * s)));
    CHECK(a->pdf == Approx(T(1) / scene.area()));
    const Vec3<T>& x = a->point.position;
    CHECK((std::abs(x.x) <= s && std::abs(x.y) <= s && x.z == T(0)));
    CHECK(a->point.normal == Vec3<T>(0, 0, 1));
    // A ray from above towards the sampled point finds it.
    const Vec3<T> origin(rng.uniform<T>() - T(0.5), rng.uniform<T>() - T(0.5),
                         h * rng.uniform<T>() + T(0.1));
    const Ray<T> ray{origin, glm::normalize(x - origin)};
    const auto hit = scene.intersect(IntersectQuery<T>{ray});
    REQUIRE(hit);
    check_hit(ray, *hit);
    CHECK(glm::length(hit->point.position - x) == Approx(0).margin(1e-4));
    CHECK(scene.visible(VisibilityQuery<T>{scene.emitter().point(), a->point}));
    CHECK(scene.visible(VisibilityQuery<T>{a->point, SurfacePoint<T>::at_point(origin)}));
    // Through the square to the other side is blocked; past its edge is not.
    CHECK_FALSE(scene.visible(VisibilityQuery<T>{SurfacePoint<T>::at_point(x + Vec3<T>(0, 0, 1)),
                                                 SurfacePoint<T>::at_point(x - Vec3<T>(0, 0, 1))}));
  }
  const auto left = SurfacePoint<T>::at_point(Vec3<T>(-s - 1, 0, 1));
  const auto right = SurfacePoint<T>::at_point(Vec3<T>(-s - 1, 0, -1));
  CHECK(scene.visible(VisibilityQuery<T>{left, right}));
  CHECK_FALSE(scene.intersect(
      IntersectQuery<T>{Ray<T>{Vec3<T>(0, 0, 1), glm::normalize(Vec3<T>(s + 1, 0, -1))}}));
  CHECK_FALSE(scene.intersect(IntersectQuery<T>{Ray<T>{Vec3<T>(0, 0, 1), Vec3<T>(0, 0, 1)}}));
  for (std::uint32_t pixel = 0; pixel < 2; ++pixel) {
    const Hit<T> hit = probe_hit<T>(scene, pixel);
    CHECK(glm::length(hit.point.position - scene.probe_target(pixel)) == Approx(0).margin(1e-6));
    CHECK(hit.point.position.z == T(0));
  }
}

TEMPLATE_TEST_CASE("PointLitPlane next-event estimate equals the closed form", "[testing][scenes]",
                   float, double) {
  using T = TestType;
  const auto scene = make_point_lit<T>();
  const auto light = scene.emitter();
  const auto bsdf = scene.bsdf();
  const T h = scene.parameters().height;
  const T intensity = scene.parameters().intensity;
  CHECK(scene.irradiance_at(Vec3<T>(0, 0, 0)) == Approx(intensity / (h * h)));
  for (std::uint32_t pixel = 0; pixel < 2; ++pixel) {
    const Hit<T> hit = probe_hit<T>(scene, pixel);
    const auto ls =
        light.sample_towards(EmitterTowardsQuery<T>{hit.point, Vec2<T>(T(0.5), T(0.5))});
    REQUIRE(ls);
    const Vec3<T> to_light = glm::normalize(ls->point.position - hit.point.position);
    const T estimate = bsdf.eval(BsdfQuery<T>{hit.point, Vec3<T>(0, 0, 1), to_light}) *
                       geometry_term(Segment<T>{hit.point, ls->point}) * ls->radiance / ls->pdf;
    CHECK(estimate == Approx(scene.probe_radiance(pixel)).epsilon(1e-5));
    CHECK(scene.bounce_radiance_at(hit.point.position, 1) == scene.radiance_at(hit.point.position));
    CHECK(scene.bounce_radiance_at(hit.point.position, 2) == T(0));
  }
  // Nothing but the light's own point emits.
  CHECK(light.radiance(EmissionQuery<T>{
            SurfacePoint<T>::on_surface(Vec3<T>(0, 0, 0), Vec3<T>(0, 0, 1)), Vec3<T>(0, 0, 1)}) ==
        T(0));
}

TEST_CASE("PointLitPlane Laplacian and kernel-bias estimate", "[testing][scenes]") {
  using T = double;
  const auto scene = make_point_lit<T>();
  const T h = scene.parameters().height;
  const T intensity = scene.parameters().intensity;
  // The analytic Laplacian against the five-point stencil of the closed form, Richardson-
  // extrapolated from steps d and d/2 so its O(d^2) truncation error cancels (what is left,
  // O(d^4) and rounding ~ eps E / d^2, is below 1e-8 here).
  const auto stencil = [&](const Vec3<T>& x, T d) {
    return (scene.irradiance_at(x + Vec3<T>(d, 0, 0)) + scene.irradiance_at(x - Vec3<T>(d, 0, 0)) +
            scene.irradiance_at(x + Vec3<T>(0, d, 0)) + scene.irradiance_at(x - Vec3<T>(0, d, 0)) -
            4 * scene.irradiance_at(x)) /
           (d * d);
  };
  for (const T r : {0.0, 0.3, 0.7, 1.2, 2.0}) {
    const Vec3<T> x(r * 0.6, r * 0.8, 0);
    const T fd = (4 * stencil(x, 1e-3) - stencil(x, 2e-3)) / 3;
    CHECK(scene.irradiance_laplacian_at(x) == Approx(fd).epsilon(1e-6).margin(1e-8));
  }
  CHECK(scene.irradiance_laplacian_at(Vec3<T>(0, 0, 0)) ==
        Approx(-6 * intensity / (h * h * h * h)));

  // The exact disk-average bias of the kernel estimate, (rho / pi) (<E>_disk - E): on the axis
  // in closed form, <E> = 2 I h (1/h - 1/sqrt(h^2 + R^2)) / R^2; off the axis by quadrature.
  // The estimate (R^2/8) Delta E must match it up to the next term, O(R^4): the relative
  // residual shrinks about fourfold when R halves (a wrong coefficient leaves a constant
  // relative residual, ratio 1).
  const T k = scene.parameters().albedo / pi<T>;
  const auto exact_bias = [&](const Vec3<T>& x, T radius) {
    T mean;
    if (x.x == 0 && x.y == 0) {
      mean =
          2 * intensity * h * (1 / h - 1 / std::sqrt(h * h + radius * radius)) / (radius * radius);
    } else {
      mean = segpath::testing::integrate_2d(
                 [&](const glm::dvec2& p) {
                   return scene.irradiance_at(
                              x + Vec3<T>(p.x * std::cos(p.y), p.x * std::sin(p.y), 0)) *
                          p.x;
                 },
                 {0.0, 0.0}, {radius, 2 * pi<T>}, 4, 8) /
             (pi<T> * radius * radius);
    }
    return k * (mean - scene.irradiance_at(x));
  };
  for (const Vec3<T> x : {Vec3<T>(0, 0, 0), Vec3<T>(0.7, -0.2, 0), Vec3<T>(1.2, 0.4, 0)}) {
    const T r1 = 0.2;
    const T r2 = 0.1;
    const T residual1 = std::abs(exact_bias(x, r1) / scene.kernel_bias_estimate(x, r1) - 1);
    const T residual2 = std::abs(exact_bias(x, r2) / scene.kernel_bias_estimate(x, r2) - 1);
    INFO("x = (" << x.x << ", " << x.y << "): relative residuals " << residual1 << ", "
                 << residual2);
    CHECK(residual1 / residual2 == Approx(4).epsilon(0.1));
  }
}

TEMPLATE_TEST_CASE("PointLitPlane rejects bad parameters", "[testing][scenes]", float, double) {
  using T = TestType;
  const T nan = std::numeric_limits<T>::quiet_NaN();
  const T inf = std::numeric_limits<T>::infinity();
  const std::vector<Vec2<T>> probes{Vec2<T>(0, 0)};
  const auto make = [&](auto modify) {
    PointLitPlaneParameters<T> p;
    modify(p);
    return [p, &probes] { PointLitPlane<T>(p, probes); };
  };
  CHECK_NOTHROW(make([](auto&) {})());
  CHECK_THROWS_AS(make([&](auto& p) { p.half_size = T(0); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.half_size = inf; })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.height = -T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.height = nan; })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.intensity = -T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.intensity = inf; })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.albedo = T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.albedo = -T(0.5); })(), std::invalid_argument);
  CHECK_THROWS_AS(PointLitPlane<T>(PointLitPlaneParameters<T>{}, {Vec2<T>(3, 0)}),
                  std::invalid_argument);
  CHECK_THROWS_AS(PointLitPlane<T>(PointLitPlaneParameters<T>{}, {Vec2<T>(0, nan)}),
                  std::invalid_argument);
  CHECK_THROWS_AS(PointLitPlane<T>(PointLitPlaneParameters<T>{}, {}), std::invalid_argument);
}

// ---- DiskLitPlane ----------------------------------------------------------------------

TEMPLATE_TEST_CASE("DiskLitPlane irradiance matches quadrature over the disk", "[testing][scenes]",
                   float, double) {
  using T = TestType;
  const auto scene = make_disk_lit<T>();
  const double h = scene.parameters().height;
  const double a = scene.parameters().disk_radius;
  const double l = scene.parameters().radiance;
  // E(r0) = integral over the disk of L cos_x cos_y / d^2 = L h^2 / d^4, in polar
  // coordinates (rho, phi) about the disk centre (composite Gauss-Legendre, smooth integrand).
  const auto quadrature = [&](double r0) {
    return segpath::testing::integrate_2d(
        [&](const glm::dvec2& p) {
          const double d2 = h * h + p.x * p.x + r0 * r0 - 2 * p.x * r0 * std::cos(p.y);
          return l * h * h / (d2 * d2) * p.x;
        },
        {0.0, 0.0}, {a, 2 * pi<double>}, 16, 32);
  };
  for (const double r0 : {0.0, 0.7, 1.5}) {
    const double closed = scene.irradiance_at(Vec3<T>(T(r0), 0, 0));
    CHECK(closed == Approx(quadrature(r0)).epsilon(closed_form_tolerance<T>));
    // The textbook form (pi L / 2)(1 - (h^2 + r^2 - a^2) / Y) agrees with the stable one.
    const double y =
        std::sqrt((h * h + r0 * r0 + a * a) * (h * h + r0 * r0 + a * a) - 4 * a * a * r0 * r0);
    CHECK(closed == Approx(pi<double> * l / 2 * (1 - (h * h + r0 * r0 - a * a) / y))
                        .epsilon(closed_form_tolerance<T>));
  }
  CHECK(static_cast<double>(scene.irradiance_at(Vec3<T>(0, 0, 0))) ==
        Approx(pi<double> * l * a * a / (h * h + a * a)).epsilon(closed_form_tolerance<T>));
  // The disk depends only on the distance from the axis.
  CHECK(scene.irradiance_at(Vec3<T>(0, T(0.7), 0)) ==
        Approx(scene.irradiance_at(Vec3<T>(T(0.7), 0, 0))));
  CHECK(scene.probe_radiance(1) ==
        Approx(scene.parameters().albedo * scene.irradiance_at(Vec3<T>(T(0.7), 0, 0)) / pi<T>));
}

TEMPLATE_TEST_CASE("DiskLitPlane geometry, sampling and visibility", "[testing][scenes]", float,
                   double) {
  using T = TestType;
  const auto scene = make_disk_lit<T>();
  const T s = scene.parameters().half_size;
  const T h = scene.parameters().height;
  const T a = scene.parameters().disk_radius;
  CHECK(scene.area() == Approx(T(4) * s * s + pi<T> * a * a));
  Pcg32 rng(17, 0);
  int on_disk = 0;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const auto sample = scene.sample_area(AreaSampleQuery<T>{rng.uniform2<T>()});
    REQUIRE(sample);
    CHECK(sample->pdf == Approx(T(1) / scene.area()));
    const SurfacePoint<T>& p = sample->point;
    if (p.primitive_id == 1) {
      ++on_disk;
      CHECK((p.position.z == h &&
             p.position.x * p.position.x + p.position.y * p.position.y <= a * a * T(1.0001)));
      CHECK(p.normal == Vec3<T>(0, 0, -1));
    } else {
      CHECK((p.primitive_id == 0 && p.position.z == T(0) && std::abs(p.position.x) <= s &&
             std::abs(p.position.y) <= s));
      CHECK(p.normal == Vec3<T>(0, 0, 1));
    }
    if (i >= 200) continue;
    // Rays between the two surfaces hit what they aim at, with the normal facing them.
    const Vec3<T> origin(rng.uniform<T>() - T(0.5), rng.uniform<T>() - T(0.5),
                         h * (T(0.1) + T(0.8) * rng.uniform<T>()));
    const Ray<T> ray{origin, glm::normalize(p.position - origin)};
    const auto hit = scene.intersect(IntersectQuery<T>{ray});
    REQUIRE(hit);
    check_hit(ray, *hit);
    CHECK(hit->point.primitive_id == p.primitive_id);
    CHECK(glm::length(hit->point.position - p.position) == Approx(0).margin(1e-4));
    CHECK(scene.visible(VisibilityQuery<T>{SurfacePoint<T>::at_point(origin), p}));
  }
  // The disk's share of the area, 5 binomial standard deviations.
  const double share = pi<double> * a * a / scene.area();
  CHECK(std::abs(on_disk - n * share) < 5 * std::sqrt(n * share * (1 - share)));

  const auto under = scene.disk_point(0, 0);
  const auto ground = SurfacePoint<T>::on_surface(Vec3<T>(T(0.1), 0, 0), Vec3<T>(0, 0, 1), 0, 0);
  const auto far_ground =
      SurfacePoint<T>::on_surface(Vec3<T>(T(1.5), T(1.5), 0), Vec3<T>(0, 0, 1), 0, 0);
  CHECK(scene.visible(VisibilityQuery<T>{ground, under}));
  CHECK(scene.visible(VisibilityQuery<T>{under, ground}));
  CHECK_FALSE(scene.visible(VisibilityQuery<T>{ground, far_ground}));
  CHECK_FALSE(
      scene.visible(VisibilityQuery<T>{SurfacePoint<T>::at_point(Vec3<T>(0, 0, 2 * h)), ground}));
  CHECK(scene.visible(
      VisibilityQuery<T>{SurfacePoint<T>::at_point(Vec3<T>(a + 1, 0, 2 * h)), far_ground}));
  // Straight up from under the disk hits the disk; from beside it escapes.
  const auto up = scene.intersect(IntersectQuery<T>{Ray<T>{ground.position, Vec3<T>(0, 0, 1)}});
  REQUIRE(up);
  CHECK(up->point.primitive_id == 1);
  CHECK(up->distance == Approx(h));
  CHECK_FALSE(scene.intersect(IntersectQuery<T>{Ray<T>{far_ground.position, Vec3<T>(0, 0, 1)}}));
  // A ray leaving the disk downwards reaches the square, not the disk again.
  const auto down = scene.intersect(IntersectQuery<T>{Ray<T>{under.position, Vec3<T>(0, 0, -1)}});
  REQUIRE(down);
  CHECK(down->point.primitive_id == 0);
  for (std::uint32_t pixel = 0; pixel < 2; ++pixel) {
    const Hit<T> hit = probe_hit<T>(scene, pixel);
    CHECK(glm::length(hit.point.position - scene.probe_target(pixel)) == Approx(0).margin(1e-6));
  }
}

TEMPLATE_TEST_CASE("DiskLitPlane emitter and materials", "[testing][scenes]", float, double) {
  using T = TestType;
  const auto scene = make_disk_lit<T>();
  const auto emitter = scene.emitter();
  const auto bsdf = scene.bsdf();
  const T l = scene.parameters().radiance;
  const auto under = scene.disk_point(T(0.1), T(0.2));
  const auto ground = SurfacePoint<T>::on_surface(Vec3<T>(T(0.7), 0, 0), Vec3<T>(0, 0, 1), 0, 0);
  CHECK(emitter.radiance(EmissionQuery<T>{under, Vec3<T>(0, 0, -1)}) == l);
  CHECK(emitter.radiance(EmissionQuery<T>{under, Vec3<T>(0, 0, 1)}) == T(0));
  CHECK(emitter.radiance(EmissionQuery<T>{ground, Vec3<T>(0, 0, 1)}) == T(0));
  const Vec3<T> up(0, 0, 1);
  CHECK(bsdf.eval(BsdfQuery<T>{ground, up, up}) == Approx(scene.parameters().albedo / pi<T>));
  CHECK(bsdf.eval(BsdfQuery<T>{under, -up, -up}) == T(0));
  Pcg32 rng(19, 0);
  for (int i = 0; i < 200; ++i) {
    const auto t = emitter.sample_towards(EmitterTowardsQuery<T>{ground, rng.uniform2<T>()});
    REQUIRE(t);
    CHECK(t->pdf == Approx(T(1) / scene.disk_area()));
    CHECK(t->pdf == emitter.pdf_towards(EmitterPdfTowardsQuery<T>{ground, t->point}));
    CHECK(t->radiance == l);
    const auto e =
        emitter.sample_emission(EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>()});
    REQUIRE(e);
    const auto pdf = emitter.pdf_emission(EmissionPdfQuery<T>{e->point, e->direction});
    CHECK(pdf.position == Approx(e->pdf_position));
    CHECK(pdf.direction == Approx(e->pdf_direction).epsilon(1e-4));
    CHECK(e->direction.z < T(0));
    CHECK(emitter.radiance(EmissionQuery<T>{e->point, e->direction}) == e->radiance);
  }
  CHECK(emitter.pdf_towards(EmitterPdfTowardsQuery<T>{under, ground}) == T(0));
}

TEMPLATE_TEST_CASE("DiskLitPlane next-event estimates converge to the closed form",
                   "[testing][scenes][stat]", float, double) {
  using T = TestType;
  const auto scene = make_disk_lit<T>();
  const auto emitter = scene.emitter();
  const auto bsdf = scene.bsdf();
  const int n = 100000;
  for (std::uint32_t pixel = 0; pixel < 2; ++pixel) {
    const Hit<T> hit = probe_hit<T>(scene, pixel);
    const Vec3<T> to_sensor = -scene.sensor().probe(pixel).direction;
    RunningStats stats;
    for (int i = 0; i < n; ++i) {
      Pcg32 rng = Pcg32::for_sample(77, pixel, static_cast<std::uint64_t>(i));
      const auto ls = emitter.sample_towards(EmitterTowardsQuery<T>{hit.point, rng.uniform2<T>()});
      T value = 0;
      if (ls && scene.visible(VisibilityQuery<T>{hit.point, ls->point})) {
        const Vec3<T> to_light = glm::normalize(ls->point.position - hit.point.position);
        value = bsdf.eval(BsdfQuery<T>{hit.point, to_sensor, to_light}) *
                geometry_term(Segment<T>{hit.point, ls->point}) * ls->radiance / ls->pdf;
      }
      stats.add(value);
    }
    const double expected = scene.probe_radiance(pixel);
    INFO("pixel " << pixel << ": expected " << expected << ", got " << stats.mean() << " +- "
                  << stats.standard_error());
    CHECK_FALSE(segpath::testing::student_t_test(stats, expected).rejects(stat_alpha));
    // Power: a 1% error in the reference is detected.
    CHECK(segpath::testing::student_t_test(stats, expected * 1.01).rejects(stat_alpha));
  }
}

TEMPLATE_TEST_CASE("DiskLitPlane rejects bad parameters", "[testing][scenes]", float, double) {
  using T = TestType;
  const T nan = std::numeric_limits<T>::quiet_NaN();
  const T inf = std::numeric_limits<T>::infinity();
  const std::vector<Vec2<T>> probes{Vec2<T>(0, 0)};
  const auto make = [&](auto modify) {
    DiskLitPlaneParameters<T> p;
    modify(p);
    return [p, &probes] { DiskLitPlane<T>(p, probes); };
  };
  CHECK_NOTHROW(make([](auto&) {})());
  CHECK_THROWS_AS(make([&](auto& p) { p.half_size = -T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.height = T(0); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.height = inf; })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.disk_radius = T(0); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.disk_radius = -T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.disk_radius = nan; })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.radiance = -T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.radiance = nan; })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.albedo = T(1.5); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.albedo = T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(DiskLitPlane<T>(DiskLitPlaneParameters<T>{}, {Vec2<T>(0, 5)}),
                  std::invalid_argument);
}
