// Endpoint clustering for propagation (SPEC 1.8 step 2): every segment endpoint gets a voxel
// key; after a sort, each run of equal keys is one cluster, holding the segments that start
// there (x ends) and those that end there (y ends). Each segment is in at most two clusters.
// Refs are also numbered by slot (their rank among the refs of the same end), so that
// propagation can keep what it needs in cluster order and read it in order.
#pragma once

#include "segpath/core/segment.hpp"
#include "segpath/propagation/plane_box_area.hpp"
#include "segpath/propagation/voxel_grid.hpp"

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

namespace segpath {

inline constexpr std::uint32_t no_cluster = 0xffffffffu;

/// One endpoint in a cluster: which segment and which end.
struct EndpointRef {
  VoxelKey key;
  std::uint32_t segment = 0;
  std::uint8_t end = 0;  ///< 0: the x end (the segment starts here), 1: the y end (it ends here)

  friend constexpr bool operator<(const EndpointRef& a, const EndpointRef& b) noexcept {
    if (a.key != b.key) return a.key < b.key;
    if (a.end != b.end) return a.end < b.end;
    return a.segment < b.segment;
  }
};

/// A cluster: refs[begin, middle) are segments starting in it, refs[middle, end) segments
/// ending in it; `kernel` is the voxel kernel value 1/|K| (0 when the support is degenerate).
/// Refs are also numbered by slot, their rank among the refs of the same end (starting or
/// ending) over all clusters: data kept per slot is laid out in cluster order. `slot` is the
/// starting slot of refs[begin].
template <Real T>
struct Cluster {
  std::uint32_t begin = 0, middle = 0, end = 0;
  std::uint32_t slot = 0;
  T kernel = 0;

  [[nodiscard]] std::uint32_t starting_count() const noexcept { return middle - begin; }
  [[nodiscard]] std::uint32_t ending_count() const noexcept { return end - middle; }
  /// The slot of starting ref r in [begin, middle).
  [[nodiscard]] std::uint32_t starting_slot(std::uint32_t r) const noexcept { return slot + (r - begin); }
  /// The slot of ending ref r in [middle, end): the refs before it less the starting ones.
  [[nodiscard]] std::uint32_t ending_slot(std::uint32_t r) const noexcept { return r - slot - (middle - begin); }
};

/// The clusters of one iteration. Memory: one EndpointRef per endpoint, three ids per segment
/// and one per slot, O(#segments). Deterministic: the sort order is a total order.
template <Real T>
class Clustering {
 public:
  Clustering() = default;

  /// Clusters the endpoints of `segments` on `grid`. Endpoints that are not surface points
  /// (pinholes, points at infinity) join no cluster. `canonical` maps a point to the position
  /// its voxel key is computed from: the identity, or for periodic domains (a flat torus) the
  /// representative in the fundamental cell, so that all images of a point share a cluster.
  template <class Canonical>
  void build(const VoxelGrid<T>& grid, std::span<const Segment<T>> segments, const Canonical& canonical) {
    refs_.clear();
    clusters_.clear();
    cluster_of_x_.assign(segments.size(), no_cluster);
    cluster_of_y_.assign(segments.size(), no_cluster);
    ending_slot_of_.assign(segments.size(), no_cluster);
    refs_.reserve(2 * segments.size());
    auto key_of = [&](const SurfacePoint<T>& p) {
      SurfacePoint<T> q = p;
      q.position = canonical(p);
      return grid.key(q);
    };
    for (std::uint32_t i = 0; i < segments.size(); ++i) {
      if (const auto kx = key_of(segments[i].x); kx.valid) refs_.push_back({kx.key, i, 0});
      if (const auto ky = key_of(segments[i].y); ky.valid) refs_.push_back({ky.key, i, 1});
    }
    std::sort(refs_.begin(), refs_.end());
    std::uint32_t slot = 0;
    for (std::uint32_t b = 0; b < refs_.size();) {
      std::uint32_t e = b, m = b;
      while (e < refs_.size() && refs_[e].key == refs_[b].key) {
        if (refs_[e].end == 0) m = e + 1;
        ++e;
      }
      const auto id = static_cast<std::uint32_t>(clusters_.size());
      Cluster<T> c{b, m, e, slot, T(0)};
      slot += m - b;
      Vec3<T> mean_position(0), mean_normal(0);
      for (std::uint32_t r = b; r < e; ++r) {
        const Segment<T>& s = segments[refs_[r].segment];
        const SurfacePoint<T>& p = refs_[r].end == 0 ? s.x : s.y;
        mean_position += canonical(p);
        mean_normal += p.normal;
        (refs_[r].end == 0 ? cluster_of_x_ : cluster_of_y_)[refs_[r].segment] = id;
      }
      mean_position /= T(e - b);
      const auto box = grid.bounds(refs_[b].key);
      const T area = plane_box_area(mean_position, mean_normal, box[0], box[1]);
      c.kernel = area > T(0) ? T(1) / area : T(0);
      clusters_.push_back(c);
      b = e;
    }
    starting_segment_.resize(starting_slot_count());
    ending_segment_.resize(ending_slot_count());
    for (const Cluster<T>& c : clusters_) {
      for (std::uint32_t r = c.begin; r < c.middle; ++r) starting_segment_[c.starting_slot(r)] = refs_[r].segment;
      for (std::uint32_t r = c.middle; r < c.end; ++r) {
        ending_segment_[c.ending_slot(r)] = refs_[r].segment;
        ending_slot_of_[refs_[r].segment] = c.ending_slot(r);
      }
    }
  }

  void build(const VoxelGrid<T>& grid, std::span<const Segment<T>> segments) {
    build(grid, segments, [](const SurfacePoint<T>& p) { return p.position; });
  }

  [[nodiscard]] std::span<const Cluster<T>> clusters() const noexcept { return clusters_; }
  [[nodiscard]] std::span<const EndpointRef> refs() const noexcept { return refs_; }
  /// The number of starting refs: the size of data kept per starting slot.
  [[nodiscard]] std::size_t starting_slot_count() const noexcept {
    return clusters_.empty() ? 0 : clusters_.back().slot + clusters_.back().starting_count();
  }
  /// The number of ending refs: the size of data kept per ending slot.
  [[nodiscard]] std::size_t ending_slot_count() const noexcept { return refs_.size() - starting_slot_count(); }
  /// The segment of every starting (ending) slot: the refs' segments without the keys, in
  /// slot order.
  [[nodiscard]] std::span<const std::uint32_t> starting_segments() const noexcept { return starting_segment_; }
  [[nodiscard]] std::span<const std::uint32_t> ending_segments() const noexcept { return ending_segment_; }
  /// The cluster a segment starts in (its x end), or no_cluster.
  [[nodiscard]] std::uint32_t cluster_of_x(std::uint32_t segment) const noexcept { return cluster_of_x_[segment]; }
  /// The cluster a segment ends in (its y end), or no_cluster.
  [[nodiscard]] std::uint32_t cluster_of_y(std::uint32_t segment) const noexcept { return cluster_of_y_[segment]; }
  /// The ending slot of a segment (of its y end), or no_cluster.
  [[nodiscard]] std::uint32_t ending_slot_of(std::uint32_t segment) const noexcept { return ending_slot_of_[segment]; }
  [[nodiscard]] std::size_t bytes_per_segment() const noexcept {
    if (cluster_of_x_.empty()) return 0;
    return (refs_.capacity() * sizeof(EndpointRef) + clusters_.capacity() * sizeof(Cluster<T>) +
            (3 * cluster_of_x_.capacity() + starting_segment_.capacity() + ending_segment_.capacity()) *
                sizeof(std::uint32_t)) /
           cluster_of_x_.size();
  }

 private:
  std::vector<EndpointRef> refs_;
  std::vector<Cluster<T>> clusters_;
  std::vector<std::uint32_t> cluster_of_x_, cluster_of_y_, ending_slot_of_;
  std::vector<std::uint32_t> starting_segment_, ending_segment_;
};

}  // namespace segpath
