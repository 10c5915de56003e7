// A segment as a technique draws it, before pooling (Record), and the list a path generator
// fills with them (RecordList); pool.hpp's append copies the lists into the pool.
#pragma once

#include "segpath/core/segment.hpp"
#include "segpath/core/spectrum.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

namespace segpath::filtering {

inline constexpr std::uint32_t no_parent = 0xffffffffu;

/// A segment as a technique produces it, before pooling.
template <Real T, Spectrum S>
struct Record {
  Segment<T> segment;
  Vec3<T> first_direction, last_direction;
  S chain;
  T geometry = 0, sensor_weight = 0;
  /// Only for a kept chain (kept_chain): its MMIS denominator, N_L times its first segment's
  /// density; every other segment's is computed from the pool (densities.hpp).
  T density = 0;
  std::uint32_t pixel = 0;
  std::uint32_t parent = no_parent;  ///< index in the same generator's record list
  std::uint16_t flags = 0;
  std::uint16_t pieces = 1;  ///< Pool::pieces
  bool next_event = false;
};

/// One generator's records before pooling, in blocks that never move: no copies as the list
/// grows, and no outgrown buffers left as holes in the heap that the pool and the propagation's
/// large arrays cannot reuse (a std::vector's doubling did; docs/figures.md, session 27).
template <Real T, Spectrum S>
class RecordList {
 public:
  using value_type = Record<T, S>;
  /// Records per block (~0.6 MB in float, ~1.2 MB in double; a list takes whole blocks).
  static constexpr std::size_t block_size = 4096;

  RecordList() = default;
  RecordList(const RecordList&) = delete;
  RecordList& operator=(const RecordList&) = delete;
  RecordList(RecordList&& other) noexcept : blocks_(std::move(other.blocks_)), size_(std::exchange(other.size_, 0)) {}
  RecordList& operator=(RecordList&& other) noexcept {
    if (this != &other) {
      destroy();
      blocks_ = std::move(other.blocks_);
      size_ = std::exchange(other.size_, 0);
    }
    return *this;
  }
  ~RecordList() { destroy(); }

  void push_back(const value_type& r) {
    if (size_ % block_size == 0) {
      Block block(std::allocator<value_type>{}.allocate(block_size));
      blocks_.push_back(std::move(block));
    }
    std::construct_at(blocks_.back().get() + size_ % block_size, r);
    ++size_;
  }
  [[nodiscard]] value_type& operator[](std::size_t i) noexcept { return blocks_[i / block_size][i % block_size]; }
  [[nodiscard]] const value_type& operator[](std::size_t i) const noexcept { return blocks_[i / block_size][i % block_size]; }
  [[nodiscard]] std::size_t size() const noexcept { return size_; }

 private:
  struct Deallocate {
    void operator()(value_type* block) const noexcept { std::allocator<value_type>{}.deallocate(block, block_size); }
  };
  using Block = std::unique_ptr<value_type[], Deallocate>;
  /// Ends the records' lifetimes (a user's spectrum need not be trivially destructible) and frees the blocks.
  void destroy() noexcept {
    if constexpr (!std::is_trivially_destructible_v<value_type>)
      for (std::size_t b = 0; b < blocks_.size(); ++b)
        std::destroy_n(blocks_[b].get(), std::min(block_size, size_ - b * block_size));
    blocks_.clear();
    size_ = 0;
  }
  std::vector<Block> blocks_;
  std::size_t size_ = 0;
};

}  // namespace segpath::filtering
