// A radiance probe: each pixel measures the radiance arriving along one fixed ray. W and
// the sampling densities share one delta in position and one in direction, so W G / p = 1
// for the first segment, and a pixel's value is L(s_1) (N22).
#pragma once

#include "segpath/concepts/sensor.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/core/ray.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <vector>

namespace segpath {

template <Real T>
class ProbeSensor {
 public:
  /// One probe per ray: pixel i measures radiance arriving at rays[i].origin from
  /// rays[i].direction (unit, non-zero, finite).
  explicit ProbeSensor(std::vector<Ray<T>> rays) : rays_(std::move(rays)) {
    if (rays_.empty()) throw std::invalid_argument("segpath::ProbeSensor: needs at least one probe ray");
    for (auto& r : rays_) {
      const T len = glm::length(r.direction);
      if (!is_finite(r.origin) || !std::isfinite(len) || !(len > T(0)))
        throw std::invalid_argument("segpath::ProbeSensor: probe rays need a finite origin and a non-zero direction");
      r.direction /= len;
    }
  }

  [[nodiscard]] std::uint32_t pixel_count() const noexcept { return static_cast<std::uint32_t>(rays_.size()); }
  [[nodiscard]] const Ray<T>& probe(std::uint32_t pixel) const noexcept { return rays_[pixel]; }

  [[nodiscard]] std::optional<SensorSample<T>> sample_ray(const SensorSampleQuery<T>& q) const noexcept {
    if (q.pixel >= rays_.size()) return std::nullopt;
    const Ray<T>& r = rays_[q.pixel];
    return in_place_optional<SensorSample<T>>(SurfacePoint<T>::at_point(r.origin, r.direction), r.direction, T(1), T(1), T(1));
  }

  [[nodiscard]] std::optional<SensorResponse<T>> importance(const SensorQuery<T>& q) const noexcept {
    const auto pixel = find(q);
    if (!pixel) return std::nullopt;
    return in_place_optional<SensorResponse<T>>(*pixel, T(1));
  }

  [[nodiscard]] SensorPdf<T> pdf(const SensorQuery<T>& q) const noexcept {
    return find(q) ? SensorPdf<T>{T(1), T(1)} : SensorPdf<T>{};
  }

 private:
  /// The probe that generated exactly this ray (deltas match only themselves).
  std::optional<std::uint32_t> find(const SensorQuery<T>& q) const noexcept {
    if (q.origin.kind != PointKind::point) return std::nullopt;
    for (std::uint32_t i = 0; i < rays_.size(); ++i) {
      const T tolerance = T(64) * std::numeric_limits<T>::epsilon();
      if (q.origin.position == rays_[i].origin &&
          glm::dot(q.direction, rays_[i].direction) >= T(1) - tolerance)
        return i;
    }
    return std::nullopt;
  }

  std::vector<Ray<T>> rays_;
};

}  // namespace segpath
