// The disk support as an alternative to voxel clusters for propagation (SPEC 1.2, uniform
// kernel N19): the end y of a segment joins every segment start x within radius r whose normal
// agrees with n_y, K = 1 / (pi r^2). Disks around different ends overlap, so the junctions are
// stored as neighbour lists (both directions, compressed rows) instead of a partition.
#pragma once

#include "segpath/core/format.hpp"
#include "segpath/core/index_range.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/segment.hpp"
#include "segpath/kernels/hash_grid.hpp"
#include "segpath/propagation/junction_support.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <ranges>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace segpath {

/// Who joins whom under the disk kernel: for a segment s, `starting_near(s)` are the segments
/// s' whose x end lies in the support of y_s, in increasing id order; `ending_near(s')` is the
/// transpose (the segments t whose support around y_t holds x_s'). The relation is symmetric in
/// the two points (distance < r, n_x . n_y >= min_normal_cosine), so each list is also "every
/// technique sample whose kernel reaches this end". A segment is never in its own lists: it does
/// not join itself, nor draw itself (propagation/propagate.hpp). Memory: two ids per junction plus two
/// offsets per segment, O(#segments x occupancy).
///
/// As a JunctionSupport (propagation/junction_support.hpp): group s is segment s, its one
/// ending slot s, its starting slots the junctions of starting_near(s) (slot j holds the
/// segment starting_segments()[j]; a segment has one starting slot per disk holding its x end).
template <Real T>
class DiskJunctions {
 public:
  using Scalar = T;
  /// One end per group: nothing to factorise.
  static constexpr bool factorisable = false;
  /// A segment starts in every disk that holds its x end.
  static constexpr bool single_start = false;

  DiskJunctions() = default;

  /// Builds the lists for `segments` with disk radius `radius` (> 0, finite). `canonical`
  /// maps a point to the position the distance is measured at (see Clustering::build; on a
  /// periodic domain distances are not wrapped, so disks are cut at the fundamental cell's
  /// faces); ends that are not surface points join nothing. Deterministic for any
  /// `parallel_for`.
  template <class Canonical, ParallelFor P = SerialFor>
  void build(T radius, std::span<const Segment<T>> segments, const Canonical& canonical, T min_normal_cosine = T(0.5),
             const P& parallel_for = {}) {
    if (!(radius > T(0)) || !std::isfinite(radius))
      throw std::invalid_argument("segpath::DiskJunctions: radius must be finite and > 0, got " + format_number(double(radius)));
    if (!(min_normal_cosine >= T(-1) && min_normal_cosine <= T(1)))
      throw std::invalid_argument("segpath::DiskJunctions: min_normal_cosine must lie in [-1, 1], got " +
                                  format_number(double(min_normal_cosine)));
    radius_ = radius;
    kernel_ = T(1) / (pi<T> * radius * radius);
    const auto n = static_cast<std::uint32_t>(segments.size());
    std::vector<std::uint32_t> starts;
    for (std::uint32_t i = 0; i < n; ++i)
      if (segments[i].x.kind == PointKind::surface) starts.push_back(i);
    HashGrid<T> grid;
    grid.build(starts, radius, [&](std::uint32_t i) { return Vec3<T>(canonical(segments[i].x)); }, parallel_for);

    // Two passes over the ends (count, then fill), each parallel over chunks of segments.
    const T threshold = min_normal_cosine - T(8) * std::numeric_limits<T>::epsilon();
    auto for_each_start_near = [&](std::uint32_t s, auto&& f) {
      const SurfacePoint<T>& y = segments[s].y;
      if (y.kind != PointKind::surface) return;
      grid.for_each_within(Vec3<T>(canonical(y)), [&](std::uint32_t sp, const Vec3<T>&) {
        if (sp != s && glm::dot(segments[sp].x.normal, y.normal) >= threshold) f(sp);
      });
    };
    starting_offsets_.assign(std::size_t(n) + 1, 0);
    constexpr std::size_t chunk = 4096;
    const std::size_t chunks = chunk_count(n, chunk);
    for_chunks(n, chunks, parallel_for, [&](std::size_t begin, std::size_t end) {
      for (std::size_t s = begin; s < end; ++s) {
        std::uint32_t count = 0;
        for_each_start_near(std::uint32_t(s), [&](std::uint32_t) { ++count; });
        starting_offsets_[s + 1] = count;
      }
    });
    std::uint64_t total = 0;
    for (std::size_t s = 0; s < n; ++s) {
      total += starting_offsets_[s + 1];
      if (total > std::numeric_limits<std::uint32_t>::max())
        throw std::length_error("segpath::DiskJunctions: more than 2^32 junctions; use a smaller radius");
      starting_offsets_[s + 1] = std::uint32_t(total);
    }
    starting_.resize(starting_offsets_[n]);
    for_chunks(n, chunks, parallel_for, [&](std::size_t begin, std::size_t end) {
      for (std::size_t s = begin; s < end; ++s) {
        std::uint32_t* out = starting_.data() + starting_offsets_[s];
        std::uint32_t* cursor = out;
        for_each_start_near(std::uint32_t(s), [&](std::uint32_t sp) { *cursor++ = sp; });
        std::sort(out, cursor);
      }
    });
    // The transpose by counting sort: for each s' the ends t (in increasing id order).
    ending_offsets_.assign(std::size_t(n) + 1, 0);
    for (const std::uint32_t sp : starting_) ++ending_offsets_[sp + 1];
    for (std::size_t s = 0; s < n; ++s) ending_offsets_[s + 1] += ending_offsets_[s];
    ending_.resize(starting_.size());
    std::vector<std::uint32_t> cursor(ending_offsets_.begin(), ending_offsets_.end() - 1);
    for (std::uint32_t t = 0; t < n; ++t)
      for (std::uint32_t j = starting_offsets_[t]; j < starting_offsets_[t + 1]; ++j) ending_[cursor[starting_[j]]++] = t;
  }

  void build(T radius, std::span<const Segment<T>> segments) {
    build(radius, segments, [](const SurfacePoint<T>& p) { return p.position; });
  }

  [[nodiscard]] T radius() const noexcept { return radius_; }
  /// K = 1 / (pi r^2) for every junction (N19).
  [[nodiscard]] T kernel() const noexcept { return kernel_; }
  [[nodiscard]] std::size_t segment_count() const noexcept { return starting_offsets_.empty() ? 0 : starting_offsets_.size() - 1; }
  [[nodiscard]] std::size_t junction_count() const noexcept { return starting_.size(); }

  /// The segments starting in the disk around y_s.
  [[nodiscard]] std::span<const std::uint32_t> starting_near(std::uint32_t s) const noexcept {
    return {starting_.data() + starting_offsets_[s], starting_.data() + starting_offsets_[s + 1]};
  }
  /// The segments ending within the disk of x_s (whose disks hold x_s).
  [[nodiscard]] std::span<const std::uint32_t> ending_near(std::uint32_t s) const noexcept {
    return {ending_.data() + ending_offsets_[s], ending_.data() + ending_offsets_[s + 1]};
  }

  /// JunctionSupport: one group per segment.
  [[nodiscard]] std::size_t group_count() const noexcept { return segment_count(); }
  [[nodiscard]] SlotRange ending_slots(std::size_t s) const noexcept { return {std::uint32_t(s), std::uint32_t(s) + 1}; }
  [[nodiscard]] SlotRange starting_slots(std::size_t s) const noexcept {
    return {starting_offsets_[s], starting_offsets_[s + 1]};
  }
  [[nodiscard]] T kernel(std::size_t) const noexcept { return kernel_; }
  /// Ending slot s is segment s.
  [[nodiscard]] auto ending_segments() const noexcept {
    return IndexRange<std::uint32_t>(0, std::uint32_t(segment_count()));
  }
  /// The starting_near lists, concatenated.
  [[nodiscard]] std::span<const std::uint32_t> starting_segments() const noexcept { return starting_; }
  [[nodiscard]] std::uint32_t ending_slot_of(std::uint32_t s) const noexcept { return s; }

  [[nodiscard]] std::size_t bytes_per_segment() const noexcept {
    const std::size_t n = segment_count();
    if (n == 0) return 0;
    return (2 * starting_.capacity() + starting_offsets_.capacity() + ending_offsets_.capacity()) * sizeof(std::uint32_t) / n;
  }

 private:
  T radius_ = 0, kernel_ = 0;
  std::vector<std::uint32_t> starting_offsets_, starting_, ending_offsets_, ending_;
};

}  // namespace segpath
