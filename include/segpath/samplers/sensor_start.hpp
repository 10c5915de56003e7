// The sequential sensor-start sampler (N29): p_W(s_1) proportional to W_rho(s_1) G(s_1).
// x_1 and the direction come from the sensor; y_1 is the first surface hit.
#pragma once

#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/geometry.hpp"
#include "segpath/core/in_place_optional.hpp"

#include <cstdint>
#include <optional>

namespace segpath {

template <Scene Scn>
class SensorStartSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// The technique parameter: the pixel whose importance is sampled.
  struct Technique {
    std::uint32_t pixel = 0;
  };
  /// Pinhole cameras and probes are deltas in position (and probes in direction).
  static constexpr bool is_dirac = true;

  /// Draws s_1 (y_1 the first hit, or the `direction` endpoint of an escaping ray) with pdf = p_pos(x_1) p_w(s^) |n_y . s^| / |x - y|^2 and factor W G(s_1)
  /// (visibility holds by construction: y_1 is the first hit).
  template <UniformSource<T> R>
  [[nodiscard]] std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique& t, R& rng) const noexcept {
    const Vec2<T> u_position = uniform2<T>(rng);
    const Vec2<T> u_direction = uniform2<T>(rng);
    const auto ray = scene.sensor().sample_ray(SensorSampleQuery<T>{t.pixel, u_position, u_direction});
    if (!ray) return std::nullopt;
    const T pdf_ray = ray->pdf_position * ray->pdf_direction;
    if (!(pdf_ray > T(0))) return std::nullopt;
    const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{ray->origin.position, ray->direction}});
    // A ray that leaves the scene ends at infinity (a `direction` endpoint), where an
    // environment emitter may shine; its density is in solid angle there.
    SurfacePoint<T> escaped;
    const SurfacePoint<T>& y = hit ? hit->point : (escaped = SurfacePoint<T>::at_infinity(ray->direction));
    const T distance = hit ? hit->distance : T(1);
    // W G / p: the |n_y . s^| / d^2 of G and of the density cancel.
    const T area_factor = solid_angle_to_area(T(1), ray->origin, y, ray->direction, distance);
    const T cos_x = endpoint_cosine(ray->origin, ray->direction);
    return in_place_optional<SegmentSample<S>>(Segment<T>{ray->origin, y}, ray->direction, S(ray->importance * cos_x * area_factor),
                                               pdf_ray * area_factor, S(ray->importance * cos_x / pdf_ray), false);
  }

  /// p(s | pixel) as if y were the first hit from x: ray_pdf(x, s^) |n_y . s^| / d^2, zero
  /// unless the sensor maps s to this pixel.
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    const Vec3<T> direction = s.direction();
    const auto response = scene.sensor().importance(SensorQuery<T>{s.x, direction});
    if (!response || response->pixel != t.pixel) return T(0);
    return solid_angle_to_area(ray_pdf(scene, s.x, direction), s.x, s.y);
  }

  /// p(s | pixel) (N29): unoccluded_pdf where y is the first hit from x, 0 otherwise.
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return visibility_masked(scene, s, unoccluded_pdf(scene, t, s));
  }

  /// The sensor's density p_pos(x) p_w(direction | x) of a primary ray from x, in the product
  /// of x's measure and solid angle at x (pixel-independent: the pixel selects, it does not
  /// weight). The part of (N29) a caller that pools sensor segments of every pixel needs.
  [[nodiscard]] static SEGPATH_FORCE_INLINE T ray_pdf(const Scn& scene, const SurfacePoint<T>& x,
                                                      const Vec3<T>& direction) noexcept {
    const SensorPdf<T> p = scene.sensor().pdf(SensorQuery<T>{x, direction});
    return p.position * p.direction;
  }

  /// |n_y . s^| / |x - y|^2 (1 for a `direction` end y): turns ray_pdf's solid angle at x into
  /// y's area measure; ray_pdf(x, s^) * area_jacobian(s) is unoccluded_pdf up to rounding
  /// (the multiplications are grouped differently).
  [[nodiscard]] static SEGPATH_FORCE_INLINE T area_jacobian(const Segment<T>& s) noexcept {
    return solid_angle_to_area(T(1), s.x, s.y);
  }
};

}  // namespace segpath
