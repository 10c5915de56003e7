// Warps from the unit square to common domains, each with its density (the Mitsuba triple
// square_to_X / square_to_X_pdf; inverse maps where a test needs them).
#pragma once

#include "segpath/core/vec.hpp"

#include <algorithm>
#include <cmath>

namespace segpath {

/// Uniform point in the unit disk (Shirley-Chiu concentric map); density 1/pi.
template <Real T>
[[nodiscard]] inline Vec2<T> square_to_uniform_disk(const Vec2<T>& u) noexcept {
  const T a = T(2) * u.x - T(1);
  const T b = T(2) * u.y - T(1);
  if (a == T(0) && b == T(0)) return Vec2<T>(0, 0);
  T r, phi;
  if (std::abs(a) > std::abs(b)) {
    r = a;
    phi = (pi<T> / T(4)) * (b / a);
  } else {
    r = b;
    phi = pi<T> / T(2) - (pi<T> / T(4)) * (a / b);
  }
  return Vec2<T>(r * std::cos(phi), r * std::sin(phi));
}

/// Cosine-weighted direction about +z (Malley's method); density cos(theta)/pi.
template <Real T>
[[nodiscard]] inline Vec3<T> square_to_cosine_hemisphere(const Vec2<T>& u) noexcept {
  const Vec2<T> d = square_to_uniform_disk(u);
  const T z = std::sqrt(std::max(T(0), T(1) - d.x * d.x - d.y * d.y));
  return Vec3<T>(d.x, d.y, z);
}
template <Real T>
[[nodiscard]] constexpr T square_to_cosine_hemisphere_pdf(const Vec3<T>& local) noexcept {
  return local.z > T(0) ? local.z * inv_pi<T> : T(0);
}

/// Uniform direction on the unit sphere; density 1/(4 pi).
template <Real T>
[[nodiscard]] inline Vec3<T> square_to_uniform_sphere(const Vec2<T>& u) noexcept {
  const T z = T(1) - T(2) * u.x;
  const T r = std::sqrt(std::max(T(0), T(1) - z * z));
  const T phi = T(2) * pi<T> * u.y;
  return Vec3<T>(r * std::cos(phi), r * std::sin(phi), z);
}
template <Real T>
[[nodiscard]] constexpr T square_to_uniform_sphere_pdf() noexcept {
  return T(1) / (T(4) * pi<T>);
}

/// Uniform direction on the hemisphere about +z; density 1/(2 pi).
template <Real T>
[[nodiscard]] inline Vec3<T> square_to_uniform_hemisphere(const Vec2<T>& u) noexcept {
  const T z = u.x;
  const T r = std::sqrt(std::max(T(0), T(1) - z * z));
  const T phi = T(2) * pi<T> * u.y;
  return Vec3<T>(r * std::cos(phi), r * std::sin(phi), z);
}
template <Real T>
[[nodiscard]] constexpr T square_to_uniform_hemisphere_pdf(const Vec3<T>& local) noexcept {
  return local.z > T(0) ? T(1) / (T(2) * pi<T>) : T(0);
}

/// Uniform barycentrics (b1, b2) on a triangle (b0 = 1 - b1 - b2); density 1/area.
template <Real T>
[[nodiscard]] inline Vec2<T> square_to_uniform_triangle(const Vec2<T>& u) noexcept {
  const T s = std::sqrt(u.x);
  return Vec2<T>(T(1) - s, u.y * s);
}

/// Uniform direction in the cone of half-angle acos(cos_max) about +z; density
/// 1/(2 pi (1 - cos_max)).
template <Real T>
[[nodiscard]] inline Vec3<T> square_to_uniform_cone(const Vec2<T>& u, T cos_max) noexcept {
  const T z = T(1) - u.x * (T(1) - cos_max);
  const T r = std::sqrt(std::max(T(0), T(1) - z * z));
  const T phi = T(2) * pi<T> * u.y;
  return Vec3<T>(r * std::cos(phi), r * std::sin(phi), z);
}
template <Real T>
[[nodiscard]] constexpr T square_to_uniform_cone_pdf(const Vec3<T>& local, T cos_max) noexcept {
  return local.z >= cos_max ? T(1) / (T(2) * pi<T> * (T(1) - cos_max)) : T(0);
}

}  // namespace segpath
