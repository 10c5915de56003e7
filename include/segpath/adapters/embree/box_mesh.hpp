// An axis-aligned box as a triangle mesh for EmbreeManifold: a room seen from inside (normals
// inwards) or a closed object (normals outwards), each face two triangles.
#pragma once

#include "segpath/adapters/embree.hpp"

#include <array>
#include <cstdint>

namespace segpath {

/// Which way a box mesh's geometric normals point.
enum class BoxFacing : std::uint8_t { inwards, outwards };

/// The box [lower, upper] as 12 triangles, appended to `mesh` (its positions and triangles;
/// nothing else of it changes).
template <Real T>
void append_box(typename EmbreeManifold<T>::Mesh& mesh, const Vec3<T>& lower, const Vec3<T>& upper, BoxFacing facing) {
  const auto base = std::uint32_t(mesh.positions.size());
  // Corner i has x from bit 0, y from bit 1, z from bit 2 (0: lower, 1: upper).
  for (std::uint32_t i = 0; i < 8; ++i)
    mesh.positions.push_back(Vec3<T>((i & 1) ? upper.x : lower.x, (i & 2) ? upper.y : lower.y, (i & 4) ? upper.z : lower.z));
  // Each face's corners wound so that cross(v1 - v0, v2 - v0) points into the box.
  constexpr std::array<std::array<std::uint32_t, 4>, 6> faces{{{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1},
                                                               {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}}};
  for (const auto& f : faces) {
    if (facing == BoxFacing::inwards) {
      mesh.triangles.push_back({base + f[0], base + f[1], base + f[2]});
      mesh.triangles.push_back({base + f[0], base + f[2], base + f[3]});
    } else {
      mesh.triangles.push_back({base + f[0], base + f[2], base + f[1]});
      mesh.triangles.push_back({base + f[0], base + f[3], base + f[2]});
    }
  }
}

/// The box [lower, upper] as a mesh of its own.
template <Real T>
[[nodiscard]] typename EmbreeManifold<T>::Mesh box_mesh(const Vec3<T>& lower, const Vec3<T>& upper, BoxFacing facing) {
  typename EmbreeManifold<T>::Mesh mesh;
  append_box<T>(mesh, lower, upper, facing);
  return mesh;
}

}  // namespace segpath
