// Orthonormal frames: the shading frame of a surface point and local <-> world transforms.
#pragma once

#include "segpath/core/vec.hpp"

namespace segpath {

/// Right-handed orthonormal basis (tangent, bitangent, normal).
template <Real T>
struct Frame {
  Vec3<T> tangent{1, 0, 0};
  Vec3<T> bitangent{0, 1, 0};
  Vec3<T> normal{0, 0, 1};

  /// Builds a frame around a unit normal without branches on the sign of n.z
  /// (Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 2017).
  [[nodiscard]] static Frame from_normal(const Vec3<T>& n) noexcept {
    const T sign = std::copysign(T(1), n.z);
    const T a = T(-1) / (sign + n.z);
    const T b = n.x * n.y * a;
    return Frame{Vec3<T>(T(1) + sign * n.x * n.x * a, sign * b, -sign * n.x),
                 Vec3<T>(b, sign + n.y * n.y * a, -n.y), n};
  }

  [[nodiscard]] Vec3<T> to_local(const Vec3<T>& v) const noexcept {
    return Vec3<T>(glm::dot(v, tangent), glm::dot(v, bitangent), glm::dot(v, normal));
  }
  [[nodiscard]] Vec3<T> to_world(const Vec3<T>& v) const noexcept {
    return tangent * v.x + bitangent * v.y + normal * v.z;
  }
};

}  // namespace segpath
