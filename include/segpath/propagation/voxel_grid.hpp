// Position-and-normal voxel keys for segment endpoints (SPEC 1.2, voxel support): a grid of
// cell size h, shifted by a per-iteration jitter so quantisation turns into noise, and the
// normal's dominant axis and sign, so the two sides of a thin wall never share a cluster.
#pragma once

#include "segpath/core/rng.hpp"
#include "segpath/core/surface_point.hpp"

#include <array>
#include <cmath>
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
      throw std::invalid_argument("segpath::VoxelGrid: cell size must be finite and > 0, got " + std::to_string(cell_size));
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

}  // namespace segpath
