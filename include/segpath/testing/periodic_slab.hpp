// Analytic scene: two parallel Lambertian planes, periodic in x and y (SPEC section 2).
// Every cosine-sampled ray from one plane hits the other, so L_A = (L_eA + rho_A L_eB) / (1 - rho_A
// rho_B).
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "segpath/concepts/scene.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/core/warp.hpp"
#include "segpath/materials/lambertian.hpp"
#include "segpath/sensors/probe.hpp"

namespace segpath::testing {

/// Plane A is z = 0 with normal +z (primitive and material id 0); plane B is z = h with
/// normal -z (id 1).
enum class SlabSide : std::uint8_t { a = 0, b = 1 };

template <Real T>
struct PeriodicSlabParameters {
  T height = 1;  ///< h, the distance between the planes
  T period = 1;  ///< P: both planes repeat with period P in x and in y
  T emission_a = 1;
  T emission_b = 0;
  T albedo_a = T(0.5);
  T albedo_b = T(0.5);
};

/// A probe ray from `origin` (strictly between the planes) to the point (target.x, target.y)
/// of plane `side`.
template <Real T>
struct SlabProbe {
  Vec3<T> origin{0, 0, T(0.5)};
  SlabSide side = SlabSide::a;
  Vec2<T> target{0, 0};
};

/// The scene; it models Scene and LightSampledScene with scalar spectra. M is the flat torus
/// of two P x P cells (area 2 P^2). Endpoints are points of its universal cover: positions
/// are never wrapped, so a segment keeps its true length and direction, and the plane a
/// point lies on is its primitive_id.
///
/// Which samplers this scene is exact for: any that extend paths by tracing rays or by
/// kernels around existing ends (the cover's points then range over the whole planes), and
/// next-event / bridge ends drawn by Emission::sample_towards, which samples the whole
/// opposite plane by projected solid angle. A segment whose two ends are both drawn by
/// sample_area (the uniform sampler, N26) joins one representative of each torus point and
/// sees one lattice translate of the other end only, so it underestimates G summed over the
/// translates: use SphereInterior for such samplers.
template <Real T>
class PeriodicSlab {
 public:
  using Scalar = T;
  using Spectrum = T;

  PeriodicSlab(const PeriodicSlabParameters<T>& p, const std::vector<SlabProbe<T>>& probes)
      : p_(validated(p)), targets_(probe_targets(p_, probes)), sensor_(probe_rays(p_, probes)) {}

  // ---- closed forms -------------------------------------------------------------------
  [[nodiscard]] T emission(SlabSide s) const noexcept {
    return s == SlabSide::a ? p_.emission_a : p_.emission_b;
  }
  [[nodiscard]] T albedo(SlabSide s) const noexcept {
    return s == SlabSide::a ? p_.albedo_a : p_.albedo_b;
  }
  /// L_s = (L_es + rho_s L_eo) / (1 - rho_s rho_o), o the opposite plane.
  [[nodiscard]] T radiance(SlabSide s) const noexcept {
    return (emission(s) + albedo(s) * emission(other(s))) / (T(1) - p_.albedo_a * p_.albedo_b);
  }
  /// The part of L_s carried by paths with exactly `bounces` reflections: (rho_s rho_o)^j L_es
  /// for 2j bounces, rho_s (rho_s rho_o)^j L_eo for 2j + 1.
  [[nodiscard]] T bounce_radiance(SlabSide s, unsigned bounces) const noexcept {
    const T pair = std::pow(p_.albedo_a * p_.albedo_b, T(bounces / 2));
    return bounces % 2 == 0 ? pair * emission(s) : albedo(s) * pair * emission(other(s));
  }
  /// L_s truncated after `max_bounces` reflections (for estimators with a depth limit).
  [[nodiscard]] T radiance_up_to(SlabSide s, unsigned max_bounces) const noexcept {
    T sum = 0;
    for (unsigned k = 0; k <= max_bounces; ++k) sum += bounce_radiance(s, k);
    return sum;
  }
  [[nodiscard]] SlabSide probe_side(std::uint32_t pixel) const noexcept {
    return targets_[pixel].side;
  }
  /// The plane point probe `pixel` looks at.
  [[nodiscard]] Vec3<T> probe_target(std::uint32_t pixel) const noexcept {
    const SlabProbe<T>& t = targets_[pixel];
    return Vec3<T>(t.target.x, t.target.y, plane_z(t.side));
  }
  /// What probe `pixel` measures: the radiance of the plane it looks at.
  [[nodiscard]] T probe_radiance(std::uint32_t pixel) const noexcept {
    return radiance(probe_side(pixel));
  }
  [[nodiscard]] const PeriodicSlabParameters<T>& parameters() const noexcept { return p_; }

  // ---- Manifold ----------------------------------------------------------------------
  /// The image of a point in the fundamental cell [0, P)^2 (Manifold's optional
  /// canonical_position): clustering treats the slab as the flat torus it is.
  [[nodiscard]] Vec3<T> canonical_position(const SurfacePoint<T>& p) const noexcept {
    const T px = p_.period;
    return Vec3<T>(p.position.x - px * std::floor(p.position.x / px), p.position.y - px * std::floor(p.position.y / px),
                   p.position.z);
  }

  [[nodiscard]] T area() const noexcept { return T(2) * p_.period * p_.period; }

  /// u.x < 1/2 picks plane A, otherwise B (each has half the area); the point is uniform in
  /// the cell [0, P)^2 of that plane.
  [[nodiscard]] std::optional<AreaSample<T>> sample_area(
      const AreaSampleQuery<T>& q) const noexcept {
    return in_place_optional<AreaSample<T>>(cell_point(q.u), T(1) / area());
  }

  /// The nearest crossing with t > 0 of either plane, so a ray leaving a plane point hits the
  /// other plane (or nothing) and never the plane it starts on.
  [[nodiscard]] std::optional<Hit<T>> intersect(const IntersectQuery<T>& q) const noexcept {
    const Vec3<T>& o = q.ray.origin;
    const Vec3<T>& d = q.ray.direction;
    if (d.z == T(0)) return std::nullopt;
    const T t_a = -o.z / d.z;
    const T t_b = (p_.height - o.z) / d.z;
    const bool a_ok = t_a > T(0) && t_a < q.t_max;
    const bool b_ok = t_b > T(0) && t_b < q.t_max;
    if (!a_ok && !b_ok) return std::nullopt;
    const SlabSide s = a_ok && (!b_ok || t_a < t_b) ? SlabSide::a : SlabSide::b;
    const T t = s == SlabSide::a ? t_a : t_b;
    const Vec3<T> x = o + d * t;
    if (!std::isfinite(t) || !std::isfinite(x.x) || !std::isfinite(x.y)) return std::nullopt;
    return in_place_optional<Hit<T>>(point_on(s, x.x, x.y), t);
  }

  /// True for ends on different planes or with one strictly between the planes; false for
  /// two ends on the same plane, ends outside the slab and `direction` ends (no ray escapes
  /// except horizontal ones, a set of measure zero).
  [[nodiscard]] bool visible(const VisibilityQuery<T>& q) const noexcept {
    const Location a = locate(q.from);
    const Location b = locate(q.to);
    if (a == Location::outside || b == Location::outside) return false;
    return a == Location::between || a != b;
  }

  // ---- radiometry --------------------------------------------------------------------
  class Materials {
   public:
    explicit Materials(const PeriodicSlab& s) : s_(&s) {}
    [[nodiscard]] T eval(const BsdfQuery<T>& q) const noexcept { return at(q.point).eval(q); }
    [[nodiscard]] std::optional<BsdfSample<T>> sample(const BsdfSampleQuery<T>& q) const noexcept {
      return at(q.point).sample(q);
    }
    [[nodiscard]] T pdf(const BsdfQuery<T>& q) const noexcept { return at(q.point).pdf(q); }
    /// Both planes are Lambertian (the optional Bsdf customization point of concepts/bsdf.hpp).
    [[nodiscard]] std::optional<T> lambertian_albedo(const SurfacePoint<T>& p) const noexcept { return at(p).albedo; }

   private:
    [[nodiscard]] Lambertian<T> at(const SurfacePoint<T>& p) const noexcept {
      const Location l = s_->locate(p);
      if (l == Location::a) return Lambertian<T>{s_->p_.albedo_a};
      if (l == Location::b) return Lambertian<T>{s_->p_.albedo_b};
      return Lambertian<T>{T(0)};
    }
    const PeriodicSlab* s_;
  };

  /// Lambertian emission of each plane towards the other. sample_emission draws like
  /// sample_area plus a cosine direction; sample_towards draws the emitting end by projected
  /// solid angle from the receiver (a cosine direction about a plane receiver's normal, a
  /// uniform direction from a receiver between the planes) and reports its area density
  /// p = cos_r cos_y / (pi d^2), resp. cos_y / (4 pi d^2), over the whole cover plane.
  class Emission {
   public:
    explicit Emission(const PeriodicSlab& s) : s_(&s) {}

    [[nodiscard]] T radiance(const EmissionQuery<T>& q) const noexcept {
      if (q.point.kind != PointKind::surface || glm::dot(q.to_sensor, q.point.normal) <= T(0))
        return T(0);
      const Location l = s_->locate(q.point);
      if (l == Location::a) return s_->p_.emission_a;
      if (l == Location::b) return s_->p_.emission_b;
      return T(0);
    }

    [[nodiscard]] std::optional<EmissionSample<T>> sample_emission(
        const EmissionSampleQuery<T>& q) const noexcept {
      const SurfacePoint<T> y = s_->cell_point(q.u_position);
      const Vec3<T> local = square_to_cosine_hemisphere(q.u_direction);
      const T pdf_dir = square_to_cosine_hemisphere_pdf(local);
      if (!(pdf_dir > T(0))) return std::nullopt;
      const T le = y.primitive_id == 0 ? s_->p_.emission_a : s_->p_.emission_b;
      return in_place_optional<EmissionSample<T>>(y, y.shading_frame().to_world(local), le, T(1) / s_->area(),
                                                  pdf_dir);
    }

    [[nodiscard]] EmissionPdf<T> pdf_emission(const EmissionPdfQuery<T>& q) const noexcept {
      const Location l = s_->locate(q.point);
      if (q.point.kind != PointKind::surface || (l != Location::a && l != Location::b))
        return EmissionPdf<T>{};
      const T cosine = glm::dot(q.direction, q.point.normal);
      return EmissionPdf<T>{T(1) / s_->area(), cosine > T(0) ? cosine * inv_pi<T> : T(0)};
    }

    [[nodiscard]] std::optional<EmitterTowardsSample<T>> sample_towards(
        const EmitterTowardsQuery<T>& q) const noexcept {
      const Location l = s_->locate(q.receiver);
      Vec3<T> d;
      T pdf_solid_angle;
      if (l == Location::a || l == Location::b) {
        const Vec3<T> local = square_to_cosine_hemisphere(q.u);
        pdf_solid_angle = square_to_cosine_hemisphere_pdf(local);
        d = Frame<T>::from_normal(plane_normal(l == Location::a ? SlabSide::a : SlabSide::b))
                .to_world(local);
      } else if (l == Location::between) {
        d = square_to_uniform_sphere(q.u);
        pdf_solid_angle = square_to_uniform_sphere_pdf<T>();
      } else {
        return std::nullopt;
      }
      if (!(pdf_solid_angle > T(0))) return std::nullopt;
      const auto hit = s_->intersect(IntersectQuery<T>{Ray<T>{q.receiver.position, d}});
      if (!hit) return std::nullopt;
      const T pdf = pdf_solid_angle * std::abs(d.z) / (hit->distance * hit->distance);
      if (!(pdf > T(0)) || !std::isfinite(pdf)) return std::nullopt;
      return in_place_optional<EmitterTowardsSample<T>>(hit->point, radiance(EmissionQuery<T>{hit->point, -d}), pdf);
    }

    [[nodiscard]] T pdf_towards(const EmitterPdfTowardsQuery<T>& q) const noexcept {
      const Location r = s_->locate(q.receiver);
      const Location y = s_->locate(q.point);
      if (q.point.kind != PointKind::surface || (y != Location::a && y != Location::b) || r == y)
        return T(0);
      const Vec3<T> delta = q.point.position - q.receiver.position;
      const T d2 = glm::dot(delta, delta);
      if (!(d2 > T(0))) return T(0);
      const T cosine = std::abs(delta.z) / std::sqrt(d2);
      if (r == Location::between) return square_to_uniform_sphere_pdf<T>() * cosine / d2;
      if (r == Location::outside) return T(0);
      return cosine * cosine * inv_pi<T> / d2;
    }

   private:
    const PeriodicSlab* s_;
  };

  [[nodiscard]] Materials bsdf() const noexcept { return Materials(*this); }
  [[nodiscard]] Emission emitter() const noexcept { return Emission(*this); }
  [[nodiscard]] const ProbeSensor<T>& sensor() const noexcept { return sensor_; }

  /// The point (x, y) of plane s (cover coordinates, not wrapped).
  [[nodiscard]] SurfacePoint<T> point_on(SlabSide s, T x, T y) const noexcept {
    const auto id = static_cast<std::uint32_t>(s);
    return SurfacePoint<T>::on_surface(Vec3<T>(x, y, plane_z(s)), plane_normal(s), id, id);
  }
  [[nodiscard]] static Vec3<T> plane_normal(SlabSide s) noexcept {
    return s == SlabSide::a ? Vec3<T>(0, 0, 1) : Vec3<T>(0, 0, -1);
  }
  [[nodiscard]] T plane_z(SlabSide s) const noexcept { return s == SlabSide::a ? T(0) : p_.height; }

 private:
  enum class Location : std::uint8_t { a, b, between, outside };

  static SlabSide other(SlabSide s) noexcept {
    return s == SlabSide::a ? SlabSide::b : SlabSide::a;
  }

  /// Surface points by primitive id (kernels move points within a plane and keep the id),
  /// other ends by height.
  [[nodiscard]] Location locate(const SurfacePoint<T>& p) const noexcept {
    if (p.kind == PointKind::direction) return Location::outside;
    if (p.kind == PointKind::surface && p.primitive_id == 0) return Location::a;
    if (p.kind == PointKind::surface && p.primitive_id == 1) return Location::b;
    const T z = p.position.z;
    if (z == T(0)) return Location::a;
    if (z == p_.height) return Location::b;
    return z > T(0) && z < p_.height ? Location::between : Location::outside;
  }

  [[nodiscard]] SurfacePoint<T> cell_point(const Vec2<T>& u) const noexcept {
    const SlabSide s = u.x < T(0.5) ? SlabSide::a : SlabSide::b;
    const T ux = s == SlabSide::a ? T(2) * u.x : T(2) * u.x - T(1);
    return point_on(s, ux * p_.period, u.y * p_.period);
  }

  static PeriodicSlabParameters<T> validated(const PeriodicSlabParameters<T>& p) {
    auto fail = [](const std::string& what) {
      throw std::invalid_argument("segpath::testing::PeriodicSlab: " + what);
    };
    if (!std::isfinite(p.height) || !(p.height > T(0)))
      fail("height must be finite and > 0, got " + std::to_string(p.height));
    if (!std::isfinite(p.period) || !(p.period > T(0)))
      fail("period must be finite and > 0, got " + std::to_string(p.period));
    if (!std::isfinite(p.emission_a) || !(p.emission_a >= T(0)))
      fail("emission_a must be finite and >= 0, got " + std::to_string(p.emission_a));
    if (!std::isfinite(p.emission_b) || !(p.emission_b >= T(0)))
      fail("emission_b must be finite and >= 0, got " + std::to_string(p.emission_b));
    if (!(p.albedo_a >= T(0) && p.albedo_a < T(1)))
      fail("albedo_a must lie in [0, 1), got " + std::to_string(p.albedo_a));
    if (!(p.albedo_b >= T(0) && p.albedo_b < T(1)))
      fail("albedo_b must lie in [0, 1), got " + std::to_string(p.albedo_b));
    return p;
  }

  static std::vector<SlabProbe<T>> probe_targets(const PeriodicSlabParameters<T>& p,
                                                 const std::vector<SlabProbe<T>>& probes) {
    for (const auto& probe : probes) {
      if (!is_finite(probe.origin) || !std::isfinite(probe.target.x) ||
          !std::isfinite(probe.target.y))
        throw std::invalid_argument(
            "segpath::testing::PeriodicSlab: probe origins and targets must be finite");
      if (!(probe.origin.z > T(0) && probe.origin.z < p.height))
        throw std::invalid_argument(
            "segpath::testing::PeriodicSlab: probe origins must lie strictly between the planes, "
            "got z = " +
            std::to_string(probe.origin.z));
    }
    return probes;
  }

  static std::vector<Ray<T>> probe_rays(const PeriodicSlabParameters<T>& p,
                                        const std::vector<SlabProbe<T>>& probes) {
    std::vector<Ray<T>> rays;
    rays.reserve(probes.size());
    for (const auto& probe : probes) {
      const Vec3<T> target(probe.target.x, probe.target.y,
                           probe.side == SlabSide::a ? T(0) : p.height);
      rays.push_back(Ray<T>{probe.origin, target - probe.origin});
    }
    return rays;
  }

  PeriodicSlabParameters<T> p_;
  std::vector<SlabProbe<T>> targets_;
  ProbeSensor<T> sensor_;
};

}  // namespace segpath::testing
