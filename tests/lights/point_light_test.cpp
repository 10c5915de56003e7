#include <cmath>
#include <limits>
#include <optional>
#include <segpath/core/geometry.hpp>
#include <segpath/lights/point_light.hpp>
#include <segpath/testing/chi_square.hpp>
#include <stdexcept>

#include "support/catch.hpp"

using namespace segpath;

static_assert(SampledEmitter<PointLight<float>, float>);
static_assert(SampledEmitter<PointLight<double>, double>);
static_assert(SampledEmitter<PointLight<Rgb<float>>, Rgb<float>>);
static_assert(SampledEmitter<PointLight<Rgb<double>>, Rgb<double>>);

TEMPLATE_TEST_CASE("PointLight radiance is I at its own point and 0 elsewhere", "[lights]", float,
                   double) {
  using T = TestType;
  const Vec3<T> p(T(0.5), T(-1), T(2));
  const PointLight<Rgb<T>> light(p, Rgb<T>(1, 2, 3));
  const auto y = light.point();
  CHECK(y.kind == PointKind::point);
  CHECK(y.position == p);
  CHECK(light.radiance(EmissionQuery<T>{y, Vec3<T>(0, 0, -1)}) == Rgb<T>(1, 2, 3));
  CHECK(light.radiance(EmissionQuery<T>{y, Vec3<T>(0, 1, 0)}) == Rgb<T>(1, 2, 3));  // isotropic
  const auto elsewhere = SurfacePoint<T>::at_point(p + Vec3<T>(0, 0, T(0.25)));
  CHECK(light.radiance(EmissionQuery<T>{elsewhere, Vec3<T>(0, 0, -1)}) == Rgb<T>(0));
  const auto surface_here = SurfacePoint<T>::on_surface(p, Vec3<T>(0, 0, -1));
  CHECK(light.radiance(EmissionQuery<T>{surface_here, Vec3<T>(0, 0, -1)}) == Rgb<T>(0));
}

TEMPLATE_TEST_CASE("PointLight L_e G is the inverse-square irradiance", "[lights]", float, double) {
  using T = TestType;
  const T intensity = T(3);
  const PointLight<T> light(Vec3<T>(0, 0, 2), intensity);
  const auto x = SurfacePoint<T>::on_surface(Vec3<T>(1, 0, 0), Vec3<T>(0, 0, 1));
  const auto s = light.sample_towards(EmitterTowardsQuery<T>{x, Vec2<T>(T(0.3), T(0.7))});
  REQUIRE(s);
  CHECK(s->pdf == T(1));
  CHECK(s->point.kind == PointKind::point);
  // E = I cos / d^2 with d^2 = 5 and cos = 2 / sqrt(5).
  const T expected = intensity * (T(2) / std::sqrt(T(5))) / T(5);
  CHECK(s->radiance * geometry_term(Segment<T>{x, s->point}) / s->pdf ==
        Approx(expected).epsilon(1e-6));
  CHECK(light.pdf_towards(EmitterPdfTowardsQuery<T>{x, s->point}) == T(1));
  CHECK(light.pdf_towards(EmitterPdfTowardsQuery<T>{x, x}) == T(0));
  // A receiver at the light's own position has no direction to it.
  const auto at_light = SurfacePoint<T>::on_surface(Vec3<T>(0, 0, 2), Vec3<T>(0, 0, 1));
  CHECK_FALSE(light.sample_towards(EmitterTowardsQuery<T>{at_light, Vec2<T>(T(0.3), T(0.7))}));
}

TEMPLATE_TEST_CASE("PointLight sample_emission agrees with pdf_emission", "[lights]", float,
                   double) {
  using T = TestType;
  const PointLight<T> light(Vec3<T>(1, 2, 3), T(4));
  Pcg32 rng(7, 1);
  for (int i = 0; i < 256; ++i) {
    const auto s =
        light.sample_emission(EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>()});
    REQUIRE(s);
    CHECK(s->point.position == light.position());
    CHECK(s->point.kind == PointKind::point);
    CHECK(glm::length(s->direction) == Approx(T(1)).epsilon(1e-5));
    CHECK(s->radiance == T(4));
    CHECK(s->pdf_position == T(1));
    CHECK(s->pdf_direction == Approx(T(1) / (T(4) * pi<T>)));
    const auto pdf = light.pdf_emission(EmissionPdfQuery<T>{s->point, s->direction});
    CHECK(pdf.position == s->pdf_position);
    CHECK(pdf.direction == s->pdf_direction);
    CHECK(light.radiance(EmissionQuery<T>{s->point, -s->direction}) == s->radiance);
  }
  const auto other = SurfacePoint<T>::at_point(Vec3<T>(0, 0, 0));
  const auto pdf = light.pdf_emission(EmissionPdfQuery<T>{other, Vec3<T>(0, 0, 1)});
  CHECK(pdf.position == T(0));
  CHECK(pdf.direction == T(0));
}

TEMPLATE_TEST_CASE("PointLight rejects bad parameters", "[lights]", float, double) {
  using T = TestType;
  const T inf = std::numeric_limits<T>::infinity();
  const T nan = std::numeric_limits<T>::quiet_NaN();
  CHECK_THROWS_AS(PointLight<T>(Vec3<T>(inf, 0, 0), T(1)), std::invalid_argument);
  CHECK_THROWS_AS(PointLight<T>(Vec3<T>(0, nan, 0), T(1)), std::invalid_argument);
  CHECK_THROWS_AS(PointLight<T>(Vec3<T>(0, 0, 0), T(-1)), std::invalid_argument);
  CHECK_THROWS_AS(PointLight<T>(Vec3<T>(0, 0, 0), nan), std::invalid_argument);
  CHECK_THROWS_AS(PointLight<T>(Vec3<T>(0, 0, 0), inf), std::invalid_argument);
  CHECK_THROWS_AS(PointLight<Rgb<T>>(Vec3<T>(0, 0, 0), Rgb<T>(1, T(-0.5), 1)),
                  std::invalid_argument);
  CHECK_THROWS_AS(PointLight<Rgb<T>>(Vec3<T>(0, 0, 0), Rgb<T>(1, 1, nan)), std::invalid_argument);
  // The message names the least channel (it named the largest: "got max 1.000000").
  CHECK_THROWS_WITH(PointLight<Rgb<T>>(Vec3<T>(0, 0, 0), Rgb<T>(1, T(-1e-9), 1)), Catch::Contains("got min -1e-09"));
  CHECK_THROWS_WITH(PointLight<Rgb<T>>(Vec3<T>(0, 0, 0), Rgb<T>(1, 1, nan)), Catch::Contains("got a non-finite value"));
  CHECK_NOTHROW(PointLight<T>(Vec3<T>(0, 0, 0), T(0)));
  CHECK_NOTHROW(PointLight<Rgb<T>>(Vec3<T>(0, 0, 0), Rgb<T>(0, 1, 2)));
}

TEMPLATE_TEST_CASE("PointLight emission directions are uniform on the sphere",
                   "[lights][chi2][stat]", float, double) {
  using T = TestType;
  using namespace segpath::testing;
  const PointLight<T> light(Vec3<T>(0, 0, 0), T(1));
  ChiSquare2DConfig config;
  config.lo = {-1.0, 0.0};
  config.hi = {1.0, 2.0 * pi<double>};
  config.cells_x = 16;
  config.cells_y = 32;
  config.samples = 200'000;
  const auto uniform_pdf = [](const glm::dvec2&) { return 1.0 / (4.0 * pi<double>); };
  const double alpha = sidak_alpha(family_alpha, sampler_suite_size);

  const auto sample = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const auto s =
        light.sample_emission(EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>()});
    if (!s) return std::nullopt;
    return direction_to_cos_theta_phi(glm::dvec3(s->direction));
  };
  const auto report = chi_square_2d(sample, uniform_pdf, config, 11);
  INFO(report.table);
  CHECK(report.failed_samples == 0);
  CHECK(report.integral_of_pdf == Approx(1.0).epsilon(1e-9));
  CHECK_FALSE(report.rejects(alpha));

  // The test has power: directions folded into the upper hemisphere are rejected.
  const auto folded = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const auto s =
        light.sample_emission(EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>()});
    Vec3<T> d = s->direction;
    d.z = std::abs(d.z);
    return direction_to_cos_theta_phi(glm::dvec3(d));
  };
  CHECK(chi_square_2d(folded, uniform_pdf, config, 12).rejects(alpha));
}
