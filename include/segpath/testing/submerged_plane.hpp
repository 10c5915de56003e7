// Analytic scene for S-D-S transport: a Lambertian square under a flat dielectric interface,
// lit by a point light above the interface and seen from above through it. Closed-form
// radiance from Snell's law, the flat interface's Jacobian and Fresnel (SPEC section 2).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "segpath/concepts/scene.hpp"
#include "segpath/lights/point_light.hpp"
#include "segpath/materials/dielectric.hpp"
#include "segpath/materials/lambertian.hpp"
#include "segpath/sensors/probe.hpp"
#include "segpath/testing/integrate.hpp"
#include "segpath/testing/lit_plane.hpp"

namespace segpath::testing {

template <Real T>
struct SubmergedPlaneParameters {
  T half_size = 2;        ///< the Lambertian square is |x|, |y| <= half_size at z = 0
  T depth = T(0.5);       ///< d: the interface is the plane z = d (index eta below, 1 above)
  T light_height = 1;     ///< a: the point light is at (0, 0, d + a)
  T eta = T(1.5);         ///< the index below the interface (the medium the square lies in)
  T intensity = 1;        ///< I in W/sr
  T albedo = T(0.5);      ///< rho of the square
};

/// A probe looking at the square point (target.x, target.y, 0) through the interface; its
/// ray leaves the interface upwards at the polar angle `tilt` (radians, |tilt| < pi / 2),
/// tilted in the xz-plane, so the probe sees the target along a refracted ray. Its origin is
/// light_height / 2 above the interface.
template <Real T>
struct SubmergedProbe {
  Vec2<T> target{0, 0};
  T tilt = 0;
};

/// The scene; it models Scene with scalar spectra. M is the square (primitive and material
/// id 0, Lambertian, normal +z) plus the interface, a square of twice the half size at z = d
/// (id 1, Dielectric with the outside above: normal +z). The light is a `point` end.
///
/// Which paths carry light: the only path of at most four segments is
/// probe -> interface (refraction) -> square -> interface (refraction) -> light, the S-D-S
/// family vertex methods cannot sample (no connection can reach a point light through a
/// delta interface). Longer paths add internal reflections; the closed forms below are for
/// estimators limited to four segments (max_length = 4), whose expectation they are.
///
/// The irradiance of the square: a ray leaving the light at polar angle theta refracts to
/// theta_t (sin theta = eta sin theta_t) and meets z = 0 at r(theta) = a tan theta + d tan
/// theta_t. Flux conservation over the ring it sweeps gives
///   E(r) = I T(theta) sin theta / (r dr/dtheta),
///   dr/dtheta = a / cos^2 theta + d cos theta / (eta cos^3 theta_t),
/// T = 1 - F the Fresnel transmittance; at r = 0, E = I T(0) / (a + d / eta)^2. The square
/// reflects L = rho E / pi into the medium, and a probe whose ray leaves the interface at
/// `tilt` measures T(tilt) L / eta^2 (radiance / n^2 is invariant across the interface).
template <Real T>
class PointLitSubmergedPlane {
 public:
  using Scalar = T;
  using Spectrum = T;

  PointLitSubmergedPlane(const SubmergedPlaneParameters<T>& p, const std::vector<SubmergedProbe<T>>& probes)
      : p_(validated(p)),
        square_{p_.half_size},
        light_(Vec3<T>(0, 0, p_.depth + p_.light_height), p_.intensity),
        glass_(p_.eta),
        probes_(probes),
        sensor_(probe_rays(p_, probes)) {}

  // ---- closed forms (computed in double) -------------------------------------------------
  /// The unpolarised Fresnel transmittance 1 - (R_s + R_p) / 2 of the interface for a ray
  /// meeting it from above at cos_theta (the same from below along the refracted ray).
  [[nodiscard]] double transmittance(double cos_theta) const noexcept {
    const double n = double(p_.eta);
    const double sin2_t = (1 - cos_theta * cos_theta) / (n * n);
    const double cos_t = std::sqrt(std::max(0.0, 1 - sin2_t));
    const double r_s = (cos_theta - n * cos_t) / (cos_theta + n * cos_t);
    const double r_p = (n * cos_theta - cos_t) / (n * cos_theta + cos_t);
    return 1 - 0.5 * (r_s * r_s + r_p * r_p);
  }

  /// sin theta of the light ray that lands at distance r from the axis (bisection on the
  /// monotone r(theta)).
  [[nodiscard]] double incidence_sine(double r) const noexcept {
    double lo = 0, hi = 1;
    for (int i = 0; i < 200 && hi - lo > 1e-16; ++i) {
      const double mid = 0.5 * (lo + hi);
      (landing_radius(mid) < r ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  }

  /// E at the square point x (only x.x, x.y are used).
  [[nodiscard]] double irradiance_at(const Vec3<T>& x) const noexcept {
    const double a = double(p_.light_height), d = double(p_.depth), n = double(p_.eta);
    const double r = std::hypot(double(x.x), double(x.y));
    if (r < 1e-12) return double(p_.intensity) * transmittance(1) / ((a + d / n) * (a + d / n));
    const double s = incidence_sine(r);
    const double c = std::sqrt(1 - s * s);
    const double c_t = std::sqrt(1 - s * s / (n * n));
    const double dr = a / (c * c) + d * c / (n * c_t * c_t * c_t);
    return double(p_.intensity) * transmittance(c) * s / (r * dr);
  }
  /// L = rho E / pi, the square's radiance into the medium.
  [[nodiscard]] double radiance_at(const Vec3<T>& x) const noexcept {
    return double(p_.albedo) * irradiance_at(x) / pi<double>;
  }
  /// What probe `pixel` measures: T(tilt) L(target) / eta^2.
  [[nodiscard]] double probe_radiance(std::uint32_t pixel) const noexcept {
    return probe_factor(pixel) * radiance_at(probe_target(pixel));
  }
  /// T(tilt) / eta^2: probe_radiance = probe_factor radiance_at(target).
  [[nodiscard]] double probe_factor(std::uint32_t pixel) const noexcept {
    const double n = double(p_.eta);
    return transmittance(std::cos(double(probes_[pixel].tilt))) / (n * n);
  }
  [[nodiscard]] Vec3<T> probe_target(std::uint32_t pixel) const noexcept {
    return Vec3<T>(probes_[pixel].target.x, probes_[pixel].target.y, 0);
  }

  /// The expectation of a uniform disk kernel of `radius` around x in the square's plane
  /// (VCM's merging, PPM): the disk average of L.
  [[nodiscard]] double disk_average_radiance(const Vec3<T>& x, double radius) const {
    const double sum = integrate_2d(
        [&](glm::dvec2 q) {
          const Vec3<T> y(T(double(x.x) + q.x * std::cos(q.y)), T(double(x.y) + q.x * std::sin(q.y)), 0);
          return q.x * radiance_at(y);
        },
        glm::dvec2(0, 0), glm::dvec2(radius, 2 * pi<double>), 8, 16);
    return sum / (pi<double> * radius * radius);
  }
  /// The expectation of a voxel kernel of side `cell` over a uniformly jittered grid: the
  /// cell average of L, averaged over the offset, is L weighted by the tent
  /// (1 - |u| / h)(1 - |v| / h) / h^2 on [-h, h]^2.
  [[nodiscard]] double voxel_average_radiance(const Vec3<T>& x, double cell) const {
    return integrate_2d(
        [&](glm::dvec2 u) {
          const double w = (1 - std::abs(u.x) / cell) * (1 - std::abs(u.y) / cell) / (cell * cell);
          return w * radiance_at(Vec3<T>(T(double(x.x) + u.x), T(double(x.y) + u.y), 0));
        },
        glm::dvec2(-cell, -cell), glm::dvec2(cell, cell), 8, 8);  // even panels: a boundary on the kink
  }
  [[nodiscard]] const SubmergedPlaneParameters<T>& parameters() const noexcept { return p_; }

  // ---- Manifold ----------------------------------------------------------------------
  [[nodiscard]] T area() const noexcept { return square_.area() + interface_area(); }
  [[nodiscard]] T interface_half_size() const noexcept { return T(2) * p_.half_size; }
  [[nodiscard]] T interface_area() const noexcept { return T(4) * square_.area(); }

  /// Picks the square or the interface with probability proportional to its area (by u.x),
  /// then a uniform point of it.
  [[nodiscard]] std::optional<AreaSample<T>> sample_area(const AreaSampleQuery<T>& q) const noexcept {
    return detail::sample_square_or_level(square_, q.u, area(), [this](const Vec2<T>& u) {
      const T s = interface_half_size();
      return interface_point((T(2) * u.x - T(1)) * s, (T(2) * u.y - T(1)) * s);
    });
  }

  /// The nearest of the square and the interface crossed at t in (0, t_max).
  [[nodiscard]] std::optional<Hit<T>> intersect(const IntersectQuery<T>& q) const noexcept {
    return detail::intersect_square_and_level(
        square_, q, p_.depth, [this](T x, T y) { return in_interface(x, y); },
        [this](T x, T y) { return interface_point(x, y); });
  }

  /// Blocked by the square or the interface (two ends on the same surface's plane are
  /// blocked); a `direction` end is visible when the ray towards it escapes.
  [[nodiscard]] bool visible(const VisibilityQuery<T>& q) const noexcept {
    return detail::visible_square_and_level(
        square_, q, p_.depth, [this](T x, T y) { return in_interface(x, y); },
        [this](const IntersectQuery<T>& r) { return intersect(r); });
  }

  // ---- radiometry --------------------------------------------------------------------
  /// Lambertian on the square (primitive 0), the dielectric on the interface (1).
  class Materials {
   public:
    explicit Materials(const PointLitSubmergedPlane& s) : s_(&s) {}
    [[nodiscard]] T eval(const BsdfQuery<T>& q) const noexcept {
      return is_square(q.point) ? square().eval(q) : s_->glass_.eval(q);
    }
    [[nodiscard]] std::optional<BsdfSample<T>> sample(const BsdfSampleQuery<T>& q) const noexcept {
      return is_square(q.point) ? square().sample(q) : s_->glass_.sample(q);
    }
    [[nodiscard]] T pdf(const BsdfQuery<T>& q) const noexcept {
      return is_square(q.point) ? square().pdf(q) : s_->glass_.pdf(q);
    }
    /// The square is Lambertian (concepts/bsdf.hpp's optional customization point).
    [[nodiscard]] std::optional<T> lambertian_albedo(const SurfacePoint<T>& p) const noexcept {
      return is_square(p) ? std::optional<T>(s_->p_.albedo) : std::nullopt;
    }

   private:
    static bool is_square(const SurfacePoint<T>& p) noexcept { return p.primitive_id == 0; }
    [[nodiscard]] Lambertian<T> square() const noexcept { return Lambertian<T>{s_->p_.albedo}; }
    const PointLitSubmergedPlane* s_;
  };

  [[nodiscard]] Materials bsdf() const noexcept { return Materials(*this); }
  [[nodiscard]] const PointLight<T>& emitter() const noexcept { return light_; }
  [[nodiscard]] const ProbeSensor<T>& sensor() const noexcept { return sensor_; }

  /// The interface point above (x, y) (normal +z, primitive and material id 1).
  [[nodiscard]] SurfacePoint<T> interface_point(T x, T y) const noexcept {
    return SurfacePoint<T>::on_surface(Vec3<T>(x, y, p_.depth), Vec3<T>(0, 0, 1), 1, 1);
  }

 private:
  /// r(theta) for sin theta = s.
  [[nodiscard]] double landing_radius(double s) const noexcept {
    const double n = double(p_.eta);
    const double tan_i = s / std::sqrt(1 - s * s);
    const double s_t = s / n;
    return double(p_.light_height) * tan_i + double(p_.depth) * s_t / std::sqrt(1 - s_t * s_t);
  }
  [[nodiscard]] bool in_interface(T x, T y) const noexcept {
    const T s = interface_half_size();
    return std::abs(x) <= s && std::abs(y) <= s;
  }

  static SubmergedPlaneParameters<T> validated(const SubmergedPlaneParameters<T>& p) {
    constexpr const char* who = "PointLitSubmergedPlane";
    auto positive = [&](T v, const char* name) {
      detail::require_lit_plane(std::isfinite(v) && v > T(0), who,
                                std::string(name) + " must be finite and > 0, got " + std::to_string(v));
    };
    positive(p.half_size, "half_size");
    positive(p.depth, "depth");
    positive(p.light_height, "light_height");
    positive(p.eta, "eta");
    detail::require_lit_plane(std::isfinite(p.intensity) && p.intensity >= T(0), who,
                              "intensity must be finite and >= 0, got " + std::to_string(p.intensity));
    detail::require_lit_plane(p.albedo >= T(0) && p.albedo < T(1), who,
                              "albedo must lie in [0, 1), got " + std::to_string(p.albedo));
    return p;
  }

  /// Each probe's ray: from light_height / 2 above the interface, at `tilt` from the
  /// vertical, through the interface point whose refracted ray meets the target.
  static std::vector<Ray<T>> probe_rays(const SubmergedPlaneParameters<T>& p,
                                        const std::vector<SubmergedProbe<T>>& probes) {
    constexpr const char* who = "PointLitSubmergedPlane";
    detail::require_lit_plane(!probes.empty(), who, "needs at least one probe");
    std::vector<Ray<T>> rays;
    rays.reserve(probes.size());
    for (const auto& probe : probes) {
      detail::require_lit_plane(std::isfinite(probe.target.x) && std::isfinite(probe.target.y) &&
                                    std::abs(probe.target.x) <= p.half_size && std::abs(probe.target.y) <= p.half_size,
                                who, "probe targets must be finite points of the square |x|, |y| <= half_size");
      detail::require_lit_plane(std::isfinite(probe.tilt) && std::abs(probe.tilt) < T(1.5), who,
                                "probe tilts must be finite and below 1.5 radians, got " + std::to_string(probe.tilt));
      const double sin_t = std::sin(double(probe.tilt)) / double(p.eta);
      const double crossing_x = double(probe.target.x) + double(p.depth) * sin_t / std::sqrt(1 - sin_t * sin_t);
      const double rise = double(p.light_height) / 2;
      const Vec3<T> crossing(T(crossing_x), probe.target.y, p.depth);
      const Vec3<T> origin(T(crossing_x + rise * std::tan(double(probe.tilt))), probe.target.y, T(double(p.depth) + rise));
      detail::require_lit_plane(std::abs(crossing_x) <= double(T(2) * p.half_size), who,
                                "a probe's ray must cross the interface inside its square");
      rays.push_back(Ray<T>{origin, crossing - origin});
    }
    return rays;
  }

  SubmergedPlaneParameters<T> p_;
  detail::LitSquare<T> square_;
  PointLight<T> light_;
  Dielectric<T> glass_;
  std::vector<SubmergedProbe<T>> probes_;
  ProbeSensor<T> sensor_;
};

}  // namespace segpath::testing
