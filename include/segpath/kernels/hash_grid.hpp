// A spatial hash grid for the range queries of kernel junctions (photon gathering, VCM
// merging with the disk kernel of N19): built once per iteration from light-subpath ends,
// queried with "every item within radius r of p", in a deterministic order.
#pragma once

#include "segpath/core/vec.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace segpath {

/// Items are indices the caller chooses (e.g. light-vertex numbers); the grid keeps a copy of
/// their positions. Cells have edge 2r, so a query ball of radius r touches at most 2 x 2 x 2
/// cells; cells are hashed into as many buckets as there are items (a power of two). Buckets
/// are filled by a stable counting sort, so a query visits items bucket by bucket and, within
/// a bucket, in the order they were given to build(): the same input gives the same visiting
/// order on every machine and thread count. build() reuses its storage (no allocation once the
/// capacity suffices); queries never allocate.
template <Real T>
class HashGrid {
 public:
  /// Builds the grid for query radius `radius` (> 0, finite) over `items`, whose positions are
  /// `position_of(item)`. Items with non-finite positions are left out.
  template <class PositionOf>
  void build(std::span<const std::uint32_t> items, T radius, PositionOf&& position_of) {
    radius_ = radius;
    radius2_ = radius * radius;
    inv_cell_ = T(1) / (T(2) * radius);
    std::size_t buckets = 1;
    while (buckets < items.size()) buckets <<= 1u;
    mask_ = buckets - 1;
    bucket_start_.assign(buckets + 1, 0);
    item_bucket_.clear();
    staged_.clear();
    for (const std::uint32_t item : items) {
      const Vec3<T> p = position_of(item);
      if (!is_finite(p)) continue;
      const auto c = cell_of(p);
      if (!c) continue;
      const std::size_t b = bucket(*c);
      staged_.push_back(Entry{p, item});
      item_bucket_.push_back(static_cast<std::uint32_t>(b));
      ++bucket_start_[b + 1];
    }
    for (std::size_t b = 0; b < buckets; ++b) bucket_start_[b + 1] += bucket_start_[b];
    entries_.resize(staged_.size());
    cursor_.assign(bucket_start_.begin(), bucket_start_.end() - 1);
    for (std::size_t i = 0; i < staged_.size(); ++i) entries_[cursor_[item_bucket_[i]]++] = staged_[i];
  }

  [[nodiscard]] std::size_t size() const noexcept { return entries_.size(); }
  [[nodiscard]] T radius() const noexcept { return radius_; }

  /// Calls f(item, position) for every item with |position - p| < radius.
  template <class F>
  void for_each_within(const Vec3<T>& p, F&& f) const noexcept(noexcept(f(std::uint32_t{}, p))) {
    if (entries_.empty() || !is_finite(p)) return;
    const auto lo = cell_of(p - Vec3<T>(radius_));
    const auto hi = cell_of(p + Vec3<T>(radius_));
    if (!lo || !hi) return;
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
          for (std::size_t i = bucket_start_[b]; i < bucket_start_[b + 1]; ++i) {
            const Vec3<T> d = entries_[i].position - p;
            if (glm::dot(d, d) < radius2_) f(entries_[i].item, entries_[i].position);
          }
        }
  }

 private:
  struct Entry {
    Vec3<T> position;
    std::uint32_t item;
  };
  using Cell = std::array<std::int64_t, 3>;

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
  std::vector<std::size_t> bucket_start_, cursor_;
  std::vector<std::uint32_t> item_bucket_;
  std::vector<Entry> staged_, entries_;
};

}  // namespace segpath
