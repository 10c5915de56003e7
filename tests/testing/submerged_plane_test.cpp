// The S-D-S test scene (testing/submerged_plane.hpp): its closed forms checked against flux
// conservation and against photons traced through the library's own dielectric.
#include <segpath/core/rng.hpp>
#include <segpath/core/warp.hpp>
#include <segpath/testing/integrate.hpp>
#include <segpath/testing/statistics.hpp>
#include <segpath/testing/submerged_plane.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;
using testing::PointLitSubmergedPlane;
using testing::SubmergedPlaneParameters;
using testing::SubmergedProbe;

static_assert(LightSampledScene<PointLitSubmergedPlane<float>>);
static_assert(LightSampledScene<PointLitSubmergedPlane<double>>);

namespace {

template <Real T>
std::vector<SubmergedProbe<T>> probes() {
  return {{Vec2<T>(0, 0), T(0)}, {Vec2<T>(T(0.6), 0), T(0.5)}, {Vec2<T>(T(-0.3), T(0.5)), T(-0.4)}};
}

}  // namespace

TEST_CASE("PointLitSubmergedPlane: the irradiance integrates to the transmitted flux", "[testing][scenes]") {
  // The flux through the disk of radius R is what the light sends into the cone of rays that
  // land inside it, times the transmittance: int_0^R E 2 pi r dr = 2 pi I int_0^theta(R) T sin.
  // A wrong Jacobian (e.g. the inverse-square law along the bent ray) breaks it.
  const SubmergedPlaneParameters<double> p{2, 0.5, 1, 1.5, 2, 0.5};
  const PointLitSubmergedPlane<double> scene(p, probes<double>());
  for (const double radius : {0.3, 1.0, 1.9}) {
    const double flux = testing::integrate_1d(
        [&](double r) { return 2 * pi<double> * r * scene.irradiance_at(Vec3<double>(r, 0, 0)); }, 0, radius, 64);
    const double theta = std::asin(scene.incidence_sine(radius));
    const double emitted = 2 * pi<double> * p.intensity *
                           testing::integrate_1d([&](double t) { return scene.transmittance(std::cos(t)) * std::sin(t); }, 0, theta, 64);
    INFO("R = " << radius);
    CHECK(flux == Approx(emitted).epsilon(1e-9));
  }
  // At the foot of the light, E = I T(0) / (a + d / eta)^2, continuous.
  const double foot = p.intensity * (1 - 0.04) / std::pow(1 + 0.5 / 1.5, 2);
  CHECK(scene.irradiance_at(Vec3<double>(0, 0, 0)) == Approx(foot).epsilon(1e-12));
  CHECK(scene.irradiance_at(Vec3<double>(1e-6, 0, 0)) == Approx(foot).epsilon(1e-9));
  // The radiance: rho E / pi into the medium; a probe sees T(tilt) / eta^2 of it.
  CHECK(scene.radiance_at(Vec3<double>(0.5, 0.5, 0)) ==
        Approx(p.albedo / pi<double> * scene.irradiance_at(Vec3<double>(0.5, 0.5, 0))).epsilon(1e-15));
  CHECK(scene.probe_factor(0) == Approx(0.96 / 2.25).epsilon(1e-12));
  CHECK(scene.probe_radiance(1) == Approx(scene.probe_factor(1) * scene.radiance_at(scene.probe_target(1))).epsilon(1e-15));
}

TEMPLATE_TEST_CASE("PointLitSubmergedPlane: photons through the library's dielectric land as the closed form says",
                   "[testing][scenes][stat]", float, double) {
  using T = TestType;
  const PointLitSubmergedPlane<T> scene(SubmergedPlaneParameters<T>{}, probes<T>());
  const auto glass = scene.bsdf();
  // Rings of the square around the axis; the expected share of emitted photons landing in
  // [r0, r1) is int E 2 pi r dr / (4 pi I).
  const double rings[] = {0, 0.25, 0.6, 1.2, 1.9};
  const std::size_t n_rings = std::size(rings) - 1;
  std::vector<testing::RunningStats> share(n_rings);
  Pcg32 rng(7, 3);
  const int photons = 400000;
  for (int i = 0; i < photons; ++i) {
    std::vector<double> landed(n_rings, 0.0);
    const Vec3<T> d = square_to_uniform_sphere(rng.uniform2<T>());
    const auto at_interface = scene.intersect(IntersectQuery<T>{Ray<T>{scene.emitter().position(), d}});
    if (at_interface && at_interface->point.primitive_id == 1) {
      const auto s = glass.sample(BsdfSampleQuery<T>{at_interface->point, -d, rng.uniform2<T>(), rng.uniform<T>(),
                                                     Transport::importance});
      if (s && s->direction.z < T(0)) {
        // Flux carried: value |cos| / pdf = 1 for an importance refraction.
        const T carried = s->value * std::abs(s->direction.z) / s->pdf;
        const auto at_square = scene.intersect(IntersectQuery<T>{Ray<T>{at_interface->point.position, s->direction}});
        if (at_square && at_square->point.primitive_id == 0) {
          const double r = std::hypot(double(at_square->point.position.x), double(at_square->point.position.y));
          for (std::size_t k = 0; k < n_rings; ++k)
            if (r >= rings[k] && r < rings[k + 1]) landed[k] = double(carried);
        }
      }
    }
    for (std::size_t k = 0; k < n_rings; ++k) share[k].add(landed[k]);
  }
  const double alpha = testing::sidak_alpha(0.01, 2 * n_rings);
  for (std::size_t k = 0; k < n_rings; ++k) {
    const double expected = testing::integrate_1d(
                                [&](double r) { return 2 * pi<double> * r * scene.irradiance_at(Vec3<T>(T(r), 0, 0)); }, rings[k],
                                rings[k + 1], 32) /
                            (4 * pi<double> * double(scene.parameters().intensity));
    INFO("ring " << rings[k] << " - " << rings[k + 1] << ": " << share[k].mean() << " +- " << share[k].standard_error() << " vs "
                 << expected);
    CHECK_FALSE(testing::student_t_test(share[k], expected).rejects(alpha));
    // Leaving the Jacobian out (E = I T cos_t / l^2 along the bent ray of length l) is 10-20 % off.
    CHECK(share[k].standard_error() < 0.02 * expected);
  }
}

TEMPLATE_TEST_CASE("PointLitSubmergedPlane: probes see their targets through the interface", "[testing][scenes]", float,
                   double) {
  using T = TestType;
  const PointLitSubmergedPlane<T> scene(SubmergedPlaneParameters<T>{}, probes<T>());
  const auto materials = scene.bsdf();
  for (std::uint32_t pixel = 0; pixel < scene.sensor().pixel_count(); ++pixel) {
    const Ray<T>& probe = scene.sensor().probe(pixel);
    const auto at_interface = scene.intersect(IntersectQuery<T>{probe});
    REQUIRE(at_interface);
    CHECK(at_interface->point.primitive_id == 1);
    CHECK_FALSE(materials.lambertian_albedo(at_interface->point).has_value());
    // u_lobe = 1: refraction. In radiance transport its coefficient is 1 / eta^2.
    const auto s = materials.sample(BsdfSampleQuery<T>{at_interface->point, -probe.direction, Vec2<T>(T(0.5)), T(1), Transport::radiance});
    REQUIRE(s);
    CHECK(double(s->pdf) == Approx(scene.transmittance(std::cos(double(probes<T>()[pixel].tilt)))).epsilon(1e-5));
    CHECK(double(s->value * std::abs(s->direction.z) / s->pdf) == Approx(1 / 2.25).epsilon(1e-5));
    const auto at_square = scene.intersect(IntersectQuery<T>{Ray<T>{at_interface->point.position, s->direction}});
    REQUIRE(at_square);
    CHECK(at_square->point.primitive_id == 0);
    CHECK(materials.lambertian_albedo(at_square->point) == scene.parameters().albedo);
    const Vec3<T> target = scene.probe_target(pixel);
    CHECK(double(glm::length(at_square->point.position - target)) < 1e-5);
  }
}

TEMPLATE_TEST_CASE("PointLitSubmergedPlane: visibility and area sampling", "[testing][scenes]", float, double) {
  using T = TestType;
  const PointLitSubmergedPlane<T> scene(SubmergedPlaneParameters<T>{}, probes<T>());
  const auto light = scene.emitter().point();
  const auto on_square = SurfacePoint<T>::on_surface(Vec3<T>(T(0.3), 0, 0), Vec3<T>(0, 0, 1), 0, 0);
  const auto below = SurfacePoint<T>::at_point(Vec3<T>(0, 0, T(0.2)));
  const auto above = SurfacePoint<T>::at_point(Vec3<T>(T(0.5), 0, T(0.8)));
  CHECK_FALSE(scene.visible(VisibilityQuery<T>{on_square, light}));  // the interface is in the way
  CHECK(scene.visible(VisibilityQuery<T>{on_square, below}));
  CHECK(scene.visible(VisibilityQuery<T>{above, light}));
  CHECK(scene.area() == Approx(T(80)));
  Pcg32 rng(3, 1);
  int on_interface = 0;
  for (int i = 0; i < 2000; ++i) {
    const auto a = scene.sample_area(AreaSampleQuery<T>{rng.uniform2<T>()});
    REQUIRE(a);
    CHECK(a->pdf == Approx(T(1) / scene.area()));
    on_interface += a->point.primitive_id == 1;
  }
  CHECK(on_interface > 1500);  // 80 % of the area
  CHECK(on_interface < 1700);
}

TEMPLATE_TEST_CASE("PointLitSubmergedPlane rejects bad parameters", "[testing][scenes]", float, double) {
  using T = TestType;
  const T nan = std::numeric_limits<T>::quiet_NaN();
  const auto make = [&](auto modify) {
    SubmergedPlaneParameters<T> p;
    modify(p);
    return [p] { PointLitSubmergedPlane<T>(p, probes<T>()); };
  };
  CHECK_NOTHROW(make([](auto&) {})());
  CHECK_THROWS_AS(make([&](auto& p) { p.depth = T(0); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.light_height = nan; })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.eta = -T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.albedo = T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(make([&](auto& p) { p.intensity = -T(1); })(), std::invalid_argument);
  CHECK_THROWS_AS(PointLitSubmergedPlane<T>(SubmergedPlaneParameters<T>{}, {}), std::invalid_argument);
  CHECK_THROWS_AS(PointLitSubmergedPlane<T>(SubmergedPlaneParameters<T>{}, {{Vec2<T>(3, 0), T(0)}}), std::invalid_argument);
  CHECK_THROWS_AS(PointLitSubmergedPlane<T>(SubmergedPlaneParameters<T>{}, {{Vec2<T>(0, 0), T(1.6)}}), std::invalid_argument);
}
