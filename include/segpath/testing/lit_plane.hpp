// Analytic scenes: a Lambertian square lit by a point light or by a coaxial disk light
// (SPEC section 2), with closed-form irradiance and the disk-kernel bias (r^2/8) Laplacian E.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "segpath/concepts/scene.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/core/warp.hpp"
#include "segpath/lights/point_light.hpp"
#include "segpath/materials/lambertian.hpp"
#include "segpath/sensors/probe.hpp"

namespace segpath::testing {

namespace detail {

/// The square z = 0, |x|, |y| <= half_size, normal +z (primitive and material id 0), shared
/// by both lit-plane scenes; probes look straight down at it from z = probe_height.
template <Real T>
struct LitSquare {
  T half_size;

  [[nodiscard]] T area() const noexcept { return T(4) * half_size * half_size; }
  [[nodiscard]] bool contains(T x, T y) const noexcept {
    return std::abs(x) <= half_size && std::abs(y) <= half_size;
  }
  [[nodiscard]] static SurfacePoint<T> point(T x, T y) noexcept {
    return SurfacePoint<T>::on_surface(Vec3<T>(x, y, 0), Vec3<T>(0, 0, 1), 0, 0);
  }
  /// u in [0, 1)^2 to a uniform point of the square.
  [[nodiscard]] SurfacePoint<T> sample(const Vec2<T>& u) const noexcept {
    return point((T(2) * u.x - T(1)) * half_size, (T(2) * u.y - T(1)) * half_size);
  }
  /// The crossing of z = 0 at t in (0, t_max) inside the square (either side of it).
  [[nodiscard]] std::optional<Hit<T>> intersect(const Ray<T>& r, T t_max) const noexcept {
    if (r.direction.z == T(0)) return std::nullopt;
    const T t = -r.origin.z / r.direction.z;
    if (!(t > T(0)) || !(t < t_max)) return std::nullopt;
    const Vec3<T> x = r.at(t);
    if (!contains(x.x, x.y)) return std::nullopt;
    return in_place_optional<Hit<T>>(point(x.x, x.y), t);
  }

  static std::vector<Ray<T>> probe_rays(const std::vector<Vec2<T>>& targets, T half_size,
                                        T probe_height, const char* who) {
    std::vector<Ray<T>> rays;
    rays.reserve(targets.size());
    for (const auto& t : targets) {
      if (!std::isfinite(t.x) || !std::isfinite(t.y) ||
          !(std::abs(t.x) <= half_size && std::abs(t.y) <= half_size))
        throw std::invalid_argument(
            std::string("segpath::testing::") + who +
            ": probe targets must be finite points of the square |x|, |y| <= half_size");
      rays.push_back(Ray<T>{Vec3<T>(t.x, t.y, probe_height), Vec3<T>(0, 0, -1)});
    }
    return rays;
  }
};

/// Whether the open segment between a and b crosses the plane z = plane_z inside the region
/// accepted by `inside(x, y)`; two ends both on that plane count as blocked (the segment lies
/// in the surface).
template <Real T, class Inside>
[[nodiscard]] bool crosses_plane(const Vec3<T>& a, const Vec3<T>& b, T plane_z,
                                 Inside&& inside) noexcept {
  const T za = a.z - plane_z;
  const T zb = b.z - plane_z;
  if (za == T(0) && zb == T(0)) return inside(a.x, a.y) || inside(b.x, b.y);
  if (!((za > T(0) && zb < T(0)) || (za < T(0) && zb > T(0)))) return false;
  const T t = za / (za - zb);
  const Vec3<T> x = a + (b - a) * t;
  return inside(x.x, x.y);
}

/// The square and a second horizontal surface at z = level (a disk light, a dielectric
/// interface): `on_level(x, y)` says whether (x, y, level) lies on it, `level_point(x, y)` makes
/// that point. The nearest of the two crossed at t in (0, t_max).
template <Real T, class OnLevel, class LevelPoint>
[[nodiscard]] std::optional<Hit<T>> intersect_square_and_level(const LitSquare<T>& square, const IntersectQuery<T>& q, T level,
                                                               const OnLevel& on_level, const LevelPoint& level_point) noexcept {
  std::optional<Hit<T>> hit = square.intersect(q.ray, q.t_max);
  const T t_max = hit ? hit->distance : q.t_max;
  if (q.ray.direction.z != T(0)) {
    const T t = (level - q.ray.origin.z) / q.ray.direction.z;
    if (t > T(0) && t < t_max) {
      const Vec3<T> x = q.ray.at(t);
      if (on_level(x.x, x.y)) hit = Hit<T>{level_point(x.x, x.y), t};
    }
  }
  return hit;
}

/// Visibility where an end is a `direction`: the ray towards it escapes (`intersect` finds
/// nothing); two directions never see each other. nullopt where neither end is one.
template <Real T, class Intersect>
[[nodiscard]] std::optional<bool> visible_towards_direction(const VisibilityQuery<T>& q, const Intersect& intersect) noexcept {
  const bool from_dir = q.from.kind == PointKind::direction;
  const bool to_dir = q.to.kind == PointKind::direction;
  if (from_dir && to_dir) return false;
  if (!from_dir && !to_dir) return std::nullopt;
  const SurfacePoint<T>& o = from_dir ? q.to : q.from;
  const SurfacePoint<T>& d = from_dir ? q.from : q.to;
  return !intersect(IntersectQuery<T>{Ray<T>{o.position, glm::normalize(d.position)}});
}

/// Visibility among the square and the level surface (two ends on one surface's plane are
/// blocked); a `direction` end is visible when the ray towards it escapes (`intersect`).
template <Real T, class OnLevel, class Intersect>
[[nodiscard]] bool visible_square_and_level(const LitSquare<T>& square, const VisibilityQuery<T>& q, T level,
                                            const OnLevel& on_level, const Intersect& intersect) noexcept {
  if (const auto towards = visible_towards_direction(q, intersect)) return *towards;
  const Vec3<T>& a = q.from.position;
  const Vec3<T>& b = q.to.position;
  return !crosses_plane(a, b, T(0), [&square](T x, T y) { return square.contains(x, y); }) && !crosses_plane(a, b, level, on_level);
}

/// u.x picks the square (with its share of `total_area`) or the level surface, whose point
/// `level_sample(u')` draws uniformly; density 1 / total_area.
template <Real T, class LevelSample>
[[nodiscard]] AreaSample<T> sample_square_or_level(const LitSquare<T>& square, const Vec2<T>& u, T total_area,
                                                   const LevelSample& level_sample) noexcept {
  const T square_share = square.area() / total_area;
  if (u.x < square_share) return AreaSample<T>{square.sample(Vec2<T>(std::min(u.x / square_share, T(1)), u.y)), T(1) / total_area};
  const T ux = std::clamp((u.x - square_share) / (T(1) - square_share), T(0), T(1));
  return AreaSample<T>{level_sample(Vec2<T>(ux, u.y)), T(1) / total_area};
}

inline void require_lit_plane(bool ok, const char* who, const std::string& what) {
  if (!ok) throw std::invalid_argument(std::string("segpath::testing::") + who + ": " + what);
}

}  // namespace detail

template <Real T>
struct PointLitPlaneParameters {
  T half_size = 2;  ///< the square is |x|, |y| <= half_size at z = 0
  T height = 1;     ///< h: the light is at (0, 0, h)
  T intensity = 1;  ///< I in W/sr
  T albedo = T(0.5);
};

/// A Lambertian square under an isotropic point light; it models Scene and
/// LightSampledScene with scalar spectra. M is the square only (the light is a `point`
/// end, not on M). Probes (the sensor's pixels) look straight down at given points of the
/// square from z = h / 2. All light is single-bounce: the square cannot see itself.
template <Real T>
class PointLitPlane {
 public:
  using Scalar = T;
  using Spectrum = T;

  /// `probe_targets`: one probe per (x, y) of the square.
  PointLitPlane(const PointLitPlaneParameters<T>& p, const std::vector<Vec2<T>>& probe_targets)
      : p_(validated(p)),
        square_{p_.half_size},
        light_(Vec3<T>(0, 0, p_.height), p_.intensity),
        sensor_(detail::LitSquare<T>::probe_rays(probe_targets, p_.half_size, p_.height / T(2),
                                                 "PointLitPlane")) {}

  // ---- closed forms -------------------------------------------------------------------
  /// E(r) = I h / (h^2 + r^2)^(3/2), r the distance of x from the axis (only x.x, x.y are used).
  [[nodiscard]] T irradiance_at(const Vec3<T>& x) const noexcept {
    const T h = p_.height;
    const T s = h * h + x.x * x.x + x.y * x.y;
    return p_.intensity * h / (s * std::sqrt(s));
  }
  /// L(x) = rho E(x) / pi towards any direction above the square.
  [[nodiscard]] T radiance_at(const Vec3<T>& x) const noexcept {
    return p_.albedo * irradiance_at(x) * inv_pi<T>;
  }
  /// All of L is carried by one-bounce paths.
  [[nodiscard]] T bounce_radiance_at(const Vec3<T>& x, unsigned bounces) const noexcept {
    return bounces == 1 ? radiance_at(x) : T(0);
  }
  /// The 2D Laplacian of E, analytically: with E = I h (h^2 + r^2)^(-3/2),
  /// Delta E = E'' + E'/r = I h (9 r^2 - 6 h^2) / (h^2 + r^2)^(7/2).
  [[nodiscard]] T irradiance_laplacian_at(const Vec3<T>& x) const noexcept {
    const T h = p_.height;
    const T r2 = x.x * x.x + x.y * x.y;
    const T s = h * h + r2;
    return p_.intensity * h * (T(9) * r2 - T(6) * h * h) / (s * s * s * std::sqrt(s));
  }
  /// Leading term of the bias of a uniform disk kernel estimate (N19, kernels/disk.hpp) of
  /// the radiance at x: the kernel averages rho E / pi over the disk of `radius` around x,
  /// and the disk average of a smooth E is E + (radius^2 / 8) Delta E + O(radius^4) (SPEC 2).
  /// Returns (rho / pi) (radius^2 / 8) Delta E(x), in radiance units. Valid while the disk
  /// lies inside the square.
  [[nodiscard]] T kernel_bias_estimate(const Vec3<T>& x, T radius) const noexcept {
    return p_.albedo * inv_pi<T> * radius * radius / T(8) * irradiance_laplacian_at(x);
  }
  [[nodiscard]] Vec3<T> probe_target(std::uint32_t pixel) const noexcept {
    const Ray<T>& r = sensor_.probe(pixel);
    return Vec3<T>(r.origin.x, r.origin.y, 0);
  }
  [[nodiscard]] T probe_radiance(std::uint32_t pixel) const noexcept {
    return radiance_at(probe_target(pixel));
  }
  [[nodiscard]] const PointLitPlaneParameters<T>& parameters() const noexcept { return p_; }

  // ---- Manifold ----------------------------------------------------------------------
  [[nodiscard]] T area() const noexcept { return square_.area(); }
  [[nodiscard]] std::optional<AreaSample<T>> sample_area(
      const AreaSampleQuery<T>& q) const noexcept {
    return in_place_optional<AreaSample<T>>(square_.sample(q.u), T(1) / area());
  }
  /// The crossing of the square from either side; its normal is always +z (the front).
  [[nodiscard]] std::optional<Hit<T>> intersect(const IntersectQuery<T>& q) const noexcept {
    return square_.intersect(q.ray, q.t_max);
  }
  /// Blocked only by the square (two ends on the square's plane are blocked); a `direction`
  /// end is visible when the ray towards it misses the square.
  [[nodiscard]] bool visible(const VisibilityQuery<T>& q) const noexcept {
    if (const auto towards = detail::visible_towards_direction(q, [this](const IntersectQuery<T>& r) { return intersect(r); }))
      return *towards;
    return !detail::crosses_plane(q.from.position, q.to.position, T(0),
                                  [this](T x, T y) { return square_.contains(x, y); });
  }

  // ---- radiometry --------------------------------------------------------------------
  [[nodiscard]] Lambertian<T> bsdf() const noexcept { return Lambertian<T>{p_.albedo}; }
  [[nodiscard]] const PointLight<T>& emitter() const noexcept { return light_; }
  [[nodiscard]] const ProbeSensor<T>& sensor() const noexcept { return sensor_; }

 private:
  static PointLitPlaneParameters<T> validated(const PointLitPlaneParameters<T>& p) {
    constexpr const char* who = "PointLitPlane";
    detail::require_lit_plane(
        std::isfinite(p.half_size) && p.half_size > T(0), who,
        "half_size must be finite and > 0, got " + std::to_string(p.half_size));
    detail::require_lit_plane(std::isfinite(p.height) && p.height > T(0), who,
                              "height must be finite and > 0, got " + std::to_string(p.height));
    detail::require_lit_plane(
        std::isfinite(p.intensity) && p.intensity >= T(0), who,
        "intensity must be finite and >= 0, got " + std::to_string(p.intensity));
    detail::require_lit_plane(p.albedo >= T(0) && p.albedo < T(1), who,
                              "albedo must lie in [0, 1), got " + std::to_string(p.albedo));
    return p;
  }

  PointLitPlaneParameters<T> p_;
  detail::LitSquare<T> square_;
  PointLight<T> light_;
  ProbeSensor<T> sensor_;
};

template <Real T>
struct DiskLitPlaneParameters {
  T half_size = 2;  ///< the square is |x|, |y| <= half_size at z = 0
  T height = 1;     ///< h: the disk lies at z = h, centred on the z axis, facing -z
  T disk_radius = T(0.5);
  T radiance = 1;     ///< L, the disk's Lambertian emitted radiance (downwards only)
  T albedo = T(0.5);  ///< the square's; the disk is black
};

/// A Lambertian square under a coaxial one-sided Lambertian disk light; it models Scene and
/// LightSampledScene with scalar spectra. M is the square (primitive id 0) plus the disk
/// (id 1, albedo 0). Probes look straight down at points of the square from z = h / 2.
/// All light leaving the square is single-bounce: it sees only the disk, which is black.
template <Real T>
class DiskLitPlane {
 public:
  using Scalar = T;
  using Spectrum = T;

  /// `probe_targets`: one probe per (x, y) of the square.
  DiskLitPlane(const DiskLitPlaneParameters<T>& p, const std::vector<Vec2<T>>& probe_targets)
      : p_(validated(p)),
        square_{p_.half_size},
        sensor_(detail::LitSquare<T>::probe_rays(probe_targets, p_.half_size, p_.height / T(2),
                                                 "DiskLitPlane")) {}

  // ---- closed forms -------------------------------------------------------------------
  /// E at the plane point x (r from the axis) from the parallel coaxial disk:
  /// E = (pi L / 2) (1 - (h^2 + r^2 - a^2) / Y), Y = sqrt((h^2 + r^2 + a^2)^2 - 4 a^2 r^2),
  /// evaluated without cancellation as 2 pi L a^2 h^2 / (Y (Y + h^2 + r^2 - a^2)) (since
  /// Y^2 - (h^2 + r^2 - a^2)^2 = 4 a^2 h^2) with Y^2 = (h^2 + (r - a)^2)(h^2 + (r + a)^2).
  /// At r = 0 it is pi L a^2 / (h^2 + a^2).
  [[nodiscard]] T irradiance_at(const Vec3<T>& x) const noexcept {
    const T h2 = p_.height * p_.height;
    const T a = p_.disk_radius;
    const T r = std::sqrt(x.x * x.x + x.y * x.y);
    const T y = std::sqrt((h2 + (r - a) * (r - a)) * (h2 + (r + a) * (r + a)));
    return T(2) * pi<T> * p_.radiance * a * a * h2 / (y * (y + h2 + r * r - a * a));
  }
  [[nodiscard]] T radiance_at(const Vec3<T>& x) const noexcept {
    return p_.albedo * irradiance_at(x) * inv_pi<T>;
  }
  [[nodiscard]] T bounce_radiance_at(const Vec3<T>& x, unsigned bounces) const noexcept {
    return bounces == 1 ? radiance_at(x) : T(0);
  }
  [[nodiscard]] Vec3<T> probe_target(std::uint32_t pixel) const noexcept {
    const Ray<T>& r = sensor_.probe(pixel);
    return Vec3<T>(r.origin.x, r.origin.y, 0);
  }
  [[nodiscard]] T probe_radiance(std::uint32_t pixel) const noexcept {
    return radiance_at(probe_target(pixel));
  }
  [[nodiscard]] const DiskLitPlaneParameters<T>& parameters() const noexcept { return p_; }
  [[nodiscard]] T disk_area() const noexcept { return pi<T> * p_.disk_radius * p_.disk_radius; }

  // ---- Manifold ----------------------------------------------------------------------
  [[nodiscard]] T area() const noexcept { return square_.area() + disk_area(); }

  /// Picks the square or the disk with probability proportional to its area (by u.x), then
  /// a uniform point of it.
  [[nodiscard]] std::optional<AreaSample<T>> sample_area(
      const AreaSampleQuery<T>& q) const noexcept {
    return detail::sample_square_or_level(square_, q.u, area(), [this](const Vec2<T>& u) { return disk_sample(u); });
  }

  /// The nearest of the square (normal +z) and the disk (normal -z) crossed at t in (0, t_max).
  [[nodiscard]] std::optional<Hit<T>> intersect(const IntersectQuery<T>& q) const noexcept {
    return detail::intersect_square_and_level(
        square_, q, p_.height, [this](T x, T y) { return in_disk(x, y); }, [this](T x, T y) { return disk_point(x, y); });
  }

  /// Blocked by the square or the disk (two ends on the same surface's plane are blocked); a
  /// `direction` end is visible when the ray towards it escapes.
  [[nodiscard]] bool visible(const VisibilityQuery<T>& q) const noexcept {
    return detail::visible_square_and_level(
        square_, q, p_.height, [this](T x, T y) { return in_disk(x, y); }, [this](const IntersectQuery<T>& r) { return intersect(r); });
  }

  // ---- radiometry --------------------------------------------------------------------
  /// Lambertian with the square's albedo on primitive 0, black on the disk.
  class Materials {
   public:
    explicit Materials(const DiskLitPlane& s) : s_(&s) {}
    [[nodiscard]] T eval(const BsdfQuery<T>& q) const noexcept { return at(q.point).eval(q); }
    [[nodiscard]] std::optional<BsdfSample<T>> sample(const BsdfSampleQuery<T>& q) const noexcept {
      return at(q.point).sample(q);
    }
    [[nodiscard]] T pdf(const BsdfQuery<T>& q) const noexcept { return at(q.point).pdf(q); }

   private:
    [[nodiscard]] Lambertian<T> at(const SurfacePoint<T>& p) const noexcept {
      return Lambertian<T>{p.primitive_id == 0 ? s_->p_.albedo : T(0)};
    }
    const DiskLitPlane* s_;
  };

  /// The disk's one-sided Lambertian emission L; sampled uniformly by area (sample_towards)
  /// and with a cosine direction about -z (sample_emission).
  class Emission {
   public:
    explicit Emission(const DiskLitPlane& s) : s_(&s) {}

    [[nodiscard]] T radiance(const EmissionQuery<T>& q) const noexcept {
      if (!is_disk(q.point) || glm::dot(q.to_sensor, q.point.normal) <= T(0)) return T(0);
      return s_->p_.radiance;
    }

    [[nodiscard]] std::optional<EmissionSample<T>> sample_emission(
        const EmissionSampleQuery<T>& q) const noexcept {
      const SurfacePoint<T> y = s_->disk_sample(q.u_position);
      const Vec3<T> local = square_to_cosine_hemisphere(q.u_direction);
      const T pdf_dir = square_to_cosine_hemisphere_pdf(local);
      if (!(pdf_dir > T(0))) return std::nullopt;
      return in_place_optional<EmissionSample<T>>(y, y.shading_frame().to_world(local), s_->p_.radiance,
                                                  T(1) / s_->disk_area(), pdf_dir);
    }

    [[nodiscard]] EmissionPdf<T> pdf_emission(const EmissionPdfQuery<T>& q) const noexcept {
      if (!is_disk(q.point)) return EmissionPdf<T>{};
      const T cosine = glm::dot(q.direction, q.point.normal);
      return EmissionPdf<T>{T(1) / s_->disk_area(), cosine > T(0) ? cosine * inv_pi<T> : T(0)};
    }

    [[nodiscard]] std::optional<EmitterTowardsSample<T>> sample_towards(
        const EmitterTowardsQuery<T>& q) const noexcept {
      const SurfacePoint<T> y = s_->disk_sample(q.u);
      const Vec3<T> to_receiver = q.receiver.position - y.position;
      const T d2 = glm::dot(to_receiver, to_receiver);
      if (!(d2 > T(0))) return std::nullopt;
      return in_place_optional<EmitterTowardsSample<T>>(y, radiance(EmissionQuery<T>{y, to_receiver / std::sqrt(d2)}),
                                                        T(1) / s_->disk_area());
    }

    [[nodiscard]] T pdf_towards(const EmitterPdfTowardsQuery<T>& q) const noexcept {
      return is_disk(q.point) ? T(1) / s_->disk_area() : T(0);
    }

   private:
    static bool is_disk(const SurfacePoint<T>& p) noexcept {
      return p.kind == PointKind::surface && p.primitive_id == 1;
    }
    const DiskLitPlane* s_;
  };

  [[nodiscard]] Materials bsdf() const noexcept { return Materials(*this); }
  [[nodiscard]] Emission emitter() const noexcept { return Emission(*this); }
  [[nodiscard]] const ProbeSensor<T>& sensor() const noexcept { return sensor_; }

  /// The disk point above (x, y) (normal -z, primitive and material id 1).
  [[nodiscard]] SurfacePoint<T> disk_point(T x, T y) const noexcept {
    return SurfacePoint<T>::on_surface(Vec3<T>(x, y, p_.height), Vec3<T>(0, 0, -1), 1, 1);
  }

 private:
  [[nodiscard]] bool in_disk(T x, T y) const noexcept {
    return x * x + y * y <= p_.disk_radius * p_.disk_radius;
  }
  [[nodiscard]] SurfacePoint<T> disk_sample(const Vec2<T>& u) const noexcept {
    const Vec2<T> d = square_to_uniform_disk(u) * p_.disk_radius;
    return disk_point(d.x, d.y);
  }

  static DiskLitPlaneParameters<T> validated(const DiskLitPlaneParameters<T>& p) {
    constexpr const char* who = "DiskLitPlane";
    detail::require_lit_plane(
        std::isfinite(p.half_size) && p.half_size > T(0), who,
        "half_size must be finite and > 0, got " + std::to_string(p.half_size));
    detail::require_lit_plane(std::isfinite(p.height) && p.height > T(0), who,
                              "height must be finite and > 0, got " + std::to_string(p.height));
    detail::require_lit_plane(
        std::isfinite(p.disk_radius) && p.disk_radius > T(0), who,
        "disk_radius must be finite and > 0, got " + std::to_string(p.disk_radius));
    detail::require_lit_plane(
        std::isfinite(p.radiance) && p.radiance >= T(0), who,
        "radiance must be finite and >= 0, got " + std::to_string(p.radiance));
    detail::require_lit_plane(p.albedo >= T(0) && p.albedo < T(1), who,
                              "albedo must lie in [0, 1), got " + std::to_string(p.albedo));
    return p;
  }

  DiskLitPlaneParameters<T> p_;
  detail::LitSquare<T> square_;
  ProbeSensor<T> sensor_;
};

}  // namespace segpath::testing
