// The segment pool of one filtering iteration (SPEC 1.9): every segment the techniques drew,
// structure of arrays, with the flags that say which technique drew it and which techniques
// its ends offer (a technique sample is a pooled segment whose end was continued).
#pragma once

#include "segpath/algorithms/filtering/record_list.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/segment.hpp"
#include "segpath/core/spectrum.hpp"

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace segpath::filtering {

/// One iteration's segments, structure of arrays (memory O(#segments)). Drawn in path order;
/// on voxels with the path-conditioned weighting renumbered after the clustering
/// (slot_order.hpp: an array added here must be renumbered there too).
template <Real T, Spectrum S>
struct Pool {
  std::vector<Segment<T>> segments;
  std::vector<Vec3<T>> first_direction, last_direction;  ///< unit, at x and at y (equal unless a chain)
  std::vector<S> chain, emitted;                         ///< delta-vertex throughput; chain * L_e(y)
  std::vector<T> geometry, density, sensor_weight;       ///< G, D and W for sensor segments
  std::vector<std::uint32_t> pixel;
  /// The segment whose technique sample drew this one: a camera successor's or next-event
  /// segment's predecessor on its camera path, a light predecessor's successor on its light
  /// path; no_parent for the unconditional draws (sensor, light start, extra techniques) and bridges.
  std::vector<std::uint32_t> parent;
  std::vector<std::uint16_t> flags;
  /// The segments each pooled one stands for: 1, or the pieces of a chain through delta
  /// bounces. Paths are limited to max_length of these (propagation/segment_budget.hpp).
  std::vector<std::uint16_t> pieces;
  std::uint64_t bridge_targets = 0;       ///< M: light technique samples (bridges on)
  std::uint64_t next_event_segments = 0;  ///< camera-born segments drawn by light sampling
  [[nodiscard]] std::size_t size() const noexcept { return flags.size(); }
  [[nodiscard]] std::size_t bytes_per_segment() const noexcept {
    return sizeof(Segment<T>) + 2 * sizeof(Vec3<T>) + 2 * sizeof(S) + 3 * sizeof(T) + 2 * sizeof(std::uint32_t) +
           2 * sizeof(std::uint16_t);
  }
  /// Room for n segments in every array append fills: appends up to n then move nothing.
  void reserve(std::size_t n) {
    segments.reserve(n), first_direction.reserve(n), last_direction.reserve(n), chain.reserve(n), geometry.reserve(n);
    sensor_weight.reserve(n), pixel.reserve(n), density.reserve(n), parent.reserve(n), flags.reserve(n), pieces.reserve(n);
  }
  /// What release_geometry() frees, per segment.
  static constexpr std::size_t geometry_bytes_per_segment = sizeof(Segment<T>) + 2 * sizeof(Vec3<T>) + sizeof(S) + sizeof(std::uint32_t);
  /// Frees what only the drawing, the support, the densities and the transfer's set-up read:
  /// the end points, the directions, the chain throughput and the parents (more than half of a
  /// segment's bytes). The propagation's sweeps and the gather read the rest.
  void release_geometry() noexcept {
    // Moved from an empty vector: `= {}` would assign an empty list and keep the capacity.
    segments = decltype(segments){};
    first_direction = decltype(first_direction){};
    last_direction = decltype(last_direction){};
    chain = decltype(chain){};
    parent = decltype(parent){};
  }
};

/// Appends the generators' records, chunk after chunk (in parallel over chunks); a record's
/// parent indexes its own chunk, the pool's the pool.
template <Real T, Spectrum S, ParallelFor P>
void append(Pool<T, S>& pool, const std::vector<RecordList<T, S>>& chunks, const P& parallel_for) {
  std::vector<std::size_t> base(chunks.size() + 1, pool.size());
  for (std::size_t c = 0; c < chunks.size(); ++c) base[c + 1] = base[c] + chunks[c].size();
  const std::size_t total = base.back();
  if (total >= no_parent)
    throw std::length_error("segpath::SegmentFiltering: a pass's pool of " + std::to_string(total) +
                            " segments is more than its 32-bit indices allow (" + std::to_string(no_parent - 1) +
                            "): use more pixel passes or fewer light paths (beta)");
  pool.segments.resize(total), pool.first_direction.resize(total), pool.last_direction.resize(total);
  pool.chain.resize(total), pool.geometry.resize(total), pool.sensor_weight.resize(total), pool.pixel.resize(total);
  pool.density.resize(total);
  pool.parent.resize(total), pool.flags.resize(total), pool.pieces.resize(total);
  std::vector<std::uint64_t> next_event(chunks.size(), 0);
  parallel_for(chunks.size(), [&](std::size_t c) {
    std::size_t i = base[c];
    // A parent precedes its children in its list: its segment is in the pool already.
    const auto segment_of = [&](std::uint32_t parent) -> const Segment<T>& { return pool.segments[base[c] + parent]; };
    chunks[c].unpack(segment_of, [&](const RecordFields<T, S>& r, const SurfacePoint<T>& x, const SurfacePoint<T>& y) {
      pool.segments[i].x = x;
      pool.segments[i].y = y;
      pool.first_direction[i] = r.first_direction;
      pool.last_direction[i] = r.last_direction;
      pool.chain[i] = r.chain;
      pool.geometry[i] = r.geometry;
      pool.sensor_weight[i] = r.sensor_weight;
      pool.density[i] = r.density;
      pool.pixel[i] = r.pixel;
      pool.parent[i] = r.parent == no_parent ? no_parent : std::uint32_t(base[c] + r.parent);
      pool.flags[i] = r.flags;
      pool.pieces[i] = r.pieces;
      next_event[c] += r.next_event ? 1 : 0;
      ++i;
    });
  });
  for (const auto n : next_event) pool.next_event_segments += n;
}

// Which segments each conditional technique can produce: a camera successor any segment but
// one with a Dirac light end (N31) or a kept chain; a light predecessor (or the light start,
// through delta bounces) ends its ray at a surface hit, so never a segment whose x is off the
// manifold (a sensor segment), a Dirac light end or a kept chain; a bridge any straight segment
// between two surface points.
template <class Pl>
[[nodiscard]] bool camera_reachable(const Pl& pool, std::size_t s) noexcept {
  return !(pool.flags[s] & (delta_light | kept_density));
}
template <class Pl>
[[nodiscard]] bool light_reachable(const Pl& pool, std::size_t s) noexcept {
  return !(pool.flags[s] & (delta_light | kept_density)) && pool.segments[s].x.kind == PointKind::surface;
}
template <class Pl>
[[nodiscard]] bool bridge_reachable(const Pl& pool, std::size_t s) noexcept {
  return !(pool.flags[s] & (chain_segment | delta_light)) && pool.segments[s].x.kind == PointKind::surface &&
         pool.segments[s].y.kind == PointKind::surface;
}
/// The targets of bridge segments: the light technique samples (light-born segments whose
/// surface x tried a predecessor), as the path-conditioned weighting takes them
/// (ConditionedInputs::bridge_target_term): its junctions leave a target's term out of the
/// bridge density, and in a factorised cluster the targets are the third class of starts.
template <class Pl>
[[nodiscard]] bool is_bridge_target(const Pl& pool, std::size_t i) noexcept {
  return (pool.flags[i] & light_technique) != 0;
}
/// A light start from a Dirac light (point light, sun) continued through delta bounces: no other
/// technique draws such a chain (a camera chain cannot end on a Dirac), so its balance weight is
/// 1 and its denominator, N_L times its first segment's density, is kept from the draw (its G is
/// the first segment's: G w is the photon's 1 / (N_L p_position p_direction)). So is a sky's
/// chain where no camera successor draws (PhF). A light predecessor's chain is never kept.
template <class Pl>
[[nodiscard]] bool kept_chain(const Pl& pool, std::size_t s) noexcept {
  return (pool.flags[s] & kept_density) != 0;
}
/// Whether a delta scattering at p from `fixed` to `sampled` crosses the surface.
template <Real T>
[[nodiscard]] bool is_transmission(const SurfacePoint<T>& p, const Vec3<T>& fixed, const Vec3<T>& sampled) noexcept {
  return glm::dot(fixed, p.normal) * glm::dot(sampled, p.normal) < T(0);
}

}  // namespace segpath::filtering
