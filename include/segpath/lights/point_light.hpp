// An isotropic point light: a PointKind::point light end with intensity I (W/sr per
// channel), modelling SampledEmitter (N30 light-start ends, N34 next-event ends).
#pragma once

#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "segpath/concepts/emitter.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/core/warp.hpp"

namespace segpath {

/// Under segpath's delta convention (core/surface_point.hpp) a point light's end y has no
/// surface: G(s) keeps only cos_x / d^2, so radiance() returns the intensity I and
/// L_e G = I cos_x / d^2 is the irradiance at x (N17). Both sampling routines return this
/// light's single point with discrete probability 1 (there is no light selection).
template <Spectrum S>
class PointLight {
 public:
  using Scalar = spectrum_scalar_t<S>;

  /// `position` finite; `intensity` finite and >= 0 in every channel.
  PointLight(const Vec3<Scalar>& position, const S& intensity)
      : position_(position), intensity_(intensity) {
    if (!is_finite(position))
      throw std::invalid_argument("segpath::PointLight: position must be finite");
    // max_component(-I) <= 0 says every channel of I is >= 0 with the Spectrum operations only.
    if (!is_finite(intensity) || max_component(intensity * Scalar(-1)) > Scalar(0))
      throw std::invalid_argument(
          "segpath::PointLight: intensity must be finite and >= 0 in every channel, got " +
          least_channel_text(intensity));
  }

  [[nodiscard]] const Vec3<Scalar>& position() const noexcept { return position_; }
  [[nodiscard]] const S& intensity() const noexcept { return intensity_; }
  /// The light's endpoint (PointKind::point; the normal is only a reference axis).
  [[nodiscard]] SurfacePoint<Scalar> point() const noexcept {
    return SurfacePoint<Scalar>::at_point(position_);
  }
  /// Whether `p` is this light's endpoint (a delta position matches only itself).
  [[nodiscard]] bool is_own_point(const SurfacePoint<Scalar>& p) const noexcept {
    return p.kind == PointKind::point && p.position == position_;
  }

  /// I at this light's endpoint in every direction, 0 at any other endpoint.
  [[nodiscard]] S radiance(const EmissionQuery<Scalar>& q) const noexcept {
    return is_own_point(q.point) ? intensity_ : S(Scalar(0));
  }

  /// The light's point (discrete probability 1) and a uniform direction (density 1/(4 pi)).
  [[nodiscard]] std::optional<EmissionSample<S>> sample_emission(
      const EmissionSampleQuery<Scalar>& q) const noexcept {
    const Vec3<Scalar> direction = square_to_uniform_sphere(q.u_direction);
    return in_place_optional<EmissionSample<S>>(point(), direction, intensity_, Scalar(1),
                                                square_to_uniform_sphere_pdf<Scalar>(), true);
  }

  [[nodiscard]] EmissionPdf<Scalar> pdf_emission(const EmissionPdfQuery<Scalar>& q) const noexcept {
    if (!is_own_point(q.point)) return EmissionPdf<Scalar>{};
    return EmissionPdf<Scalar>{Scalar(1), square_to_uniform_sphere_pdf<Scalar>()};
  }

  /// The light's point with probability 1; nullopt for a receiver at the light's position.
  [[nodiscard]] std::optional<EmitterTowardsSample<S>> sample_towards(
      const EmitterTowardsQuery<Scalar>& q) const noexcept {
    const Vec3<Scalar> delta = q.receiver.position - position_;
    if (q.receiver.kind != PointKind::direction && !(glm::dot(delta, delta) > Scalar(0)))
      return std::nullopt;
    return in_place_optional<EmitterTowardsSample<S>>(point(), intensity_, Scalar(1), true);
  }

  /// 1 for this light's own point, 0 for any other endpoint.
  [[nodiscard]] Scalar pdf_towards(const EmitterPdfTowardsQuery<Scalar>& q) const noexcept {
    return is_own_point(q.point) ? Scalar(1) : Scalar(0);
  }

 private:
  Vec3<Scalar> position_;
  S intensity_;
};

}  // namespace segpath
