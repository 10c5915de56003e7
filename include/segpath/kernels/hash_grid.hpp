// A spatial hash grid for the range queries of kernel junctions (photon gathering, VCM
// merging with the disk kernel of N19): built once per iteration from light-subpath ends,
// queried with "every item within radius r of p", in a deterministic order.
#pragma once

#include "segpath/core/parallel.hpp"
#include "segpath/core/scratch_vector.hpp"
#include "segpath/core/vec.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <utility>
#include <vector>

namespace segpath {

/// Items are what the caller stores with each position: an index it chooses (e.g. a light-vertex
/// number), or the data a query needs (VCM keeps each light end's merging state there, so a
/// query reads the items of a cell from one contiguous run instead of chasing an index into a
/// larger array per item). Cells have edge 2r, so a query ball of radius r touches at most
/// 2 x 2 x 2 cells; cells are hashed into as many buckets as there are items (a power of two).
/// Buckets are filled by a stable counting sort, so a query visits items bucket by bucket and,
/// within a bucket, in the order of their source index: the same input gives the same visiting
/// order on every machine and thread count. build() reuses its storage (no allocation once the
/// capacity suffices); queries never allocate.
template <Real T, class Item = std::uint32_t>
class HashGrid {
 public:
  /// Builds the grid for query radius `radius` (> 0, finite) over the sources 0 .. count - 1:
  /// `position_of(i)` is source i's position as std::optional<Vec3<T>> (nullopt: left out) and
  /// `item_of(i)` the Item stored for it. Sources with non-finite positions are left out too.
  /// position_of is called twice per source, item_of once per kept source, both in index order
  /// within each of `parallel_for`'s tasks. Each thread keeps a buffer the size of the largest
  /// of 256 bucket groups it sorted (1/256 of the items when they spread over many cells, up to
  /// all of them when they crowd into one). The result does not depend on
  /// `parallel_for`. Throws std::length_error for more than 2^31 sources.
  template <class PositionOf, class ItemOf, ParallelFor P = SerialFor>
  void build(std::size_t count, T radius, PositionOf&& position_of, ItemOf&& item_of, const P& parallel_for = {}) {
    entries_.clear();
    if (count > max_sources) throw std::length_error("segpath::HashGrid: more than 2^31 items");
    try {
      sort_into_buckets(count, radius, position_of, item_of, parallel_for);
    } catch (...) {
      entries_.clear();  // a build that throws leaves an empty grid
      throw;
    }
  }

  /// Builds the grid over `items` (each its own Item), at positions `position_of(item)`.
  template <class PositionOf, ParallelFor P = SerialFor>
  void build(std::span<const Item> items, T radius, PositionOf&& position_of, const P& parallel_for = {}) {
    build(
        items.size(), radius, [&](std::size_t i) { return std::optional<Vec3<T>>(position_of(items[i])); },
        [&](std::size_t i) -> const Item& { return items[i]; }, parallel_for);
  }

  [[nodiscard]] std::size_t size() const noexcept { return entries_.size(); }
  [[nodiscard]] T radius() const noexcept { return radius_; }
  /// Bytes of the arrays that grow with the sources and items, at their sizes after the last
  /// build (entries, the buckets, each source's bucket); not the fixed per-chunk and per-group
  /// counters, unused capacity, or the per-thread sort buffers (~1/256 of the items each).
  [[nodiscard]] std::size_t item_bytes() const noexcept {
    return (bucket_start_.size() + source_bucket_.size() + grouped_bucket_.size()) * sizeof(std::uint32_t) +
           entries_.size() * sizeof(Entry);
  }

  /// Calls f(item, position) for every item with |position - p| < radius (item: const Item&).
  template <class F>
  void for_each_within(const Vec3<T>& p, F&& f) const noexcept(noexcept(f(std::declval<const Item&>(), p))) {
    if (entries_.empty() || !is_finite(p)) return;
    const auto lo = cell_of(p - Vec3<T>(radius_));
    const auto hi = cell_of(p + Vec3<T>(radius_));
    if (!lo || !hi) return;
    // The (at most 8) buckets first, then their ranges, then their items: each stage's loads are
    // independent of each other, so their cache misses overlap instead of queueing.
    std::array<std::size_t, 8> visited{};
    std::size_t count = 0;
    for (std::int64_t z = (*lo)[2]; z <= (*hi)[2]; ++z)
      for (std::int64_t y = (*lo)[1]; y <= (*hi)[1]; ++y)
        for (std::int64_t x = (*lo)[0]; x <= (*hi)[0]; ++x) {
          const std::size_t b = bucket({x, y, z});
          bool seen = false;
          for (std::size_t i = 0; i < count; ++i) seen = seen || visited[i] == b;
          if (seen || count == visited.size()) continue;
          visited[count++] = b;
          prefetch(&bucket_start_[b]);
        }
    std::array<std::uint32_t, 8> begin{}, end{};
    for (std::size_t k = 0; k < count; ++k) {
      begin[k] = bucket_start_[visited[k]];
      end[k] = bucket_start_[visited[k] + 1];
      if (begin[k] != end[k]) prefetch(&entries_[begin[k]]);
    }
    for (std::size_t k = 0; k < count; ++k)
      for (std::size_t i = begin[k]; i < end[k]; ++i) {
        const Vec3<T> d = entries_[i].position - p;
        if (glm::dot(d, d) < radius2_) f(entries_[i].item, entries_[i].position);
      }
  }

 private:
  /// build()'s work (see there).
  template <class PositionOf, class ItemOf, ParallelFor P>
  void sort_into_buckets(std::size_t count, T radius, PositionOf& position_of, ItemOf& item_of, const P& parallel_for) {
    radius_ = radius;
    radius2_ = radius * radius;
    inv_cell_ = T(1) / (T(2) * radius);
    unsigned bucket_bits = 0;
    while ((std::size_t(1) << bucket_bits) < count) ++bucket_bits;
    const std::size_t buckets = std::size_t(1) << bucket_bits;
    mask_ = buckets - 1;
    // A stable counting sort by bucket in three parallel passes. Buckets form `groups` runs by
    // their high bits: (1) each source's bucket, counted per chunk of sources and group;
    // (2) the entries laid out group by group, in index order within a group; (3) per group, a
    // counting sort of its own run into its own buckets (a run small enough to stay cached).
    const unsigned group_bits = std::min(bucket_bits, max_group_bits);
    const unsigned group_shift = bucket_bits - group_bits;
    const std::size_t groups = std::size_t(1) << group_bits;
    const std::size_t chunks = std::min(count, max_chunks);
    const auto chunk_begin = [&](std::size_t c) { return count * c / chunks; };
    resize_for_overwrite(source_bucket_, count);
    chunk_group_next_.assign(chunks * groups, 0);
    parallel_for(chunks, [&](std::size_t c) {
      std::uint32_t* counts = chunk_group_next_.data() + c * groups;
      for (std::size_t i = chunk_begin(c); i < chunk_begin(c + 1); ++i) {
        source_bucket_[i] = skipped;
        const std::optional<Vec3<T>> p = position_of(i);
        if (!p || !is_finite(*p)) continue;
        const auto cell = cell_of(*p);
        if (!cell) continue;
        const auto b = static_cast<std::uint32_t>(bucket(*cell));
        source_bucket_[i] = b;
        ++counts[b >> group_shift];
      }
    });
    resize_for_overwrite(group_start_, groups + 1);
    std::uint32_t total = 0;
    for (std::size_t g = 0; g < groups; ++g) {
      group_start_[g] = total;
      for (std::size_t c = 0; c < chunks; ++c) {
        std::uint32_t& next = chunk_group_next_[c * groups + g];
        const std::uint32_t n = next;
        next = total;
        total += n;
      }
    }
    group_start_[groups] = total;
    // (2) reads the sources in index order (streaming), (3) sorts through a per-thread buffer
    // the size of one run, so the random writes of both stay within cached runs.
    resize_for_overwrite(grouped_bucket_, total);
    resize_for_overwrite(entries_, total);
    parallel_for(chunks, [&](std::size_t c) {
      std::uint32_t* next = chunk_group_next_.data() + c * groups;
      for (std::size_t i = chunk_begin(c); i < chunk_begin(c + 1); ++i) {
        const std::uint32_t b = source_bucket_[i];
        if (b == skipped) continue;
        const std::uint32_t k = next[b >> group_shift]++;
        entries_[k] = Entry{*position_of(i), item_of(i)};
        grouped_bucket_[k] = b;
      }
    });
    // Per group, bucket_start_[b + 1] counts bucket b, then holds its start, then (as the
    // placement's cursor) its end, which is the start of b + 1.
    resize_for_overwrite(bucket_start_, buckets + 1);
    bucket_start_[0] = 0;
    const std::size_t group_size = std::size_t(1) << group_shift;
    parallel_for(groups, [&](std::size_t g) {
      const std::size_t first = g * group_size;
      std::uint32_t* slot = bucket_start_.data() + first + 1;  // slot[b - first]
      std::fill(slot, slot + group_size, 0u);
      const std::uint32_t begin = group_start_[g], end = group_start_[g + 1];
      for (std::uint32_t k = begin; k != end; ++k) ++slot[grouped_bucket_[k] - first];
      std::uint32_t running = 0;  // relative to the run's start
      for (std::size_t b = 0; b < group_size; ++b) {
        const std::uint32_t n = slot[b];
        slot[b] = running;
        running += n;
      }
      thread_local std::vector<Entry> sorted;
      sorted.resize(end - begin);
      for (std::uint32_t k = begin; k != end; ++k) sorted[slot[grouped_bucket_[k] - first]++] = std::move(entries_[k]);
      std::move(sorted.begin(), sorted.end(), entries_.begin() + std::ptrdiff_t(begin));
      for (std::size_t b = 0; b < group_size; ++b) slot[b] += begin;
    });
  }

  struct Entry {
    Vec3<T> position;
    Item item;
  };
  static constexpr std::uint32_t skipped = ~std::uint32_t(0);  ///< never a bucket: buckets <= max_sources
  static constexpr std::size_t max_sources = std::size_t(1) << 31;
  static constexpr unsigned max_group_bits = 8;   ///< at most 256 bucket groups in build()
  static constexpr std::size_t max_chunks = 64;   ///< build()'s chunks of sources
  using Cell = std::array<std::int64_t, 3>;

  static void prefetch(const void* address) noexcept {
#if defined(__GNUC__) || defined(__clang__)
    __builtin_prefetch(address);
#else
    (void)address;
#endif
  }

  /// The cell of p, or nothing when its coordinates do not fit in 2^52.
  [[nodiscard]] std::optional<Cell> cell_of(const Vec3<T>& p) const noexcept {
    Cell c{};
    for (int i = 0; i < 3; ++i) {
      const double v = std::floor(double(p[i]) * double(inv_cell_));
      if (!(std::abs(v) < 0x1p52)) return std::nullopt;
      c[std::size_t(i)] = static_cast<std::int64_t>(v);
    }
    return c;
  }
  [[nodiscard]] std::size_t bucket(const Cell& c) const noexcept {
    const auto h = (static_cast<std::uint64_t>(c[0]) * 73856093ULL) ^ (static_cast<std::uint64_t>(c[1]) * 19349663ULL) ^
                   (static_cast<std::uint64_t>(c[2]) * 83492791ULL);
    return static_cast<std::size_t>((h ^ (h >> 29)) & mask_);
  }

  T radius_ = 0, radius2_ = 0, inv_cell_ = 0;
  std::size_t mask_ = 0;
  std::vector<std::uint32_t> bucket_start_;      ///< (at most 2^31 items, checked by build)
  std::vector<std::uint32_t> source_bucket_;     ///< build: per source, its bucket or skipped
  std::vector<std::uint32_t> chunk_group_next_;  ///< build: per chunk and group, a count, then a cursor
  std::vector<std::uint32_t> group_start_;       ///< build: per group, its first entry
  std::vector<std::uint32_t> grouped_bucket_;    ///< build: the bucket of each entry before (3)
  std::vector<Entry> entries_;
};

}  // namespace segpath
