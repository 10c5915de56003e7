// A distant "sun": parallel light of direction d and irradiance E, a PointKind::direction
// light end modelling SampledEmitter (N30 light-start ends, N34 next-event ends).
#pragma once

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "segpath/concepts/emitter.hpp"
#include "segpath/core/format.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/core/warp.hpp"

namespace segpath {

namespace detail {

/// The disk that light-start rays of a distant emitter leave from: radius r (the scene's
/// bounding sphere radius), perpendicular to the direction `to_light` towards the emitter,
/// centred at c + r to_light, so every ray crossing the sphere starts on it, outside it.
template <Real T>
struct EmissionDisk {
  Vec3<T> centre{};
  T radius = 1;

  [[nodiscard]] T pdf() const noexcept { return T(1) / (pi<T> * radius * radius); }

  [[nodiscard]] Vec3<T> sample(const Vec3<T>& to_light, const Vec2<T>& u) const noexcept {
    const Vec2<T> d = square_to_uniform_disk(u) * radius;
    const Frame<T> frame = Frame<T>::from_normal(to_light);
    return centre + to_light * radius + frame.tangent * d.x + frame.bitangent * d.y;
  }

  /// Whether the line through `p` parallel to `to_light` crosses the disk (with a relative
  /// rounding allowance, so that every sampled point is inside).
  [[nodiscard]] bool contains(const Vec3<T>& to_light, const Vec3<T>& p) const noexcept {
    const Vec3<T> q = p - centre;
    const Vec3<T> perpendicular = q - to_light * glm::dot(q, to_light);
    const T allowance = T(1) + T(64) * std::numeric_limits<T>::epsilon();
    return glm::dot(perpendicular, perpendicular) <= radius * radius * allowance;
  }

  static EmissionDisk checked(const Vec3<T>& centre, T radius, const char* who) {
    if (!is_finite(centre))
      throw std::invalid_argument(std::string(who) +
                                  ": the scene's bounding sphere centre must be finite");
    if (!(radius > T(0)) || !std::isfinite(radius) || !std::isfinite(T(1) / (radius * radius)))
      throw std::invalid_argument(
          std::string(who) + ": the scene's bounding sphere radius must be finite and > 0, got " +
          format_number(double(radius)));
    return EmissionDisk{centre, radius};
  }
};

/// The `direction` endpoint of a distant emitter seen along `to_light` (from the scene
/// towards the emitter): position = normal = to_light (core/surface_point.hpp).
template <Real T>
[[nodiscard]] SurfacePoint<T> direction_endpoint(const Vec3<T>& to_light) noexcept {
  return SurfacePoint<T>{to_light,   to_light,   to_light,
                         invalid_id, invalid_id, PointKind::direction};
}

}  // namespace detail

/// Parallel light travelling along the unit direction d, of irradiance E on a surface
/// facing it (cornell box 0's sun).
///
/// Endpoint: one PointKind::direction light end y whose `position` is -d (from the scene
/// towards the light; Segment::direction() of (x, y) is then -d). Under the delta convention
/// of core/geometry.hpp, G(x, y) = |n_x . d| and radiance() returns E at y (a delta in
/// direction with coefficient 1), so L_e G = E cos_x is the irradiance at x (N17).
///
/// Densities. sample_towards / pdf_towards: y with discrete probability 1.
/// sample_emission, in the swapped roles the SampledEmitter doc gives direction emitters:
///  - `point` is y (position -d), `pdf_position` = 1: the discrete probability of the
///    (delta) direction; u_position is unused;
///  - `direction` is NOT a direction: it holds the origin o of the light-start ray, a
///    uniform point (from u_direction) of the disk of radius r perpendicular to d centred at
///    c - r d (c, r: the bounding sphere given to the constructor); the ray is o + t d;
///  - `pdf_direction` = 1/(pi r^2), o's area density on that disk. The area density of the
///    first hit x_k of the ray on the scene is pdf_direction * |n_x . d|, so the light-start
///    factor L_e G / p is E pi r^2 (the power through the disk).
/// pdf_emission({y, p}) reads `direction` the same way: p is any point of the ray (the
/// origin o, or x_k itself: only its projection along d matters); it returns {1, 1/(pi r^2)}
/// when that line crosses the disk, {1, 0} otherwise, and {0, 0} at any other endpoint.
template <Spectrum S>
class DirectionalLight {
 public:
  using Scalar = spectrum_scalar_t<S>;
  /// y is a delta (a discrete direction): LightSet lets it take precedence over continuous
  /// emitters (a background) that also emit from direction endpoints.
  static constexpr bool is_delta = true;

  /// `direction` (of travel) finite and non-zero (normalised here); `irradiance` finite and
  /// >= 0 in every channel; the scene's bounding sphere: `scene_centre` finite,
  /// `scene_radius` finite and > 0. Throws std::invalid_argument otherwise.
  DirectionalLight(const Vec3<Scalar>& direction, const S& irradiance,
                   const Vec3<Scalar>& scene_centre, Scalar scene_radius)
      : irradiance_(irradiance),
        disk_(detail::EmissionDisk<Scalar>::checked(scene_centre, scene_radius,
                                                    "segpath::DirectionalLight")) {
    const Scalar len = glm::length(direction);
    if (!is_finite(direction) || !std::isfinite(len) || !(len > Scalar(0)))
      throw std::invalid_argument(
          "segpath::DirectionalLight: direction must be finite and non-zero");
    direction_ = direction / len;
    if (!is_finite(irradiance) || max_component(irradiance * Scalar(-1)) > Scalar(0))
      throw std::invalid_argument(
          "segpath::DirectionalLight: irradiance must be finite and >= 0 in every channel, got "
          "max " +
          format_number(double(max_component(irradiance))));
  }

  /// The unit direction of travel d.
  [[nodiscard]] const Vec3<Scalar>& direction() const noexcept { return direction_; }
  [[nodiscard]] const S& irradiance() const noexcept { return irradiance_; }
  [[nodiscard]] const Vec3<Scalar>& scene_centre() const noexcept { return disk_.centre; }
  [[nodiscard]] Scalar scene_radius() const noexcept { return disk_.radius; }
  /// The light end y (PointKind::direction, position -d).
  [[nodiscard]] SurfacePoint<Scalar> point() const noexcept {
    return detail::direction_endpoint<Scalar>(-direction_);
  }
  /// Whether `p` is y (a delta direction matches only itself, exactly).
  [[nodiscard]] bool is_own_point(const SurfacePoint<Scalar>& p) const noexcept {
    return p.kind == PointKind::direction && p.position == -direction_;
  }

  /// E at y, 0 at any other endpoint.
  [[nodiscard]] S radiance(const EmissionQuery<Scalar>& q) const noexcept {
    return is_own_point(q.point) ? irradiance_ : S(Scalar(0));
  }

  /// y and a ray origin on the emission disk; see the class comment for the field meanings.
  [[nodiscard]] std::optional<EmissionSample<S>> sample_emission(
      const EmissionSampleQuery<Scalar>& q) const noexcept {
    return in_place_optional<EmissionSample<S>>(point(), disk_.sample(-direction_, q.u_direction), irradiance_,
                                                Scalar(1), disk_.pdf(), true);
  }

  [[nodiscard]] EmissionPdf<Scalar> pdf_emission(const EmissionPdfQuery<Scalar>& q) const noexcept {
    if (!is_own_point(q.point)) return EmissionPdf<Scalar>{};
    return EmissionPdf<Scalar>{Scalar(1),
                               disk_.contains(-direction_, q.direction) ? disk_.pdf() : Scalar(0)};
  }

  /// y with probability 1 and radiance E; nullopt for a receiver at infinity.
  [[nodiscard]] std::optional<EmitterTowardsSample<S>> sample_towards(
      const EmitterTowardsQuery<Scalar>& q) const noexcept {
    if (q.receiver.kind == PointKind::direction) return std::nullopt;
    return in_place_optional<EmitterTowardsSample<S>>(point(), irradiance_, Scalar(1), true);
  }

  /// 1 at y (for a finite receiver), 0 elsewhere.
  [[nodiscard]] Scalar pdf_towards(const EmitterPdfTowardsQuery<Scalar>& q) const noexcept {
    return is_own_point(q.point) && q.receiver.kind != PointKind::direction ? Scalar(1) : Scalar(0);
  }

 private:
  Vec3<Scalar> direction_{0, 0, -1};
  S irradiance_;
  detail::EmissionDisk<Scalar> disk_;
};

}  // namespace segpath
