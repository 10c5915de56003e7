// Vector aliases over GLM, templated on the scalar type (float and double).
#pragma once

#include "segpath/config.hpp"

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <concepts>
#include <numbers>

namespace segpath {

/// The scalar types segpath is instantiated with: float and double.
template <class T>
concept Real = std::floating_point<T>;

template <Real T> using Vec2 = glm::vec<2, T, glm::defaultp>;
template <Real T> using Vec3 = glm::vec<3, T, glm::defaultp>;

template <Real T> inline constexpr T pi = std::numbers::pi_v<T>;
template <Real T> inline constexpr T inv_pi = std::numbers::inv_pi_v<T>;

template <Real T> [[nodiscard]] constexpr bool is_finite(const Vec3<T>& v) noexcept {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

template <Real T> [[nodiscard]] constexpr T length_squared(const Vec3<T>& v) noexcept {
  return glm::dot(v, v);
}

}  // namespace segpath
