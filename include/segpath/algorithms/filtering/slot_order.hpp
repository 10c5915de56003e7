// The support stage on voxels, continued: the pool renumbered in the clusters' ending-slot
// order. Paths are drawn, and pooled, in path order, but every later stage walks the
// clusters and reads the pool by slot (densities, factorisation, transfer, propagation); with the
// segments numbered in ending-slot order the reads by ending slot run through memory in order
// instead of at random (those by starting slot stay at random).
// A renaming only: every stage computes the same numbers in the same order, and since each pixel
// receives one sensor segment per pass, the image is the same bit for bit. SegmentFiltering
// renumbers where the propagation is path-conditioned (BDPF's default), where it pays most
// (docs/figures.md, session 34).
#pragma once

#include "segpath/algorithms/filtering/context.hpp"
#include "segpath/algorithms/filtering/record_list.hpp"
#include "segpath/algorithms/filtering/support.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/segment.hpp"
#include "segpath/core/surface_point.hpp"
#include "segpath/propagation/clustering.hpp"

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace segpath::filtering {

/// v[i] becomes v[old_of_new[i]] for every i, gathered into `next` (its storage reused).
template <class V, ParallelFor P>
void gather_by(std::vector<V>& v, std::span<const std::uint32_t> old_of_new, const P& parallel_for, std::vector<V> next = {}) {
  if (v.empty()) return;
  next.resize(v.size());
  for_blocks(v.size(), parallel_for, [&](std::size_t i) { next[i] = v[old_of_new[i]]; });
  v.swap(next);
}

/// The segments gathered like gather_by through a buffer of half their size, their x ends:
/// once the new x ends are aside, the old x ends are free to take the new y ends, which a
/// last pass moves into place (one more sequential pass than gather_by, half its buffer).
template <Real T, ParallelFor P>
void gather_segments_by(std::vector<Segment<T>>& v, std::span<const std::uint32_t> old_of_new, const P& parallel_for,
                        std::vector<SurfacePoint<T>> x_ends = {}) {
  x_ends.resize(v.size());
  for_blocks(v.size(), parallel_for, [&](std::size_t i) { x_ends[i] = v[old_of_new[i]].x; });
  for_blocks(v.size(), parallel_for, [&](std::size_t i) { v[i].x = v[old_of_new[i]].y; });
  for_blocks(v.size(), parallel_for, [&](std::size_t i) {
    v[i].y = v[i].x;
    v[i].x = x_ends[i];
  });
}

/// Renumbers the pool, the user techniques' densities and `clustering` so that the segments of
/// the ending slots come first, segment i in ending slot i, then those whose y end is in no
/// cluster, in their old order. `x_end_storage`: storage for gather_segments_by.
template <LightSampledScene Scn, ParallelFor P>
void order_by_slot(Context<Scn>& ctx, Clustering<typename Scn::Scalar>& clustering, const P& parallel_for,
                   std::vector<SurfacePoint<typename Scn::Scalar>> x_end_storage = {}) {
  auto& pool = ctx.pool;
  const std::size_t n = pool.size();
  if (clustering.segment_count() != n || !(ctx.extra_density.empty() || ctx.extra_density.size() == n))
    throw std::invalid_argument("segpath::filtering::order_by_slot: a clustering of " + std::to_string(clustering.segment_count()) +
                                " segments and " + std::to_string(ctx.extra_density.size()) + " user densities for a pool of " +
                                std::to_string(n));
  const auto ending = clustering.ending_segments();
  std::vector<std::uint32_t> old_of_new(ending.begin(), ending.end());
  old_of_new.reserve(n);
  for (std::uint32_t s = 0; s < n; ++s)
    if (clustering.ending_slot_of(s) == no_cluster) old_of_new.push_back(s);
  std::vector<std::uint32_t> new_of_old(n);
  for_blocks(n, parallel_for, [&](std::size_t i) { new_of_old[old_of_new[i]] = std::uint32_t(i); });
  gather_segments_by(pool.segments, old_of_new, parallel_for, std::move(x_end_storage));
  gather_by(pool.first_direction, old_of_new, parallel_for);
  gather_by(pool.last_direction, old_of_new, parallel_for);
  gather_by(pool.chain, old_of_new, parallel_for);
  gather_by(pool.emitted, old_of_new, parallel_for);
  gather_by(pool.geometry, old_of_new, parallel_for);
  gather_by(pool.density, old_of_new, parallel_for);
  gather_by(pool.sensor_weight, old_of_new, parallel_for);
  gather_by(pool.pixel, old_of_new, parallel_for);
  gather_by(pool.parent, old_of_new, parallel_for);
  for_blocks(n, parallel_for, [&](std::size_t i) {
    if (pool.parent[i] != no_parent) pool.parent[i] = new_of_old[pool.parent[i]];
  });
  gather_by(pool.flags, old_of_new, parallel_for);
  gather_by(pool.pieces, old_of_new, parallel_for);
  gather_by(ctx.extra_density, old_of_new, parallel_for);
  clustering.renumber(new_of_old, parallel_for);
}

/// What cluster_in_slot_order holds per segment besides the pool and the clustering's build
/// (Clustering::build_peak_bytes_per_segment): gather_segments_by's buffer, taken before the
/// build. The renumbering's other arrays (its two index maps, one array's gather, the
/// clustering's three lookups) come after the build's refs are freed and hold less than they did.
template <Real T>
inline constexpr std::size_t slot_order_bytes_per_segment = sizeof(SurfacePoint<T>);

/// The pool's clusters on the context's grid (cluster), then the pool in their slot order
/// (order_by_slot).
template <LightSampledScene Scn, ParallelFor P>
void cluster_in_slot_order(Context<Scn>& ctx, Clustering<typename Scn::Scalar>& clustering, const P& parallel_for) {
  // Taken before the clustering's temporaries, this buffer reuses the heap the path records
  // left. Taken after, a full segment copy raised the peak by up to 180 MB at 512 x 512; this
  // half buffer made no clear difference either way (docs/figures.md, sessions 34 and 39).
  std::vector<SurfacePoint<typename Scn::Scalar>> x_end_storage(ctx.pool.size());
  cluster(ctx, clustering, parallel_for);
  order_by_slot(ctx, clustering, parallel_for, std::move(x_end_storage));
}

}  // namespace segpath::filtering
