// Tests of PinholeCamera: the cornell-box ray formula, sampling against its densities,
// W cos / (p p) = 1, the direction -> pixel inverse, normalisation of W, bad input.
#include <algorithm>
#include <array>
#include <cmath>
#include <glm/common.hpp>
#include <glm/vector_relational.hpp>
#include <limits>
#include <optional>
#include <segpath/core/rng.hpp>
#include <segpath/core/warp.hpp>
#include <segpath/sensors/pinhole_camera.hpp>
#include <segpath/testing/chi_square.hpp>
#include <segpath/testing/integrate.hpp>
#include <segpath/testing/statistics.hpp>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "support/catch.hpp"

using namespace segpath;

static_assert(Sensor<PinholeCamera<float>, float>);
static_assert(Sensor<PinholeCamera<double>, double>);

namespace {

const double alpha = testing::sidak_alpha(testing::family_alpha, testing::sampler_suite_size);

/// A small wide-angle camera where cos^3 varies strongly inside a pixel.
template <class T>
PinholeCamera<T> wide_camera(std::uint32_t width, std::uint32_t height) {
  PinholeCameraParameters<T> p;
  p.position = Vec3<T>(1, 2, 3);
  p.forward = glm::normalize(Vec3<T>(1, 1, 0));
  p.right = glm::normalize(Vec3<T>(1, -1, 0));
  p.up = Vec3<T>(0, 0, 1);
  p.width = width;
  p.height = height;
  p.fov_x_degrees = T(140);
  p.fov_y_degrees = T(100);
  return PinholeCamera<T>(p);
}

/// Image-plane coordinates (a, b) of a direction: the point F + a R + b U it passes through.
template <class T>
glm::dvec2 plane_coordinates(const PinholeCamera<T>& c, const Vec3<T>& w) {
  const glm::dvec3 d(w);
  const double z = glm::dot(d, glm::dvec3(c.forward()));
  return {glm::dot(d, glm::dvec3(c.right())) / z, glm::dot(d, glm::dvec3(c.up())) / z};
}

/// The direction through image-plane point (a, b) and the Jacobian d omega / dA = 1 / |p|^3.
template <class T>
std::pair<Vec3<T>, double> plane_direction(const PinholeCamera<T>& c, const glm::dvec2& ab) {
  const glm::dvec3 p =
      glm::dvec3(c.forward()) + glm::dvec3(c.right()) * ab.x + glm::dvec3(c.up()) * ab.y;
  const double len = glm::length(p);
  return {Vec3<T>(p / len), 1.0 / (len * len * len)};
}

}  // namespace

TEMPLATE_TEST_CASE("PinholeCamera: the cornell camera's rays follow cornell-boxes.md", "[sensors]",
                   float, double) {
  using T = TestType;
  const auto camera = cornell_camera<T>(512, 512);
  CHECK(camera.pixel_count() == 512u * 512u);
  const double t = std::tan(pi<double> / 8);
  CHECK(double(camera.tan_half_fov_x()) == Approx(t).epsilon(1e-6));
  CHECK(double(camera.tan_half_fov_y()) == Approx(t).epsilon(1e-6));
  const glm::dvec3 f(0.006886253, 0.9985055, -0.05421613), r(0.9999762, -0.006896396, 0),
      u(0.0003738963, 0.05421484, 0.9985293);
  Pcg32 rng(1, 0);
  for (int i = 0; i < 1000; ++i) {
    const std::uint32_t x = rng.next_u32() % 512, y = rng.next_u32() % 512;
    const Vec2<T> jitter = rng.uniform2<T>();
    const auto s = camera.sample_ray(SensorSampleQuery<T>{y * 512 + x, rng.uniform2<T>(), jitter});
    REQUIRE(s);
    const glm::dvec3 expected = glm::normalize(f + (2 * (x + double(jitter.x)) / 512 - 1) * t * r +
                                               (1 - 2 * (y + double(jitter.y)) / 512) * t * u);
    CHECK(glm::length(glm::dvec3(s->direction) - expected) < 1e-5);
    CHECK(s->origin.kind == PointKind::point);
    CHECK(s->origin.position == Vec3<T>(T(-0.0439815), T(-4.12529), T(0.222539)));
  }
  // Row 0 is at the top: pixel 0 looks up and to the left.
  const auto top_left = camera.sample_ray(SensorSampleQuery<T>{0, Vec2<T>(0), Vec2<T>(T(0.5))});
  REQUIRE(top_left);
  CHECK(glm::dot(glm::dvec3(top_left->direction), u) > 0.3);
  CHECK(glm::dot(glm::dvec3(top_left->direction), r) < -0.3);
  CHECK_FALSE(camera.sample_ray(SensorSampleQuery<T>{512 * 512, Vec2<T>(0), Vec2<T>(0)}));
  // Square pixels for other aspect ratios (SmallVCM fixes the horizontal angle).
  const auto wide = cornell_camera<T>(600, 300);
  CHECK(double(wide.tan_half_fov_x()) == Approx(t).epsilon(1e-6));
  CHECK(double(wide.tan_half_fov_y()) == Approx(t / 2).epsilon(1e-6));
}

TEMPLATE_TEST_CASE("PinholeCamera: importance and pdf invert sample_ray, W cos / (p p) = 1",
                   "[sensors]", float, double) {
  using T = TestType;
  const auto cornell = cornell_camera<T>(512, 512);
  const auto wide = wide_camera<T>(7, 5);
  // Within `edge` of a pixel boundary (in pixels) rounding may move the ray to the neighbour.
  const T edge = std::is_same_v<T, float> ? T(2e-3) : T(1e-9);
  Pcg32 rng(2, 0);
  for (const auto* camera : {&cornell, &wide}) {
    for (int i = 0; i < 20000; ++i) {
      const std::uint32_t pixel = rng.next_u32() % camera->pixel_count();
      const Vec2<T> jitter = rng.uniform2<T>();
      const auto s = camera->sample_ray(SensorSampleQuery<T>{pixel, rng.uniform2<T>(), jitter});
      REQUIRE(s);
      CHECK(s->pdf_position == T(1));
      CHECK(s->importance * T(1) / (s->pdf_position * s->pdf_direction) ==
            Approx(1.0).epsilon(1e-6));
      CHECK(glm::length(s->direction) == Approx(1.0).epsilon(1e-5));
      const auto raster = camera->raster_position(s->direction);
      const double px = pixel % camera->width() + double(jitter.x),
                   py = pixel / camera->width() + double(jitter.y);
      const bool near_edge =
          std::min({jitter.x, jitter.y, T(1) - jitter.x, T(1) - jitter.y}) < edge;
      if (near_edge) continue;
      REQUIRE(raster);
      CHECK(std::abs(raster->x - px) < 1e-3);
      CHECK(std::abs(raster->y - py) < 1e-3);
      const SensorQuery<T> q{s->origin, s->direction};
      const auto response = camera->importance(q);
      REQUIRE(response);
      CHECK(response->pixel == pixel);
      CHECK(response->importance == Approx(s->importance).epsilon(1e-5));
      const SensorPdf<T> pdf = camera->pdf(q);
      CHECK(pdf.position == s->pdf_position);
      CHECK(pdf.direction == Approx(s->pdf_direction).epsilon(1e-5));
    }
  }
  // Behind the camera, outside the image, or from another origin: no response.
  const auto x1 = cornell.point();
  CHECK_FALSE(cornell.importance(SensorQuery<T>{x1, -cornell.forward()}));
  CHECK_FALSE(cornell.importance(SensorQuery<T>{x1, cornell.right()}));
  CHECK_FALSE(cornell.importance(
      SensorQuery<T>{x1, glm::normalize(cornell.forward() + cornell.up())}));  // 45 deg up
  CHECK(cornell.importance(
      SensorQuery<T>{x1, glm::normalize(cornell.forward() + T(0.4) * cornell.up())}));
  const auto elsewhere = SurfacePoint<T>::at_point(cornell.position() + Vec3<T>(0, 0, T(0.01)));
  CHECK_FALSE(cornell.importance(SensorQuery<T>{elsewhere, cornell.forward()}));
  const auto on_surface = SurfacePoint<T>::on_surface(cornell.position(), cornell.forward());
  CHECK_FALSE(cornell.importance(SensorQuery<T>{on_surface, cornell.forward()}));
  CHECK(cornell.pdf(SensorQuery<T>{x1, -cornell.forward()}).direction == T(0));
  CHECK(cornell.pdf(SensorQuery<T>{elsewhere, cornell.forward()}).position == T(0));
  const T nan = std::numeric_limits<T>::quiet_NaN();
  CHECK_FALSE(cornell.importance(SensorQuery<T>{x1, Vec3<T>(nan, 0, 0)}));
}

TEMPLATE_TEST_CASE("PinholeCamera: W_rho integrates to 1 over each pixel's directions", "[sensors]",
                   float, double) {
  using T = TestType;
  const auto wide = wide_camera<T>(3, 2);
  const auto cornell = cornell_camera<T>(512, 512);
  for (const auto* camera : {&wide, &cornell}) {
    const double tx = double(camera->tan_half_fov_x()), ty = double(camera->tan_half_fov_y());
    const double w = double(camera->width()), h = double(camera->height());
    for (std::uint32_t pixel : {0u, 1u, camera->pixel_count() / 2, camera->pixel_count() - 1}) {
      const double x = pixel % camera->width(), y = pixel / camera->width();
      // The pixel's image-plane rectangle (a grows with x, b falls with y).
      const glm::dvec2 lo((2 * x / w - 1) * tx, (1 - 2 * (y + 1) / h) * ty);
      const glm::dvec2 hi((2 * (x + 1) / w - 1) * tx, (1 - 2 * y / h) * ty);
      const double total = testing::integrate_2d(
          [&](const glm::dvec2& ab) {
            const auto [d, jacobian] = plane_direction(*camera, ab);
            const auto r = camera->importance(SensorQuery<T>{camera->point(), d});
            return r && r->pixel == pixel ? double(r->importance) * jacobian : 0.0;
          },
          lo, hi, 2, 2);
      CHECK(total == Approx(1.0).epsilon(1e-5));
    }
  }
}

TEMPLATE_TEST_CASE("PinholeCamera: light-tracing estimate of each pixel's integral of W is 1",
                   "[sensors][stat]", float, double) {
  using T = TestType;
  // Directions uniform on the sphere; for each pixel, W / p_uniform where the ray lands in it.
  const auto camera = wide_camera<T>(3, 2);
  std::array<testing::RunningStats, 6> per_pixel;
  Pcg32 rng(3, 0);
  for (int i = 0; i < 200000; ++i) {
    const Vec3<T> d = square_to_uniform_sphere(rng.uniform2<T>());
    const auto r = camera.importance(SensorQuery<T>{camera.point(), d});
    for (std::uint32_t p = 0; p < 6; ++p)
      per_pixel[p].add(r && r->pixel == p ? double(r->importance) * 4 * pi<double> : 0.0);
  }
  for (std::uint32_t p = 0; p < 6; ++p) {
    INFO("pixel " << p << ": " << per_pixel[p].mean() << " +- " << per_pixel[p].standard_error());
    CHECK_FALSE(testing::student_t_test(per_pixel[p], 1.0).rejects(testing::sidak_alpha(0.01, 6)));
  }
}

TEMPLATE_TEST_CASE("PinholeCamera: sampled directions match pdf()", "[sensors][chi2][stat]", float,
                   double) {
  using T = TestType;
  using namespace segpath::testing;
  // One pixel covering the whole wide image: the solid-angle density varies by cos^3.
  const auto camera = wide_camera<T>(1, 1);
  const double tx = double(camera.tan_half_fov_x()), ty = double(camera.tan_half_fov_y());
  ChiSquare2DConfig config;
  config.lo = {-tx, -ty};
  config.hi = {tx, ty};
  // Image-plane density = solid-angle pdf times d omega / dA = 1 / |p|^3.
  const auto pdf = [&](const glm::dvec2& ab) {
    const auto [d, jacobian] = plane_direction(camera, ab);
    return double(camera.pdf(SensorQuery<T>{camera.point(), d}).direction) * jacobian;
  };
  const auto sample = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const auto s = camera.sample_ray(SensorSampleQuery<T>{0, rng.uniform2<T>(), rng.uniform2<T>()});
    if (!s) return std::nullopt;
    return plane_coordinates(camera, s->direction);
  };
  const auto report = chi_square_2d(sample, pdf, config, 91);
  INFO(report.table);
  CHECK(report.failed_samples == 0);
  CHECK(report.integral_of_pdf == Approx(1.0).epsilon(1e-6));
  CHECK_FALSE(report.rejects(alpha));

  // A pixel of the cornell camera, on its own image-plane rectangle.
  const auto cornell = cornell_camera<T>(512, 512);
  const std::uint32_t x = 3, y = 500;
  const double t = double(cornell.tan_half_fov_x());
  ChiSquare2DConfig pixel_config;
  pixel_config.lo = {(2.0 * x / 512 - 1) * t, (1 - 2.0 * (y + 1) / 512) * t};
  pixel_config.hi = {(2.0 * (x + 1) / 512 - 1) * t, (1 - 2.0 * y / 512) * t};
  pixel_config.cells_x = pixel_config.cells_y = 16;
  const auto pixel_pdf = [&](const glm::dvec2& ab) {
    const auto [d, jacobian] = plane_direction(cornell, ab);
    return double(cornell.pdf(SensorQuery<T>{cornell.point(), d}).direction) * jacobian;
  };
  const auto pixel_sample = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const auto s =
        cornell.sample_ray(SensorSampleQuery<T>{y * 512 + x, rng.uniform2<T>(), rng.uniform2<T>()});
    if (!s) return std::nullopt;
    const glm::dvec2 ab = plane_coordinates(cornell, s->direction);
    // Rounding of a float direction may step a hair (< 1e-3 pixel) outside the rectangle;
    // anything farther stays outside the domain, a hard failure.
    const glm::dvec2 slack = 1e-3 * (pixel_config.hi - pixel_config.lo);
    const glm::dvec2 clamped = glm::clamp(ab, pixel_config.lo, pixel_config.hi);
    return glm::all(glm::lessThanEqual(glm::abs(ab - clamped), slack)) ? clamped : ab;
  };
  const auto pixel_report = chi_square_2d(pixel_sample, pixel_pdf, pixel_config, 92);
  INFO(pixel_report.table);
  CHECK(pixel_report.integral_of_pdf == Approx(1.0).epsilon(1e-5));
  CHECK_FALSE(pixel_report.rejects(alpha));

  // Power: directions uniform in angle (not in image-plane area) are rejected.
  const auto angular = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const glm::dvec2 u = rng.uniform2<double>();
    const double ax = std::atan(tx) * (2 * u.x - 1), ay = std::atan(ty) * (2 * u.y - 1);
    return glm::dvec2(std::tan(ax), std::tan(ay));
  };
  ChiSquare2DConfig small = config;
  small.samples = 20000;
  CHECK(chi_square_2d(angular, pdf, small, 93).rejects(alpha));
}

TEMPLATE_TEST_CASE("PinholeCamera: extreme jitters give finite rays inside their pixel",
                   "[sensors]", float, double) {
  using T = TestType;
  const auto camera = cornell_camera<T>(512, 512);
  const std::array<T, 2> extremes{T(0), T(1) - T(0x1p-24)};
  for (std::uint32_t pixel : {0u, 511u, 512u * 511u, 512u * 512u - 1u})
    for (T a : extremes)
      for (T b : extremes) {
        const auto s = camera.sample_ray(SensorSampleQuery<T>{pixel, Vec2<T>(a, b), Vec2<T>(a, b)});
        REQUIRE(s);
        CHECK(is_finite(s->direction));
        CHECK(std::isfinite(s->pdf_direction));
        CHECK(s->pdf_direction > T(0));
        CHECK(std::isfinite(s->importance));
      }
}

TEMPLATE_TEST_CASE("PinholeCamera rejects bad parameters", "[sensors]", float, double) {
  using T = TestType;
  const T nan = std::numeric_limits<T>::quiet_NaN();
  PinholeCameraParameters<T> good;
  good.width = 4;
  good.height = 3;
  CHECK_NOTHROW(PinholeCamera<T>(good));
  const auto rejects = [&](auto change) {
    PinholeCameraParameters<T> p = good;
    change(p);
    CHECK_THROWS_AS(PinholeCamera<T>(p), std::invalid_argument);
  };
  rejects([](auto& p) { p.width = 0; });
  rejects([](auto& p) { p.height = 0; });
  rejects([](auto& p) { p.width = p.height = 70000; });
  rejects([](auto& p) { p.fov_x_degrees = 0; });
  rejects([](auto& p) { p.fov_y_degrees = 180; });
  rejects([](auto& p) { p.fov_x_degrees = -30; });
  rejects([nan](auto& p) { p.fov_y_degrees = nan; });
  rejects([](auto& p) { p.forward = Vec3<T>(0, 2, 0); });  // not unit
  rejects([](auto& p) {
    p.right = glm::normalize(Vec3<T>(1, T(0.1), 0));
  });                                                                 // not orthogonal to forward
  rejects([](auto& p) { p.up = Vec3<T>(0, 1, 0); });                  // parallel to forward
  rejects([](auto& p) { p.up = glm::normalize(Vec3<T>(1, 0, 1)); });  // not orthogonal to right
  rejects([nan](auto& p) { p.position.x = nan; });
  rejects([nan](auto& p) { p.forward.y = nan; });
  // So narrow that a pixel's area is 0 in T (an infinite inverse): every ray was dropped by
  // sample_ray, a black image with nothing counted.
  rejects([](auto& p) { p.fov_x_degrees = p.fov_y_degrees = std::numeric_limits<T>::min(); });
  try {
    PinholeCameraParameters<T> p = good;
    p.fov_x_degrees = p.fov_y_degrees = std::numeric_limits<T>::min();
    (void)PinholeCamera<T>(p);
  } catch (const std::invalid_argument& e) {
    CHECK_THAT(e.what(), Catch::Contains("too narrow for 4 x 3 pixels"));
  }
  PinholeCameraParameters<T> narrow = good;
  narrow.fov_x_degrees = narrow.fov_y_degrees = T(1e-3);
  CHECK_NOTHROW(PinholeCamera<T>(narrow));
  CHECK_NOTHROW(cornell_camera<T>(512, 512));
  CHECK_THROWS_AS(cornell_camera<T>(0, 512), std::invalid_argument);
}
