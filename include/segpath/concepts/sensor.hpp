// The Sensor concept: importance W_rho(s_1) of a pixel, sampling of first segments'
// sensor ends (N29), their densities, and the inverse mapping for light tracing.
// Customization points: pixel_count(), sample_ray(SensorSampleQuery),
//   importance(SensorQuery), pdf(SensorQuery).
#pragma once

#include "segpath/core/surface_point.hpp"

#include <concepts>
#include <cstdint>
#include <optional>

namespace segpath {

template <Real T>
struct SensorSampleQuery {
  std::uint32_t pixel = 0;
  Vec2<T> u_position;   ///< lens / sensor area position
  Vec2<T> u_direction;  ///< position within the pixel
};

/// The sensor end x_1 of a first segment and the direction towards y_1.
/// `importance` is W_rho with the cosine at x_1 folded in when `origin` is a `point`
/// endpoint (pinhole); the densities are in area (or discrete, for a point) and solid angle
/// measure. The first segment's estimator factor is W G / p = importance * cos_x /
/// (pdf_position * pdf_direction) where cos_x = 1 for a `point` origin.
template <Real T>
struct SensorSample {
  SurfacePoint<T> origin;
  Vec3<T> direction;
  T importance = 0;
  T pdf_position = 0;
  T pdf_direction = 0;
};

/// A ray leaving (or arriving at) the sensor at `origin` in `direction` (unit, away from
/// the sensor).
template <Real T>
struct SensorQuery {
  const SurfacePoint<T>& origin;
  Vec3<T> direction;
};

template <Real T>
struct SensorResponse {
  std::uint32_t pixel = 0;
  T importance = 0;
};

template <Real T>
struct SensorPdf {
  T position = 0;
  T direction = 0;
};

namespace detail {
template <class C>
concept HasPixelCount = requires(const C& c) {
  { c.pixel_count() } -> std::convertible_to<std::uint32_t>;
};
template <class C, class T>
concept HasSampleRay = requires(const C& c, const SensorSampleQuery<T>& q) {
  { c.sample_ray(q) } -> std::same_as<std::optional<SensorSample<T>>>;
};
template <class C, class T>
concept HasImportance = requires(const C& c, const SensorQuery<T>& q) {
  { c.importance(q) } -> std::same_as<std::optional<SensorResponse<T>>>;
};
template <class C, class T>
concept HasSensorPdf = requires(const C& c, const SensorQuery<T>& q) {
  { c.pdf(q) } -> std::same_as<SensorPdf<T>>;
};
}  // namespace detail

/// A camera or measurement device. Syntactic requirements, for scalar T:
///  1. `c.pixel_count()`: the number of pixels (measurements rho);
///  2. `c.sample_ray(SensorSampleQuery)` returns std::optional<SensorSample>;
///  3. `c.importance(SensorQuery)` returns the pixel a ray belongs to and its W, or nullopt;
///  4. `c.pdf(SensorQuery)` returns the position and direction densities of sample_ray.
/// Semantic requirements:
///  5. sample_ray(q) for pixel p gives importance(origin, direction) == {p, importance}
///     and pdf(origin, direction) == {pdf_position, pdf_direction} (for pixel p);
///  6. sensors with delta directions (a radiance probe) return pdf 0 and importance nullopt
///     for rays they did not generate themselves.
template <class C, class T>
concept Sensor = Real<T> && detail::HasPixelCount<C> && detail::HasSampleRay<C, T> &&
                 detail::HasImportance<C, T> && detail::HasSensorPdf<C, T>;

}  // namespace segpath
