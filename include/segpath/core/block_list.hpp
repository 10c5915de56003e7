// A list that keeps its elements in fixed-size blocks that never move: the per-chunk lists a
// parallel stage fills before its results are laid end to end (filtering's path records, VCM's
// light-subpath ends). A std::vector grown by doubling copies its elements and leaves its
// outgrown buffers as holes in the heap that the large arrays allocated after it cannot reuse
// (docs/figures.md, sessions 27 and 31); blocks of one size are reused by the next list.
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

namespace segpath {

/// Elements in blocks of `BlockSize`. clear() keeps the blocks for the next fill, so a list
/// refilled every iteration allocates only when it grows past its largest fill; release()
/// returns them.
template <class V, std::size_t BlockSize = 4096>
class BlockList {
  static_assert(BlockSize > 0);

 public:
  using value_type = V;
  static constexpr std::size_t block_size = BlockSize;

  BlockList() = default;
  /// A copy holds the elements only (the blocks they need), not the blocks clear() kept. If an
  /// element's copy throws, the elements copied so far are destroyed.
  BlockList(const BlockList& other) : BlockList() {
    for (std::size_t i = 0; i < other.size_; ++i) push_back(other[i]);
  }
  /// Copy and swap: on an exception the list is unchanged.
  BlockList& operator=(const BlockList& other) {
    if (this != &other) {
      BlockList copy(other);
      swap(copy);
    }
    return *this;
  }
  void swap(BlockList& other) noexcept {
    blocks_.swap(other.blocks_);
    std::swap(size_, other.size_);
  }
  BlockList(BlockList&& other) noexcept : blocks_(std::move(other.blocks_)), size_(std::exchange(other.size_, 0)) {
    other.blocks_.clear();
  }
  BlockList& operator=(BlockList&& other) noexcept {
    if (this != &other) {
      release();
      blocks_ = std::move(other.blocks_);
      other.blocks_.clear();
      size_ = std::exchange(other.size_, 0);
    }
    return *this;
  }
  ~BlockList() { release(); }

  void push_back(const value_type& v) {
    if (size_ == blocks_.size() * block_size) blocks_.push_back(Block(std::allocator<value_type>{}.allocate(block_size)));
    std::construct_at(blocks_[size_ / block_size].get() + size_ % block_size, v);
    ++size_;
  }
  [[nodiscard]] value_type& operator[](std::size_t i) noexcept { return blocks_[i / block_size][i % block_size]; }
  [[nodiscard]] const value_type& operator[](std::size_t i) const noexcept { return blocks_[i / block_size][i % block_size]; }
  [[nodiscard]] std::size_t size() const noexcept { return size_; }
  [[nodiscard]] bool empty() const noexcept { return size_ == 0; }
  /// Bytes of the blocks held, in use or kept by clear().
  [[nodiscard]] std::size_t capacity_bytes() const noexcept { return blocks_.size() * block_size * sizeof(value_type); }

  /// Copies the elements, in order, to out[0, size()).
  template <class OutputIt>
  OutputIt copy_to(OutputIt out) const {
    for (std::size_t b = 0; b * block_size < size_; ++b) {
      const value_type* first = blocks_[b].get();
      out = std::copy(first, first + std::min(block_size, size_ - b * block_size), out);
    }
    return out;
  }

  /// Ends the elements' lifetimes and keeps the blocks.
  void clear() noexcept {
    destroy_elements();
    size_ = 0;
  }
  /// Ends the elements' lifetimes and frees the blocks.
  void release() noexcept {
    clear();
    blocks_.clear();
  }

 private:
  struct Deallocate {
    void operator()(value_type* block) const noexcept { std::allocator<value_type>{}.deallocate(block, block_size); }
  };
  using Block = std::unique_ptr<value_type[], Deallocate>;
  void destroy_elements() noexcept {
    if constexpr (!std::is_trivially_destructible_v<value_type>)
      for (std::size_t b = 0; b * block_size < size_; ++b)
        std::destroy_n(blocks_[b].get(), std::min(block_size, size_ - b * block_size));
  }
  std::vector<Block> blocks_;
  std::size_t size_ = 0;
};

}  // namespace segpath
