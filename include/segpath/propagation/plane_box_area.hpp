// The area of a plane clipped to an axis-aligned box: the support area |K(y)| of the voxel
// kernel (SPEC 1.2: 1 over the area of the plane through the cluster's mean position with its
// mean normal, clipped to the voxel).
#pragma once

#include "segpath/core/vec.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

namespace segpath {

/// Area of {x : n . (x - p) = 0} inside [lo, hi]. The section of a plane and a box is a
/// convex polygon whose vertices are the plane's crossings of the box's 12 edges; its area is
/// |sum of cross products| / 2 after ordering the vertices by angle about their centroid.
/// Returns 0 for a plane that misses the box or a degenerate normal.
template <Real T>
[[nodiscard]] inline T plane_box_area(const Vec3<T>& p, const Vec3<T>& normal, const Vec3<T>& lo, const Vec3<T>& hi) noexcept {
  const T len = glm::length(normal);
  if (!(len > T(0)) || !std::isfinite(len)) return T(0);
  const Vec3<T> n = normal / len;
  // Work in double: the polygon ordering is sensitive to rounding in float.
  std::array<glm::dvec3, 12> vertices{};
  std::size_t count = 0;
  const glm::dvec3 dn(n), dp(p), dlo(lo), dhi(hi);
  auto corner = [&](int i) { return glm::dvec3(i & 1 ? dhi.x : dlo.x, i & 2 ? dhi.y : dlo.y, i & 4 ? dhi.z : dlo.z); };
  for (int a = 0; a < 8; ++a)
    for (int bit = 1; bit < 8; bit <<= 1) {
      if (a & bit) continue;
      const int b = a | bit;
      const glm::dvec3 ca = corner(a), cb = corner(b);
      const double da = glm::dot(dn, ca - dp), db = glm::dot(dn, cb - dp);
      if ((da > 0 && db > 0) || (da < 0 && db < 0) || da == db) continue;
      const double t = da / (da - db);
      if (count < vertices.size()) vertices[count++] = ca + (cb - ca) * t;
    }
  if (count < 3) return T(0);
  glm::dvec3 centroid(0);
  for (std::size_t i = 0; i < count; ++i) centroid += vertices[i];
  centroid /= double(count);
  // An in-plane basis to sort the vertices by angle.
  const glm::dvec3 helper = std::abs(dn.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  const glm::dvec3 u = glm::normalize(glm::cross(dn, helper)), v = glm::cross(dn, u);
  std::array<double, 12> angle{};
  for (std::size_t i = 0; i < count; ++i) {
    const glm::dvec3 d = vertices[i] - centroid;
    angle[i] = std::atan2(glm::dot(d, v), glm::dot(d, u));
  }
  std::array<std::size_t, 12> order{};
  for (std::size_t i = 0; i < count; ++i) order[i] = i;
  std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(count),
            [&](std::size_t i, std::size_t j) { return angle[i] < angle[j]; });
  glm::dvec3 twice_area(0);
  for (std::size_t k = 0; k < count; ++k)
    twice_area += glm::cross(vertices[order[k]] - centroid, vertices[order[(k + 1) % count]] - centroid);
  return T(0.5 * std::abs(glm::dot(twice_area, dn)));
}

}  // namespace segpath
