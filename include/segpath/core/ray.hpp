// Rays: an origin and a unit direction.
#pragma once

#include "segpath/core/vec.hpp"

namespace segpath {

template <Real T>
struct Ray {
  Vec3<T> origin{};
  Vec3<T> direction{0, 0, 1};  ///< unit length

  [[nodiscard]] Vec3<T> at(T t) const noexcept { return origin + direction * t; }
};

}  // namespace segpath
