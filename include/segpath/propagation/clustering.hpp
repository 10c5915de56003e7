// Endpoint clustering for propagation (SPEC 1.8 step 2): every segment endpoint gets a voxel
// key; after a sort, each run of equal keys is one cluster, holding the segments that start
// there (x ends) and those that end there (y ends). Each segment is in at most two clusters.
// Refs are also numbered by slot (their rank among the refs of the same end), so that
// propagation can keep what it needs in cluster order and read it in order.
#pragma once

#include "segpath/core/format.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/radix_sort.hpp"
#include "segpath/core/segment.hpp"
#include "segpath/kernels/voxel.hpp"
#include "segpath/propagation/junction_support.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace segpath {

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

/// How Clustering::build orders the refs; both give the same order, (key, end, segment).
enum class EndpointSort : std::uint8_t {
  radix,      ///< LSD radix sort of packed 64-bit codes (the default when the key ranges fit)
  comparison  ///< std::sort on EndpointRef::operator< (forced, or the fallback)
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

/// The clusters of one iteration, a JunctionSupport (propagation/junction_support.hpp) whose
/// groups are the clusters. Memory: three ids per segment and one per slot, O(#segments);
/// during build only, per endpoint an EndpointRef and an 8-byte code, or the radix sort's two
/// codes (the refs are freed while it runs, and its scratch before they are decoded), the refs
/// kept after it only on request (keep_refs, for inspection). Deterministic: the sort order is a total order, and the
/// parallel steps write disjoint outputs.
template <Real T>
class Clustering {
 public:
  using Scalar = T;
  /// A cluster's junction sums may factorise (PropagationInputs::factorised).
  static constexpr bool factorisable = true;
  /// A segment's x end is in at most one cluster.
  static constexpr bool single_start = true;

  Clustering() = default;

  /// Clusters the endpoints of `segments` on `grid`. Endpoints that are not surface points
  /// (pinholes, points at infinity) join no cluster. `canonical` maps a point to the position
  /// its voxel key is computed from: the identity, or for periodic domains (a flat torus) the
  /// representative in the fundamental cell, so that all images of a point share a cluster.
  /// Keys and clusters are computed on `parallel_for`; the result does not depend on it.
  template <class Canonical, ParallelFor P = SerialFor>
  void build(const VoxelGrid<T>& grid, std::span<const Segment<T>> segments, const Canonical& canonical,
             const P& parallel_for = {}) {
    const std::size_t n = segments.size();
    if (n > std::size_t(std::numeric_limits<std::uint32_t>::max() / 2))
      throw std::invalid_argument("segpath::Clustering: too many segments for 32-bit refs: " + std::to_string(n));
    clusters_.clear();
    cluster_of_x_.assign(n, no_cluster);
    cluster_of_y_.assign(n, no_cluster);
    ending_slot_of_.assign(n, no_cluster);
    build_peak_bytes_ = 0;
    compute_keys(grid, segments, canonical, parallel_for);
    note_peak();
    sort_refs(parallel_for);
    cut_clusters();
    fill_clusters(grid, segments, canonical, parallel_for);
    note_peak();
    // The slots hold the refs' segments in the same order; only their keys and ends are lost.
    if (!keep_refs_) std::vector<EndpointRef>().swap(refs_);
  }

  void build(const VoxelGrid<T>& grid, std::span<const Segment<T>> segments) {
    build(grid, segments, [](const SurfacePoint<T>& p) { return p.position; });
  }

  /// Forces std::sort (for comparisons); otherwise the radix sort runs whenever the packed
  /// codes fit in 64 bits.
  void force_comparison_sort(bool on) noexcept { force_comparison_ = on; }
  /// The sort the last build ran.
  [[nodiscard]] EndpointSort last_sort() const noexcept { return last_sort_; }

  /// Keeps the sorted refs after build (refs()); off by default, they cost 48 bytes per segment.
  void keep_refs(bool on) noexcept { keep_refs_ = on; }

  [[nodiscard]] std::span<const Cluster<T>> clusters() const noexcept { return clusters_; }
  /// The endpoint refs in cluster order, empty unless keep_refs(true) was set before build.
  [[nodiscard]] std::span<const EndpointRef> refs() const noexcept { return refs_; }
  /// The number of starting refs: the size of data kept per starting slot.
  [[nodiscard]] std::size_t starting_slot_count() const noexcept {
    return clusters_.empty() ? 0 : clusters_.back().slot + clusters_.back().starting_count();
  }
  /// The number of ending refs: the size of data kept per ending slot.
  [[nodiscard]] std::size_t ending_slot_count() const noexcept { return ending_segment_.size(); }
  /// The segment of every starting (ending) slot: the refs' segments without the keys, in
  /// slot order.
  [[nodiscard]] std::span<const std::uint32_t> starting_segments() const noexcept { return starting_segment_; }
  [[nodiscard]] std::span<const std::uint32_t> ending_segments() const noexcept { return ending_segment_; }
  /// The segments starting (ending) in cluster c: refs [begin, middle) ([middle, end)).
  [[nodiscard]] std::span<const std::uint32_t> starting_segments(std::size_t c) const noexcept {
    return std::span<const std::uint32_t>(starting_segment_).subspan(clusters_[c].slot, clusters_[c].starting_count());
  }
  [[nodiscard]] std::span<const std::uint32_t> ending_segments(std::size_t c) const noexcept {
    const Cluster<T>& cl = clusters_[c];
    return std::span<const std::uint32_t>(ending_segment_).subspan(cl.ending_slot(cl.middle), cl.ending_count());
  }
  /// The cluster a segment starts in (its x end), or no_cluster.
  [[nodiscard]] std::uint32_t cluster_of_x(std::uint32_t segment) const noexcept { return cluster_of_x_[segment]; }
  /// The cluster a segment ends in (its y end), or no_cluster.
  [[nodiscard]] std::uint32_t cluster_of_y(std::uint32_t segment) const noexcept { return cluster_of_y_[segment]; }
  /// The ending slot of a segment (of its y end), or no_cluster.
  [[nodiscard]] std::uint32_t ending_slot_of(std::uint32_t segment) const noexcept { return ending_slot_of_[segment]; }
  /// JunctionSupport: the clusters as groups.
  [[nodiscard]] std::size_t group_count() const noexcept { return clusters_.size(); }
  [[nodiscard]] std::size_t segment_count() const noexcept { return cluster_of_x_.size(); }
  [[nodiscard]] SlotRange ending_slots(std::size_t c) const noexcept {
    const Cluster<T>& cl = clusters_[c];
    const std::uint32_t first = cl.ending_slot(cl.middle);
    return {first, first + cl.ending_count()};
  }
  [[nodiscard]] SlotRange starting_slots(std::size_t c) const noexcept {
    return {clusters_[c].slot, clusters_[c].slot + clusters_[c].starting_count()};
  }
  [[nodiscard]] T kernel(std::size_t c) const noexcept { return clusters_[c].kernel; }

  /// Renames the segments: segment s becomes new_of_old[s] (a permutation of [0, #segments),
  /// else std::invalid_argument). Every cluster keeps its slots in the same order, so per-slot
  /// data is unchanged; only the segment ids they name (and the per-segment lookups) follow the
  /// new numbering. Kept refs (keep_refs) keep their order, no longer sorted by segment: a
  /// clustering built afresh on the renamed segments would order each cluster's slots by the new
  /// ids instead.
  template <ParallelFor P = SerialFor>
  void renumber(std::span<const std::uint32_t> new_of_old, const P& parallel_for = {}) {
    const std::size_t n = cluster_of_x_.size();
    if (new_of_old.size() != n)
      throw std::invalid_argument("segpath::Clustering::renumber: " + std::to_string(new_of_old.size()) +
                                  " new ids for " + std::to_string(n) + " segments");
    std::vector<bool> taken(n, false);
    for (const std::uint32_t t : new_of_old) {
      if (t >= n || taken[t])
        throw std::invalid_argument("segpath::Clustering::renumber: not a permutation of the " + std::to_string(n) +
                                    " segments (new id " + std::to_string(t) + (t >= n ? " out of range)" : " twice)"));
      taken[t] = true;
    }
    // Everything allocated before anything changes: an exception leaves the clustering as it was.
    std::vector<std::uint32_t> x(n), y(n), slot(n);
    for_blocks(n, parallel_for, [&](std::size_t s) {
      x[new_of_old[s]] = cluster_of_x_[s];
      y[new_of_old[s]] = cluster_of_y_[s];
      slot[new_of_old[s]] = ending_slot_of_[s];
    });
    cluster_of_x_.swap(x);
    cluster_of_y_.swap(y);
    ending_slot_of_.swap(slot);
    for_blocks(starting_segment_.size(), parallel_for, [&](std::size_t j) { starting_segment_[j] = new_of_old[starting_segment_[j]]; });
    for_blocks(ending_segment_.size(), parallel_for, [&](std::size_t i) { ending_segment_[i] = new_of_old[ending_segment_[i]]; });
    for (EndpointRef& r : refs_) r.segment = new_of_old[r.segment];
  }

  /// What the clustering holds per segment.
  [[nodiscard]] std::size_t bytes_per_segment() const noexcept {
    return cluster_of_x_.empty() ? 0 : held_bytes() / cluster_of_x_.size();
  }
  /// The most the last build held per segment at once, its temporaries included (the endpoint
  /// refs and the sort's buffers): the support stage's share of a render's peak.
  [[nodiscard]] std::size_t build_peak_bytes_per_segment() const noexcept {
    return cluster_of_x_.empty() ? 0 : build_peak_bytes_ / cluster_of_x_.size();
  }

 private:
  [[nodiscard]] std::size_t held_bytes() const noexcept {
    return refs_.capacity() * sizeof(EndpointRef) + clusters_.capacity() * sizeof(Cluster<T>) +
           (3 * cluster_of_x_.capacity() + starting_segment_.capacity() + ending_segment_.capacity()) * sizeof(std::uint32_t);
  }
  /// Records what is held now, with `temporaries` bytes besides (build_peak_bytes_per_segment).
  void note_peak(std::size_t temporaries = 0) noexcept {
    build_peak_bytes_ = std::max(build_peak_bytes_, held_bytes() + temporaries);
  }

  /// Segments per task when computing keys, refs per task when decoding, clusters per task.
  static constexpr std::size_t segment_chunk = 16384, ref_chunk = 32768, cluster_chunk = 8192;
  static constexpr std::uint8_t invalid_end = 2;

  /// A chunk's key bounds and valid-ref count, then its first ref.
  struct ChunkKeys {
    std::int32_t lo[3] = {std::numeric_limits<std::int32_t>::max(), std::numeric_limits<std::int32_t>::max(),
                          std::numeric_limits<std::int32_t>::max()};
    std::int32_t hi[3] = {std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::min(),
                          std::numeric_limits<std::int32_t>::min()};
    std::size_t count = 0, offset = 0;
    std::size_t out_of_range = 0;  ///< finite surface points beyond the grid's 32-bit cells
  };
  /// A code with its segment beside it, when code and segment do not fit in 64 bits together.
  struct WideCode {
    std::uint64_t code;
    std::uint32_t segment;
  };

  /// All 2n endpoint keys into refs_ (invalid ones marked), in parallel by chunks of segments.
  template <class Canonical, class P>
  void compute_keys(const VoxelGrid<T>& grid, std::span<const Segment<T>> segments, const Canonical& canonical,
                    const P& parallel_for) {
    const std::size_t n = segments.size();
    refs_.resize(2 * n);
    chunks_.assign((n + segment_chunk - 1) / segment_chunk, ChunkKeys{});
    parallel_for(chunks_.size(), [&](std::size_t c) {
      ChunkKeys& k = chunks_[c];
      const std::size_t e = std::min(n, (c + 1) * segment_chunk);
      for (std::size_t i = c * segment_chunk; i < e; ++i) {
        for (std::uint8_t end = 0; end < 2; ++end) {
          const SurfacePoint<T>& p = end == 0 ? segments[i].x : segments[i].y;
          SurfacePoint<T> q = p;
          q.position = canonical(p);
          const auto r = grid.key(q);
          refs_[2 * i + end] = {r.key, static_cast<std::uint32_t>(i), r.valid ? end : invalid_end};
          if (!r.valid) {
            k.out_of_range += q.kind == PointKind::surface && is_finite(q.position) ? 1 : 0;
            continue;
          }
          ++k.count;
          const std::int32_t v[3] = {r.key.x, r.key.y, r.key.z};
          for (int a = 0; a < 3; ++a) k.lo[a] = std::min(k.lo[a], v[a]), k.hi[a] = std::max(k.hi[a], v[a]);
        }
      }
    });
    // Such a point would join no cluster, and the chains through it would be lost unseen.
    std::size_t out_of_range = 0;
    for (const ChunkKeys& k : chunks_) out_of_range += k.out_of_range;
    if (out_of_range > 0) {
      throw std::invalid_argument("segpath::Clustering: " + std::to_string(out_of_range) +
                                  " segment ends lie more than 2^30 voxels from the origin at voxel size " +
                                  format_number(double(grid.cell_size()), 3) +
                                  ": use a larger voxel");
    }
  }

  /// Sorts the valid refs by (key, end, segment): refs are in segment order, x end first, so a
  /// stable sort on the (key, end) code keeps the segment order within equal codes.
  template <class P>
  void sort_refs(const P& parallel_for) {
    ChunkKeys all;
    for (ChunkKeys& k : chunks_) {
      k.offset = all.count;
      all.count += k.count;
      for (int a = 0; a < 3; ++a) all.lo[a] = std::min(all.lo[a], k.lo[a]), all.hi[a] = std::max(all.hi[a], k.hi[a]);
    }
    unsigned axis_bits[3] = {0, 0, 0};
    for (int a = 0; a < 3; ++a)
      if (all.count > 0) axis_bits[a] = unsigned(std::bit_width(std::uint64_t(std::int64_t(all.hi[a]) - all.lo[a])));
    // Code, most significant first: x - x_min, y - y_min, z - z_min, normal bin (3 bits), end.
    const unsigned code_bits = axis_bits[0] + axis_bits[1] + axis_bits[2] + 4;
    const unsigned segment_bits = unsigned(std::bit_width(std::uint64_t(cluster_of_x_.size())));
    last_sort_ = force_comparison_ || code_bits > 64 ? EndpointSort::comparison : EndpointSort::radix;
    if (last_sort_ == EndpointSort::comparison) {
      compact_refs();
      std::sort(refs_.begin(), refs_.end());
      return;
    }
    const unsigned shift_z = 4, shift_y = shift_z + axis_bits[2], shift_x = shift_y + axis_bits[1];
    auto code_of = [&](const EndpointRef& r) {
      return std::uint64_t(std::uint32_t(r.key.x - all.lo[0])) << shift_x |
             std::uint64_t(std::uint32_t(r.key.y - all.lo[1])) << shift_y |
             std::uint64_t(std::uint32_t(r.key.z - all.lo[2])) << shift_z | std::uint64_t(r.key.normal_bin) << 1 | r.end;
    };
    auto ref_of = [&](std::uint64_t code, std::uint32_t segment) {
      auto field = [&](unsigned shift, unsigned bits) {
        return std::int32_t(std::int64_t(code >> shift & ((std::uint64_t(1) << bits) - 1)));
      };
      VoxelKey key{std::int32_t(std::int64_t(all.lo[0]) + field(shift_x, axis_bits[0])),
                   std::int32_t(std::int64_t(all.lo[1]) + field(shift_y, axis_bits[1])),
                   std::int32_t(std::int64_t(all.lo[2]) + field(shift_z, axis_bits[2])),
                   std::uint8_t(code >> 1 & 7u)};
      return EndpointRef{key, segment, std::uint8_t(code & 1u)};
    };
    const std::size_t count = all.count;
    const std::size_t decode_chunks = (count + ref_chunk - 1) / ref_chunk;
    if (code_bits + segment_bits <= 64) {
      // The segment in the low bits: one 64-bit word per ref, sorted on its code bits.
      auto codes = std::make_unique_for_overwrite<std::uint64_t[]>(count);
      gather_codes(
          parallel_for, [&](const EndpointRef& r) { return code_of(r) << segment_bits | r.segment; }, codes.get());
      note_peak(count * sizeof(std::uint64_t));
      // The refs are rebuilt from the sorted codes: freed while the sort runs, and the buffer
      // that does not hold the result freed before they are (a BDPF render peaks in this stage
      // on some scenes: docs/figures.md, session 38).
      std::vector<EndpointRef>().swap(refs_);
      auto scratch = std::make_unique_for_overwrite<std::uint64_t[]>(count);
      note_peak(2 * count * sizeof(std::uint64_t));
      const auto sorted =
          radix_sort(std::span<std::uint64_t>(codes.get(), count), std::span<std::uint64_t>(scratch.get(), count),
                     segment_bits, code_bits, [](std::uint64_t w) { return w; }, counts_, parallel_for);
      if (sorted.data() == codes.get()) scratch.reset(); else codes.reset();
      const std::uint64_t segment_mask = (std::uint64_t(1) << segment_bits) - 1;
      refs_.resize(count);
      note_peak(count * sizeof(std::uint64_t));
      parallel_for(decode_chunks, [&](std::size_t c) {
        const std::size_t e = std::min(count, (c + 1) * ref_chunk);
        for (std::size_t i = c * ref_chunk; i < e; ++i)
          refs_[i] = ref_of(sorted[i] >> segment_bits, std::uint32_t(sorted[i] & segment_mask));
      });
    } else {
      const auto codes = std::make_unique_for_overwrite<WideCode[]>(count);
      const auto scratch = std::make_unique_for_overwrite<WideCode[]>(count);
      gather_codes(parallel_for, [&](const EndpointRef& r) { return WideCode{code_of(r), r.segment}; }, codes.get());
      note_peak(2 * count * sizeof(WideCode));
      const auto sorted =
          radix_sort(std::span<WideCode>(codes.get(), count), std::span<WideCode>(scratch.get(), count), 0,
                     code_bits, [](const WideCode& w) { return w.code; }, counts_, parallel_for);
      refs_.resize(count);
      parallel_for(decode_chunks, [&](std::size_t c) {
        const std::size_t e = std::min(count, (c + 1) * ref_chunk);
        for (std::size_t i = c * ref_chunk; i < e; ++i) refs_[i] = ref_of(sorted[i].code, sorted[i].segment);
      });
    }
  }

  /// The valid refs' codes, in ref order, each chunk at its offset.
  template <class P, class Encode, class Code>
  void gather_codes(const P& parallel_for, const Encode& encode, Code* codes) {
    parallel_for(chunks_.size(), [&](std::size_t c) {
      std::size_t o = chunks_[c].offset;
      const std::size_t e = std::min(refs_.size(), 2 * (c + 1) * segment_chunk);
      for (std::size_t i = 2 * c * segment_chunk; i < e; ++i)
        if (refs_[i].end != invalid_end) codes[o++] = encode(refs_[i]);
    });
  }

  /// Drops the invalid refs, keeping the order.
  void compact_refs() noexcept {
    std::size_t o = 0;
    for (std::size_t i = 0; i < refs_.size(); ++i)
      if (refs_[i].end != invalid_end) refs_[o++] = refs_[i];
    refs_.resize(o);
  }

  /// The runs of equal keys, their middles and starting slots.
  void cut_clusters() {
    std::uint32_t slot = 0;
    const auto size = static_cast<std::uint32_t>(refs_.size());
    for (std::uint32_t b = 0; b < size;) {
      std::uint32_t e = b, m = b;
      while (e < size && refs_[e].key == refs_[b].key) {
        if (refs_[e].end == 0) m = e + 1;
        ++e;
      }
      clusters_.push_back({b, m, e, slot, T(0)});
      slot += m - b;
      b = e;
    }
  }

  /// Per cluster, in parallel (disjoint outputs): the kernel from the mean plane in the voxel
  /// (SPEC 1.2), the cluster of every end and the segment of every slot.
  template <class Canonical, class P>
  void fill_clusters(const VoxelGrid<T>& grid, std::span<const Segment<T>> segments, const Canonical& canonical,
                     const P& parallel_for) {
    starting_segment_.resize(starting_slot_count());
    ending_segment_.resize(refs_.size() - starting_segment_.size());
    parallel_for((clusters_.size() + cluster_chunk - 1) / cluster_chunk, [&](std::size_t chunk) {
      const std::size_t last = std::min(clusters_.size(), (chunk + 1) * cluster_chunk);
      for (std::size_t id = chunk * cluster_chunk; id < last; ++id) {
        Cluster<T>& c = clusters_[id];
        Vec3<T> mean_position(0), mean_normal(0);
        for (std::uint32_t r = c.begin; r < c.end; ++r) {
          if (r + prefetch_distance < refs_.size()) prefetch_end(segments, refs_[r + prefetch_distance]);
          const Segment<T>& s = segments[refs_[r].segment];
          const SurfacePoint<T>& p = refs_[r].end == 0 ? s.x : s.y;
          mean_position += canonical(p);
          mean_normal += p.normal;
          (refs_[r].end == 0 ? cluster_of_x_ : cluster_of_y_)[refs_[r].segment] = static_cast<std::uint32_t>(id);
        }
        mean_position /= T(c.end - c.begin);
        const auto box = grid.bounds(refs_[c.begin].key);
        const T area = plane_box_area(mean_position, mean_normal, box[0], box[1]);
        c.kernel = area > T(0) ? T(1) / area : T(0);
        for (std::uint32_t r = c.begin; r < c.middle; ++r) starting_segment_[c.starting_slot(r)] = refs_[r].segment;
        for (std::uint32_t r = c.middle; r < c.end; ++r) {
          ending_segment_[c.ending_slot(r)] = refs_[r].segment;
          ending_slot_of_[refs_[r].segment] = c.ending_slot(r);
        }
      }
    });
  }

  /// Refs are in key order, their segments scattered: their ends are fetched ahead.
  static constexpr std::size_t prefetch_distance = 16;
  static void prefetch_end(std::span<const Segment<T>> segments, const EndpointRef& r) noexcept {
#if defined(__GNUC__) || defined(__clang__)
    const Segment<T>& s = segments[r.segment];
    __builtin_prefetch(r.end == 0 ? &s.x : &s.y);
#else
    (void)segments, (void)r;
#endif
  }

  std::vector<EndpointRef> refs_;
  std::vector<Cluster<T>> clusters_;
  std::vector<std::uint32_t> cluster_of_x_, cluster_of_y_, ending_slot_of_;
  std::vector<std::uint32_t> starting_segment_, ending_segment_;
  std::vector<ChunkKeys> chunks_;
  std::vector<std::uint32_t> counts_;
  std::size_t build_peak_bytes_ = 0;
  bool force_comparison_ = false, keep_refs_ = false;
  EndpointSort last_sort_ = EndpointSort::radix;
};

}  // namespace segpath
