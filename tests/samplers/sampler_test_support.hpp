// Shared pieces of the sampler tests: the analytic scenes, charts that map segments to 4
// coordinates with known Jacobians, a 4D chi-square harness, fixed uniform sources and a
// point sensor with two hemispherical pixels (for the sensor bridge).
#pragma once

#include <segpath/core/geometry.hpp>
#include <segpath/testing/chi_square.hpp>
#include <segpath/testing/integrate.hpp>
#include <segpath/testing/lit_plane.hpp>
#include <segpath/testing/periodic_slab.hpp>
#include <segpath/testing/sphere_interior.hpp>
#include <segpath/testing/statistics.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <vector>

namespace sampler_test {

using namespace segpath;
namespace st = segpath::testing;

inline double chi_square_alpha() { return st::sidak_alpha(st::family_alpha, st::sampler_suite_size); }

/// Relative tolerance of "pdf(sample) == sample.pdf" per scalar type.
template <class T> inline constexpr double pdf_tolerance = sizeof(T) == sizeof(float) ? 1e-3 : 1e-5;

template <class T>
st::SphereInterior<T> make_sphere() {
  st::SphereInteriorParameters<T> p;
  p.center = {T(0.5), T(-1), T(2)};
  p.radius = T(1.5);
  p.emission_mean = T(1);
  p.emission_gradient = {T(0.3), T(-0.2), T(0.6)};
  p.albedo_mean = T(0.6);
  p.albedo_gradient = {T(-0.15), T(0.2), T(0.1)};
  return st::SphereInterior<T>(p, {{0, 0, 1}, {1, 0, 0}});
}

/// A two-pixel point sensor: pixel 0 sees the lower hemisphere (direction.z < 0), pixel 1 the
/// upper; W = 1 (cosine folded in), position probability 1, uniform hemisphere directions.
template <class T>
class HemisphereCamera {
 public:
  explicit HemisphereCamera(const Vec3<T>& p) : p_(p) {}
  [[nodiscard]] std::uint32_t pixel_count() const noexcept { return 2; }
  [[nodiscard]] std::optional<SensorSample<T>> sample_ray(const SensorSampleQuery<T>& q) const noexcept {
    if (q.pixel > 1) return std::nullopt;
    Vec3<T> d = square_to_uniform_hemisphere(q.u_direction);
    if (q.pixel == 0) d.z = -d.z;
    if (d.z == T(0)) return std::nullopt;
    return SensorSample<T>{SurfacePoint<T>::at_point(p_), d, T(1), T(1), T(1) / (T(2) * pi<T>)};
  }
  [[nodiscard]] std::optional<SensorResponse<T>> importance(const SensorQuery<T>& q) const noexcept {
    if (!mine(q)) return std::nullopt;
    return SensorResponse<T>{q.direction.z < T(0) ? 0u : 1u, T(1)};
  }
  [[nodiscard]] SensorPdf<T> pdf(const SensorQuery<T>& q) const noexcept {
    return mine(q) ? SensorPdf<T>{T(1), T(1) / (T(2) * pi<T>)} : SensorPdf<T>{};
  }

 private:
  bool mine(const SensorQuery<T>& q) const noexcept {
    return q.origin.kind == PointKind::point && q.origin.position == p_ && q.direction.z != T(0);
  }
  Vec3<T> p_;
};

/// The periodic slab (h = 1, P = 4) with a HemisphereCamera at (0.1, -0.2, 0.5).
template <class T>
class SlabWithCamera : public st::PeriodicSlab<T> {
 public:
  SlabWithCamera()
      : st::PeriodicSlab<T>(parameters(), {st::SlabProbe<T>{}}), camera_(Vec3<T>(T(0.1), T(-0.2), T(0.5))) {}
  [[nodiscard]] const HemisphereCamera<T>& sensor() const noexcept { return camera_; }

 private:
  static st::PeriodicSlabParameters<T> parameters() {
    st::PeriodicSlabParameters<T> p;
    p.height = 1;
    p.period = 4;
    p.emission_a = T(1);
    p.emission_b = T(0.5);
    p.albedo_a = T(0.7);
    p.albedo_b = T(0.4);
    return p;
  }
  HemisphereCamera<T> camera_;
};

/// `Base` with an opaque ball that only visibility queries see (intersect stays Base's): for
/// tests of density evaluation on given segments, where V(s) is the only thing that changes
/// between two scenes of this one type (samplers must be instantiated on it: `visible` is
/// not virtual). Radius 0, the default, blocks nothing. Models whatever scene concepts Base
/// models.
template <class Base>
class WithOccluder : public Base {
 public:
  using T = typename Base::Scalar;
  explicit WithOccluder(const Base& base, const Vec3<T>& centre = {}, T radius = 0)
      : Base(base), centre_(centre), radius_(radius) {}
  /// A copy with the ball moved to `centre` and resized to `radius`.
  [[nodiscard]] WithOccluder with_ball(const Vec3<T>& centre, T radius) const {
    WithOccluder out(*this);
    out.centre_ = centre;
    out.radius_ = radius;
    return out;
  }
  [[nodiscard]] bool visible(const VisibilityQuery<T>& q) const noexcept { return !blocks(q) && Base::visible(q); }
  /// Whether the ball meets the open segment from q.from to q.to (the ray, for a `direction` end).
  [[nodiscard]] bool blocks(const VisibilityQuery<T>& q) const noexcept {
    if (q.from.kind == PointKind::direction) return false;
    const glm::dvec3 o(q.from.position), c(centre_);
    const bool ray = q.to.kind == PointKind::direction;
    const glm::dvec3 d = ray ? glm::dvec3(q.to.position) : glm::dvec3(q.to.position) - o;
    const double dd = glm::dot(d, d);
    if (!(dd > 0)) return false;
    double t = glm::dot(c - o, d) / dd;
    t = std::max(t, 0.0);
    if (!ray) t = std::min(t, 1.0);
    const glm::dvec3 closest = o + t * d - c;
    return glm::dot(closest, closest) < double(radius_) * double(radius_);
  }

 private:
  Vec3<T> centre_;
  T radius_;
};

/// Uniforms all equal to `value` (0 or 1 - 2^-24: the ends of Pcg32's range).
struct FixedUniforms {
  double value = 0;
  template <class T>
  T uniform() noexcept {
    return static_cast<T>(value);
  }
};

// ---- charts: one segment end <-> 2 coordinates, with the area Jacobian dA / d(coords) ----

/// A point of the sphere by the (cos theta, phi) of its outward unit vector; dA = R^2.
/// `phi_offset` rotates the chart, so that the Gauss nodes of two charts of the same sphere
/// never coincide (x = y, where segment densities are 0).
template <class T>
struct SphereChart {
  const st::SphereInterior<T>* scene;
  double phi_offset = 0;
  [[nodiscard]] glm::dvec2 coordinates(const SurfacePoint<T>& p) const {
    const auto& q = scene->parameters();
    glm::dvec2 c = st::direction_to_cos_theta_phi(glm::dvec3((p.position - q.center) / q.radius));
    c.y -= phi_offset;
    if (c.y < 0) c.y += 2 * std::numbers::pi;
    if (!(c.y < 2 * std::numbers::pi)) c.y = 0;
    return c;
  }
  [[nodiscard]] SurfacePoint<T> point(const glm::dvec2& c) const {
    return scene->point_at(Vec3<T>(st::cos_theta_phi_to_direction({c.x, c.y + phi_offset})));
  }
  [[nodiscard]] double jacobian() const {
    const double r = double(scene->parameters().radius);
    return r * r;
  }
  static constexpr glm::dvec2 lo{-1, 0};
  static constexpr glm::dvec2 hi{1, 2 * std::numbers::pi};
};

/// A point of the disk of radius r around `center` in its plane (normal +-z), by
/// (rho^2 / r^2, phi); dA = r^2 / 2. The point keeps the centre's normal and ids.
template <class T>
struct DiskChart {
  SurfacePoint<T> center;
  double radius;
  [[nodiscard]] glm::dvec2 coordinates(const SurfacePoint<T>& p) const {
    const glm::dvec3 d(p.position - center.position);
    double phi = std::atan2(d.y, d.x);
    if (phi < 0) phi += 2 * std::numbers::pi;
    if (!(phi < 2 * std::numbers::pi)) phi = 0;
    return {(d.x * d.x + d.y * d.y) / (radius * radius), phi};
  }
  [[nodiscard]] SurfacePoint<T> point(const glm::dvec2& c) const {
    const double rho = radius * std::sqrt(c.x);
    SurfacePoint<T> p = center;
    p.position += Vec3<T>(T(rho * std::cos(c.y)), T(rho * std::sin(c.y)), T(0));
    return p;
  }
  [[nodiscard]] double jacobian() const { return radius * radius / 2; }
  static constexpr glm::dvec2 lo{0, 0};
  static constexpr glm::dvec2 hi{1, 2 * std::numbers::pi};
};

/// A 4D histogram of (coords of one end, coords of the other) tested by Pearson chi-square
/// (statistics.hpp's pooling and zero-expected hard failure). Expected counts: n times the
/// integral of the coordinate density over each cell, by nested integrate_2d (8 x 8 Gauss
/// nodes per cell and axis pair, `panels` panels).
struct Histogram4D {
  std::array<double, 4> lo, hi;
  std::array<int, 4> cells;
  std::uint64_t samples = 1'000'000;
  int panels = 1;
};

struct Report4D {
  st::ChiSquareResult result;
  std::uint64_t outside = 0, failed = 0;
  double integral = 0;
};

template <class SampleFn, class DensityFn>
Report4D chi_square_4d(SampleFn&& sample, DensityFn&& density, const Histogram4D& h, std::uint64_t seed) {
  const std::size_t total_cells = std::size_t(h.cells[0]) * h.cells[1] * h.cells[2] * h.cells[3];
  std::vector<double> observed(total_cells, 0.0), expected(total_cells, 0.0);
  auto index = [&](const std::array<int, 4>& i) {
    return ((std::size_t(i[3]) * h.cells[2] + i[2]) * h.cells[1] + i[1]) * h.cells[0] + i[0];
  };
  Report4D report;
  Pcg32 rng(seed, 0);
  for (std::uint64_t s = 0; s < h.samples; ++s) {
    const std::optional<std::array<double, 4>> c = sample(rng);
    if (!c) {
      ++report.failed;
      continue;
    }
    std::array<int, 4> i{};
    bool inside = true;
    for (int k = 0; k < 4; ++k) {
      const double t = ((*c)[k] - h.lo[k]) / (h.hi[k] - h.lo[k]);
      if (!(t >= 0 && t <= 1)) inside = false;
      i[k] = std::min(h.cells[k] - 1, int(t * h.cells[k]));
    }
    if (!inside) {
      ++report.outside;
      continue;
    }
    observed[index(i)] += 1;
  }
  const double n = double(h.samples);
  std::array<double, 4> w{};
  for (int k = 0; k < 4; ++k) w[k] = (h.hi[k] - h.lo[k]) / h.cells[k];
  std::array<int, 4> i{};
  for (i[3] = 0; i[3] < h.cells[3]; ++i[3])
    for (i[2] = 0; i[2] < h.cells[2]; ++i[2])
      for (i[1] = 0; i[1] < h.cells[1]; ++i[1])
        for (i[0] = 0; i[0] < h.cells[0]; ++i[0]) {
          std::array<double, 4> a{};
          for (int k = 0; k < 4; ++k) a[k] = h.lo[k] + w[k] * i[k];
          const double integral = st::integrate_2d(
              [&](const glm::dvec2& p) {
                return st::integrate_2d(
                    [&](const glm::dvec2& q) { return double(density(std::array<double, 4>{p.x, p.y, q.x, q.y})); },
                    {a[2], a[3]}, {a[2] + w[2], a[3] + w[3]}, h.panels, h.panels);
              },
              {a[0], a[1]}, {a[0] + w[0], a[1] + w[1]}, h.panels, h.panels);
          report.integral += integral;
          expected[index(i)] = std::isfinite(integral) ? n * std::max(integral, 0.0) : 0.0;
        }
  report.result = st::chi_square_test(observed, expected);
  if (report.outside > 0 || !std::isfinite(report.integral)) report.result.p_value = 0;
  return report;
}

/// The relative difference |a - b| / max(|a|, |b|) (0 when both are 0).
inline double relative_difference(double a, double b) {
  const double m = std::max(std::abs(a), std::abs(b));
  return m > 0 ? std::abs(a - b) / m : 0.0;
}

}  // namespace sampler_test
