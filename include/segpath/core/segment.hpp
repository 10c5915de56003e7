// Segments s = (x, y) and segment paths s_1..s_k (SPEC 1.1). Light flows from y to x;
// x is the end nearer the sensor. Consecutive segments need not touch.
#pragma once

#include "segpath/core/surface_point.hpp"

#include <array>
#include <cstddef>

namespace segpath {

template <Real T>
struct Segment {
  SurfacePoint<T> x;  ///< end nearer the sensor
  SurfacePoint<T> y;  ///< end nearer the light

  /// Unit direction s-hat from x towards y. For a `direction` endpoint y the stored
  /// `y.position` is that direction.
  [[nodiscard]] SEGPATH_FORCE_INLINE Vec3<T> direction() const noexcept {
    if (y.kind == PointKind::direction) return y.position;
    if (x.kind == PointKind::direction) return -x.position;
    return glm::normalize(y.position - x.position);
  }
  [[nodiscard]] T length_squared() const noexcept {
    return segpath::length_squared(y.position - x.position);
  }
};

/// A segment path of at most `MaxLength` segments in fixed storage: building one never
/// allocates, so it can live on the stack of a hot loop.
template <Real T, std::size_t MaxLength>
class SegmentPath {
 public:
  static constexpr std::size_t capacity = MaxLength;

  [[nodiscard]] std::size_t size() const noexcept { return size_; }
  [[nodiscard]] bool empty() const noexcept { return size_ == 0; }
  [[nodiscard]] bool full() const noexcept { return size_ == MaxLength; }

  /// Appends a segment; returns false (and drops it) when the path is full.
  bool push_back(const Segment<T>& s) noexcept {
    if (size_ == MaxLength) return false;
    segments_[size_++] = s;
    return true;
  }
  void pop_back() noexcept {
    if (size_ > 0) --size_;
  }
  void clear() noexcept { size_ = 0; }

  [[nodiscard]] const Segment<T>& operator[](std::size_t i) const noexcept { return segments_[i]; }
  [[nodiscard]] Segment<T>& operator[](std::size_t i) noexcept { return segments_[i]; }
  [[nodiscard]] const Segment<T>& back() const noexcept { return segments_[size_ - 1]; }
  [[nodiscard]] const Segment<T>* begin() const noexcept { return segments_.data(); }
  [[nodiscard]] const Segment<T>* end() const noexcept { return segments_.data() + size_; }

 private:
  std::array<Segment<T>, MaxLength> segments_{};
  std::size_t size_ = 0;
};

}  // namespace segpath
