// A constant background ("sky"): radiance L arriving along every ray that leaves the scene,
// PointKind::direction light ends modelling SampledEmitter (N30, N34).
#pragma once

#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "segpath/concepts/emitter.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/core/warp.hpp"
#include "segpath/lights/directional_light.hpp"

namespace segpath {

/// Constant radiance L from every direction (cornell box 3's sky).
///
/// Endpoints: every PointKind::direction endpoint y is a light end; its `position` w is the
/// unit direction from the scene towards the sky (light travels along -w); radiance() returns
/// L there whatever the direction to the sensor, and 0 at any other endpoint. G(x, y) =
/// |n_x . w| (core/geometry.hpp), so L_e G integrated over w in solid angle is the
/// irradiance pi L on an unoccluded surface.
///
/// sample_towards(receiver): w cosine-weighted about the receiver's geometric normal (density
/// max(n . w, 0)/pi in solid angle) for a `surface` receiver, so the back hemisphere of a
/// surface is never sampled; uniform on the sphere (density 1/(4 pi)) for a `point`
/// receiver; nullopt for a receiver at infinity.
///
/// sample_emission, in the swapped roles the SampledEmitter doc gives direction emitters:
///  - `point` is y, w uniform on the sphere from u_position, `pdf_position` = 1/(4 pi)
///    (solid angle);
///  - `direction` is NOT a direction: it holds the origin o of the light-start ray o + t (-w),
///    a uniform point (from u_direction) of the disk of radius r perpendicular to w centred
///    at c + r w (c, r: the bounding sphere given to the constructor);
///  - `pdf_direction` = 1/(pi r^2), o's area density on that disk; the first hit x_k then has
///    area density pdf_position * pdf_direction * |n_x . w| jointly with w.
/// pdf_emission({y, p}) reads `direction` the same way (p any point of the ray): {1/(4 pi),
/// 1/(pi r^2)} when the line through p along w crosses the disk, {1/(4 pi), 0} otherwise.
template <Spectrum S>
class BackgroundLight {
 public:
  using Scalar = spectrum_scalar_t<S>;

  /// `radiance` finite and >= 0 in every channel; the scene's bounding sphere:
  /// `scene_centre` finite, `scene_radius` finite and > 0. Throws std::invalid_argument
  /// otherwise.
  BackgroundLight(const S& radiance, const Vec3<Scalar>& scene_centre, Scalar scene_radius)
      : radiance_(radiance),
        disk_(detail::EmissionDisk<Scalar>::checked(scene_centre, scene_radius,
                                                    "segpath::BackgroundLight")) {
    if (!is_finite(radiance) || max_component(radiance * Scalar(-1)) > Scalar(0))
      throw std::invalid_argument(
          "segpath::BackgroundLight: radiance must be finite and >= 0 in every channel, got " +
          least_channel_text(radiance));
  }

  [[nodiscard]] const S& emitted_radiance() const noexcept { return radiance_; }
  [[nodiscard]] const Vec3<Scalar>& scene_centre() const noexcept { return disk_.centre; }
  [[nodiscard]] Scalar scene_radius() const noexcept { return disk_.radius; }
  /// The light end in the unit direction `towards_sky` (from the scene to the sky).
  [[nodiscard]] static SurfacePoint<Scalar> point(const Vec3<Scalar>& towards_sky) noexcept {
    return detail::direction_endpoint(towards_sky);
  }

  /// L at every `direction` endpoint, 0 elsewhere.
  [[nodiscard]] S radiance(const EmissionQuery<Scalar>& q) const noexcept {
    return q.point.kind == PointKind::direction ? radiance_ : S(Scalar(0));
  }

  /// A uniform direction and a ray origin on the emission disk; see the class comment.
  [[nodiscard]] std::optional<EmissionSample<S>> sample_emission(
      const EmissionSampleQuery<Scalar>& q) const noexcept {
    const Vec3<Scalar> w = square_to_uniform_sphere(q.u_position);
    return in_place_optional<EmissionSample<S>>(point(w), disk_.sample(w, q.u_direction), radiance_,
                                                square_to_uniform_sphere_pdf<Scalar>(), disk_.pdf());
  }

  [[nodiscard]] EmissionPdf<Scalar> pdf_emission(const EmissionPdfQuery<Scalar>& q) const noexcept {
    if (q.point.kind != PointKind::direction) return EmissionPdf<Scalar>{};
    return EmissionPdf<Scalar>{
        square_to_uniform_sphere_pdf<Scalar>(),
        disk_.contains(q.point.position, q.direction) ? disk_.pdf() : Scalar(0)};
  }

  [[nodiscard]] std::optional<EmitterTowardsSample<S>> sample_towards(
      const EmitterTowardsQuery<Scalar>& q) const noexcept {
    if (q.receiver.kind == PointKind::direction) return std::nullopt;
    if (q.receiver.kind == PointKind::point) {
      return in_place_optional<EmitterTowardsSample<S>>(point(square_to_uniform_sphere(q.u)), radiance_,
                                                        square_to_uniform_sphere_pdf<Scalar>());
    }
    const Vec3<Scalar> w =
        Frame<Scalar>::from_normal(q.receiver.normal).to_world(square_to_cosine_hemisphere(q.u));
    // The density from the world direction, exactly as pdf_towards computes it.
    const Scalar pdf = glm::dot(q.receiver.normal, w) * inv_pi<Scalar>;
    if (!(pdf > Scalar(0))) return std::nullopt;
    return in_place_optional<EmitterTowardsSample<S>>(point(w), radiance_, pdf);
  }

  /// The solid-angle density of sample_towards for this receiver at a `direction` endpoint.
  [[nodiscard]] Scalar pdf_towards(const EmitterPdfTowardsQuery<Scalar>& q) const noexcept {
    if (q.point.kind != PointKind::direction || q.receiver.kind == PointKind::direction)
      return Scalar(0);
    if (q.receiver.kind == PointKind::point) return square_to_uniform_sphere_pdf<Scalar>();
    const Scalar cosine = glm::dot(q.receiver.normal, q.point.position);
    return cosine > Scalar(0) ? cosine * inv_pi<Scalar> : Scalar(0);
  }

 private:
  S radiance_;
  detail::EmissionDisk<Scalar> disk_;
};

}  // namespace segpath
