// The voxel kernel of segment filtering (SPEC 1.2): endpoints are keyed by a jittered grid of
// cell size h and their normal's dominant axis and sign (so the two sides of a thin wall never
// share a voxel); two ends in one voxel join with K = 1 / |K(y)|, the area of the plane through
// the voxel's points (their mean position and mean normal) clipped to the voxel. The points of a
// pool are grouped by voxel in propagation/clustering.hpp.
#pragma once

#include "segpath/core/format.hpp"
#include "segpath/core/rng.hpp"
#include "segpath/core/surface_point.hpp"
#include "segpath/core/vec.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace segpath {


/// An exact voxel key (no hashing, so no collisions): integer cell coordinates and a normal
/// bin in 0..5 (+x, -x, +y, -y, +z, -z by the normal's dominant component).
struct VoxelKey {
  std::int32_t x = 0, y = 0, z = 0;
  std::uint8_t normal_bin = 0;

  friend constexpr auto operator<=>(const VoxelKey&, const VoxelKey&) noexcept = default;
};

/// The normal bin of a unit normal: its dominant axis and that component's sign.
template <Real T>
[[nodiscard]] constexpr std::uint8_t normal_bin(const Vec3<T>& n) noexcept {
  const T ax = std::abs(n.x), ay = std::abs(n.y), az = std::abs(n.z);
  if (ax >= ay && ax >= az) return n.x >= T(0) ? 0 : 1;
  if (ay >= az) return n.y >= T(0) ? 2 : 3;
  return n.z >= T(0) ? 4 : 5;
}

template <Real T>
class VoxelGrid {
 public:
  /// `cell_size` > 0 and finite; `jitter` in [0, 1)^3 shifts the grid by jitter * cell_size.
  explicit VoxelGrid(T cell_size, const Vec3<T>& jitter = Vec3<T>(0)) : cell_size_(cell_size), offset_(jitter * cell_size) {
    if (!(cell_size > T(0)) || !std::isfinite(cell_size))
      throw std::invalid_argument("segpath::VoxelGrid: cell size must be finite and > 0, got " + format_number(double(cell_size)));
    if (!(jitter.x >= T(0) && jitter.x < T(1) && jitter.y >= T(0) && jitter.y < T(1) && jitter.z >= T(0) && jitter.z < T(1)))
      throw std::invalid_argument("segpath::VoxelGrid: jitter must lie in [0, 1)^3");
    inv_cell_size_ = T(1) / cell_size;
  }

  /// The grid of one iteration: jitter drawn from the iteration's own random stream, so the
  /// clustering is reproducible whatever the thread count.
  [[nodiscard]] static VoxelGrid jittered(T cell_size, std::uint64_t seed, std::uint64_t iteration) {
    Pcg32 rng = Pcg32::for_sample(seed, 0x766f78656cULL /* "voxel" */, iteration);
    const T a = rng.uniform<T>(), b = rng.uniform<T>(), c = rng.uniform<T>();
    return VoxelGrid(cell_size, Vec3<T>(a, b, c));
  }

  [[nodiscard]] T cell_size() const noexcept { return cell_size_; }
  [[nodiscard]] const Vec3<T>& offset() const noexcept { return offset_; }

  /// The key of an endpoint; nullopt-like `valid = false` for non-surface or non-finite
  /// points, and for coordinates outside the 32-bit cell range.
  struct KeyResult {
    VoxelKey key;
    bool valid = false;
  };
  [[nodiscard]] KeyResult key(const SurfacePoint<T>& p) const noexcept {
    if (p.kind != PointKind::surface || !is_finite(p.position)) return {};
    const Vec3<T> c = (p.position - offset_) * inv_cell_size_;
    constexpr T limit = T(std::numeric_limits<std::int32_t>::max() / 2);
    if (!(std::abs(c.x) < limit && std::abs(c.y) < limit && std::abs(c.z) < limit)) return {};
    return {VoxelKey{static_cast<std::int32_t>(std::floor(c.x)), static_cast<std::int32_t>(std::floor(c.y)),
                     static_cast<std::int32_t>(std::floor(c.z)), normal_bin(p.normal)},
            true};
  }

  /// The axis-aligned box of a key's cell.
  [[nodiscard]] std::array<Vec3<T>, 2> bounds(const VoxelKey& k) const noexcept {
    const Vec3<T> lo = offset_ + Vec3<T>(T(k.x), T(k.y), T(k.z)) * cell_size_;
    return {lo, lo + Vec3<T>(cell_size_)};
  }

 private:
  T cell_size_;
  T inv_cell_size_ = 1;
  Vec3<T> offset_;
};


// ---- The kernel value: 1 / the area of the mean plane in the voxel -------------------


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
