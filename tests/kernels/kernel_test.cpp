#include <segpath/concepts/kernel.hpp>
#include <segpath/kernels/dirac.hpp>
#include <segpath/kernels/disk.hpp>
#include <segpath/kernels/progressive_radius.hpp>
#include <segpath/testing/chi_square.hpp>
#include <segpath/testing/integrate.hpp>

#include "support/catch.hpp"

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

using namespace segpath;
namespace st = segpath::testing;

static_assert(Kernel<DiracKernel<float>> && Kernel<DiracKernel<double>>);
static_assert(Kernel<DiskKernel<float>> && Kernel<DiskKernel<double>>);

namespace {

/// A tilted plane through an off-origin point: the frame spans the plane, y is its centre.
template <Real T>
struct Plane {
  Vec3<T> origin{T(0.3), T(-1.2), T(2.5)};
  Vec3<T> normal = glm::normalize(Vec3<T>(T(1), T(-2), T(3)));
  Frame<T> frame = Frame<T>::from_normal(normal);

  [[nodiscard]] SurfacePoint<T> at(double u, double v) const {
    return SurfacePoint<T>::on_surface(origin + frame.tangent * T(u) + frame.bitangent * T(v),
                                       normal);
  }
  [[nodiscard]] glm::dvec2 coordinates(const Vec3<T>& p) const {
    const Vec3<T> d = p - origin;
    return {double(glm::dot(d, frame.tangent)), double(glm::dot(d, frame.bitangent))};
  }
  /// A segment arriving at the plane centre from above (x above, y = the centre).
  [[nodiscard]] Segment<T> incoming() const {
    return Segment<T>{SurfacePoint<T>::on_surface(origin + normal * T(2), -normal), at(0, 0)};
  }
  /// A segment leaving from `x`.
  [[nodiscard]] Segment<T> outgoing(const SurfacePoint<T>& x) const {
    return Segment<T>{x, SurfacePoint<T>::on_surface(x.position + normal * T(3), -normal)};
  }
};

}  // namespace

TEMPLATE_TEST_CASE("disk kernel integrates to one over a plane (N18)", "[kernels]", float, double) {
  using T = TestType;
  const Plane<T> plane;
  const DiskKernel<T> kernel(T(0.25));
  const Segment<T> from = plane.incoming();
  const auto k = [&](const glm::dvec2& p) {
    const Segment<T> to = plane.outgoing(plane.at(p.x, p.y));
    return double(kernel.eval({from, to}));
  };
  // Cartesian product rule over a square that contains the disk, panel edges not aligned with
  // the circle: the jump at the edge costs O(h) per cut panel, with signs that largely cancel.
  // 128 x 128 panels (h = 4.9e-3, 2% of r) give an error of ~4e-5, well below 1e-3.
  const double r = 0.25;
  const double integral = st::integrate_2d(k, {-1.3 * r, -1.1 * r}, {1.2 * r, 1.4 * r}, 128, 128);
  CHECK(integral == Approx(1.0).margin(1e-3));
  // A kernel normalised for a disk 1% smaller than its support is caught by the same rule.
  const DiskKernel<T> wider(T(0.2525));
  const double wrong = st::integrate_2d(
      [&](const glm::dvec2& p) {
        const Segment<T> to = plane.outgoing(plane.at(p.x, p.y));
        return double(wider.eval({from, to})) * (1.01 * 1.01);
      },
      {-1.3 * r, -1.1 * r}, {1.2 * r, 1.4 * r}, 128, 128);
  CHECK(std::abs(wrong - 1.0) > 1e-2);
}

TEMPLATE_TEST_CASE("disk kernel is zero outside its support", "[kernels]", float, double) {
  using T = TestType;
  const Plane<T> plane;
  const DiskKernel<T> kernel(T(0.25), T(0.5));
  const Segment<T> from = plane.incoming();
  const T inside = T(1) / (pi<T> * T(0.25) * T(0.25));
  const auto eval_at = [&](const SurfacePoint<T>& x) {
    return kernel.eval({from, plane.outgoing(x)});
  };
  const auto pdf_at = [&](const SurfacePoint<T>& x) {
    return kernel.pdf({from, plane.outgoing(x)});
  };

  CHECK(eval_at(plane.at(0.1, -0.1)) == Approx(inside));
  CHECK(pdf_at(plane.at(0.1, -0.1)) == Approx(inside));
  CHECK(eval_at(plane.at(0.2499, 0)) == Approx(inside));
  // Beyond r, in the plane and off it (within r of the tangent plane but not of y).
  CHECK(eval_at(plane.at(0.2501, 0)) == T(0));
  CHECK(eval_at(plane.at(0.18, 0.18)) == T(0));
  CHECK(pdf_at(plane.at(0.18, 0.18)) == T(0));
  SurfacePoint<T> above = plane.at(0.2, 0);
  above.position += plane.normal * T(0.2);
  CHECK(eval_at(above) == T(0));
  // Close, but the normal disagrees: cos = 0.4 < 0.5; and facing away.
  SurfacePoint<T> tilted = plane.at(0.05, 0.05);
  tilted.normal =
      glm::normalize(plane.normal * T(0.4) + plane.frame.tangent * T(std::sqrt(1 - 0.16)));
  CHECK(eval_at(tilted) == T(0));
  CHECK(pdf_at(tilted) == T(0));
  tilted.normal = glm::normalize(plane.normal * T(0.6) + plane.frame.tangent * T(0.8));
  CHECK(eval_at(tilted) == Approx(inside));
  SurfacePoint<T> back = plane.at(0.05, 0.05);
  back.normal = -plane.normal;
  CHECK(eval_at(back) == T(0));
  // Non-surface endpoints (a pinhole, a point light) are never in a disk support.
  CHECK(eval_at(SurfacePoint<T>::at_point(plane.origin, plane.normal)) == T(0));
  CHECK(kernel.support_radius({plane.at(0, 0)}) == T(0.25));
}

TEMPLATE_TEST_CASE("disk kernel samples lie in the support with pdf == pdf()", "[kernels]", float,
                   double) {
  using T = TestType;
  const Plane<T> plane;
  const T largest_u = T(1) - std::numeric_limits<T>::epsilon() / 2;  // largest value below 1
  for (const T radius : {T(0.25), T(1e-3)}) {
    for (const T min_cos : {T(0.5), T(1)}) {
      const DiskKernel<T> kernel(radius, min_cos);
      const Segment<T> from = plane.incoming();
      Pcg32 rng(42, 0);
      for (int i = 0; i < 2000; ++i) {
        Vec2<T> u = rng.uniform2<T>();
        if (i < 64) u.x = largest_u;  // the rim, where rounding could leave the disk
        if (i == 64) u = Vec2<T>(0, 0);
        const std::optional<KernelSample<T>> s = kernel.sample({from, u});
        REQUIRE(s);
        INFO("radius " << radius << ", min cos " << min_cos << ", u = (" << u.x << ", " << u.y
                       << ")");
        CHECK(kernel.in_support(from.y, s->point));
        CHECK(s->pdf == kernel.pdf({from, plane.outgoing(s->point)}));
        CHECK(s->pdf == kernel.eval({from, plane.outgoing(s->point)}));
        CHECK(std::abs(glm::dot(s->point.position - plane.origin, plane.normal)) <
              T(64) * std::numeric_limits<T>::epsilon());
      }
    }
  }
  // No disk around a point-like endpoint.
  const DiskKernel<T> kernel(T(0.25));
  const Segment<T> from{plane.at(1, 1), SurfacePoint<T>::at_point(plane.origin)};
  CHECK_FALSE(kernel.sample({from, Vec2<T>(T(0.5), T(0.5))}));
}

TEMPLATE_TEST_CASE("disk kernel sampling matches its pdf (chi-square)", "[kernels][stat]", float,
                   double) {
  using T = TestType;
  const Plane<T> plane;
  const double r = 0.25;
  const DiskKernel<T> kernel{T(r)};
  const Segment<T> from = plane.incoming();
  st::ChiSquare2DConfig config;
  config.lo = {-r, -r};
  config.hi = {r, r};
  config.cells_x = config.cells_y = 24;
  config.samples = 300'000;
  config.integration_panels = 16;  // the pdf jumps at the rim, inside the cells
  const auto pdf = [&](const glm::dvec2& p) {
    return double(kernel.pdf({from, plane.outgoing(plane.at(p.x, p.y))}));
  };
  const double alpha = st::sidak_alpha(st::family_alpha, st::sampler_suite_size);

  const st::ChiSquare2DReport r_ok = st::chi_square_2d(
      [&](Pcg32& rng) -> std::optional<glm::dvec2> {
        const auto s = kernel.sample({from, rng.uniform2<T>()});
        if (!s) return std::nullopt;
        return plane.coordinates(s->point.position);
      },
      pdf, config, 5);
  INFO(r_ok.table);
  CHECK_FALSE(r_ok.rejects(alpha));
  CHECK(r_ok.integral_of_pdf == Approx(1.0).margin(2e-4));

  // A wrong sampler (radius linear in u instead of sqrt(u)) is rejected by the same test.
  const st::ChiSquare2DReport r_bad = st::chi_square_2d(
      [&](Pcg32& rng) -> std::optional<glm::dvec2> {
        const Vec2<T> u = rng.uniform2<T>();
        const auto s = kernel.sample({from, Vec2<T>(u.x * u.x, u.y)});
        if (!s) return std::nullopt;
        return plane.coordinates(s->point.position);
      },
      pdf, config, 5);
  CHECK(r_bad.rejects(alpha));
}

TEMPLATE_TEST_CASE("Dirac kernel is 1 at y and 0 elsewhere", "[kernels]", float, double) {
  using T = TestType;
  const Plane<T> plane;
  const DiracKernel<T> kernel;
  const Segment<T> from = plane.incoming();
  const Segment<T> touching = plane.outgoing(from.y);
  const Segment<T> apart = plane.outgoing(plane.at(1e-3, 0));
  CHECK(kernel.eval({from, touching}) == T(1));
  CHECK(kernel.pdf({from, touching}) == T(1));
  CHECK(kernel.eval({from, apart}) == T(0));
  CHECK(kernel.pdf({from, apart}) == T(0));
  const std::optional<KernelSample<T>> s = kernel.sample({from, Vec2<T>(T(0.3), T(0.7))});
  REQUIRE(s);
  CHECK(s->point.position == from.y.position);
  CHECK(s->pdf == T(1));
  CHECK(kernel.eval({from, plane.outgoing(s->point)}) == T(1));
  CHECK(kernel.support_radius({from.y}) == T(0));
  static_assert(DiracKernel<T>::is_dirac && !DiskKernel<T>::is_dirac);
}

TEMPLATE_TEST_CASE("disk kernel rejects bad parameters", "[kernels]", float, double) {
  using T = TestType;
  const T nan = std::numeric_limits<T>::quiet_NaN();
  const T inf = std::numeric_limits<T>::infinity();
  CHECK_THROWS_AS(DiskKernel<T>(T(0)), std::invalid_argument);
  CHECK_THROWS_AS(DiskKernel<T>(T(-1)), std::invalid_argument);
  CHECK_THROWS_AS(DiskKernel<T>(nan), std::invalid_argument);
  CHECK_THROWS_AS(DiskKernel<T>(inf), std::invalid_argument);
  CHECK_THROWS_AS(DiskKernel<T>(T(1), T(1.001)), std::invalid_argument);
  CHECK_THROWS_AS(DiskKernel<T>(T(1), T(-1.001)), std::invalid_argument);
  CHECK_THROWS_AS(DiskKernel<T>(T(1), nan), std::invalid_argument);
  // r^2 below the least normal number or above the largest: eval was 0 everywhere and sample
  // nullopt (1 / (pi r^2) infinite or 0).
  CHECK_THROWS_WITH(DiskKernel<T>(std::sqrt(std::numeric_limits<T>::min()) * T(0.1)), Catch::Contains("1 / (pi r^2)"));
  CHECK_THROWS_WITH(DiskKernel<T>(std::sqrt(std::numeric_limits<T>::max()) * T(10)), Catch::Contains("1 / (pi r^2)"));
  CHECK_NOTHROW(DiskKernel<T>(std::sqrt(std::numeric_limits<T>::min()) * T(100)));
  try {
    DiskKernel<T> bad(T(-2));
    FAIL("DiskKernel accepted radius -2");
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    CHECK(message.find("DiskKernel") != std::string::npos);
    CHECK(message.find("-2") != std::string::npos);
  }
  CHECK_NOTHROW(DiskKernel<T>(T(1), T(-1)));
  CHECK_NOTHROW(DiskKernel<T>(T(1), T(1)));
}

TEMPLATE_TEST_CASE("progressive radius shrinks as r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1)",
                   "[kernels]", float, double) {
  using T = TestType;
  const ProgressiveRadius<T> schedule(T(0.5), T(0.67));
  CHECK(schedule.radius(1) == T(0.5));
  CHECK(schedule.initial_radius() == T(0.5));
  CHECK(schedule.alpha() == T(0.67));
  double r2 = 0.25;
  T previous = schedule.radius(1);
  for (std::uint64_t i = 1; i < 200; ++i) {
    r2 *= (double(i) + double(T(0.67))) / double(i + 1);
    const T next = schedule.radius(i + 1);
    CHECK(double(next) * double(next) == Approx(r2).epsilon(1e-5));
    CHECK(next < previous);
    previous = next;
  }
  // The PPM asymptote: r_i^2 ~ r_1^2 Gamma(2) / Gamma(1 + alpha) * i^(alpha - 1).
  const double asymptote = 0.25 / std::tgamma(1.67) * std::pow(1e4, 0.67 - 1);
  CHECK(double(schedule.radius(10000)) * double(schedule.radius(10000)) ==
        Approx(asymptote).epsilon(1e-3));

  CHECK_THROWS_AS(ProgressiveRadius<T>(T(0.5), T(0)), std::invalid_argument);
  CHECK_THROWS_AS(ProgressiveRadius<T>(T(0.5), T(1)), std::invalid_argument);
  CHECK_THROWS_AS(ProgressiveRadius<T>(T(0.5), T(-0.2)), std::invalid_argument);
  CHECK_THROWS_AS(ProgressiveRadius<T>(T(0.5), std::numeric_limits<T>::quiet_NaN()),
                  std::invalid_argument);
  CHECK_THROWS_AS(ProgressiveRadius<T>(T(0), T(0.5)), std::invalid_argument);
  CHECK_THROWS_AS(ProgressiveRadius<T>(T(-1), T(0.5)), std::invalid_argument);
  CHECK_THROWS_AS(ProgressiveRadius<T>(std::numeric_limits<T>::infinity(), T(0.5)),
                  std::invalid_argument);
}
