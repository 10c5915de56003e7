// The average pixel footprint of a scene's sensor: the unit in which the kernel methods choose
// their automatic kernel size (the paper: "initial support ~ 4x the average pixel footprint").
#pragma once

#include "segpath/concepts/scene.hpp"

#include <cmath>
#include <cstdint>

namespace segpath {

/// The average, over the pixel centres of every 7th pixel (deterministic and cheap), of the
/// distance to the first hit times the side of the pixel's solid angle (1 / sqrt of the
/// sensor's direction density). `fallback` when no centre ray hits anything.
template <Scene Scn>
[[nodiscard]] typename Scn::Scalar pixel_footprint(const Scn& scene, typename Scn::Scalar fallback = typename Scn::Scalar(2.5e-3)) {
  using T = typename Scn::Scalar;
  const auto& sensor = scene.sensor();
  double sum = 0;
  std::uint64_t count = 0;
  for (std::uint32_t p = 0; p < sensor.pixel_count(); p += 7) {
    const auto ray = sensor.sample_ray(SensorSampleQuery<T>{p, Vec2<T>(T(0.5)), Vec2<T>(T(0.5))});
    if (!ray || !(ray->pdf_direction > T(0))) continue;
    const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{ray->origin.position, ray->direction}});
    if (!hit) continue;
    sum += double(hit->distance) / std::sqrt(double(ray->pdf_direction));
    ++count;
  }
  return count ? T(sum / double(count)) : fallback;
}

}  // namespace segpath
