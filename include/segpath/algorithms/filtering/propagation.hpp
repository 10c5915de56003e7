// Stage 5 of a filtering iteration: propagation (SPEC 1.8, Algorithm 1) over the pool's
// support with the chosen weighting: the paper's prod 1 / D (propagation/propagate.hpp) or the
// path-conditioned one (propagation/path_conditioned.hpp), with the factorised O(n + m) sums
// where the clusters allow. Returns L (weighted L for the path-conditioned weighting) and the
// G w (G) per segment that the gather multiplies by.
#pragma once

#include "segpath/algorithms/filtering/context.hpp"
#include "segpath/algorithms/filtering/factorisation.hpp"
#include "segpath/algorithms/filtering/light_side.hpp"
#include "segpath/algorithms/filtering/transfer.hpp"
#include "segpath/propagation/clustering.hpp"
#include "segpath/propagation/disk_junctions.hpp"
#include "segpath/propagation/junction_support.hpp"
#include "segpath/propagation/pair_table.hpp"
#include "segpath/propagation/path_conditioned.hpp"
#include "segpath/propagation/propagate.hpp"

#include <array>
#include <cstdint>
#include <type_traits>
#include <vector>

namespace segpath::filtering {

/// The path-conditioned propagation's memory per segment, besides the junction table
/// (FilteringOptions::transfer_cache_bytes) and the copies of FilteringStats::propagation_copy_bytes:
/// at most, per ending slot its W values, emission, end, class junctions and U index, per start
/// its W values, start and U index, per segment its light side (LightSide), the s-only factor
/// of q_l and its backtrack partner (backtrack_partners). The U values of the segments a
/// junction can force, and their indices, are in FilteringStats::forced_value_bytes.
template <Spectrum S>
inline constexpr std::size_t conditioned_bytes_per_segment =
    2 * sizeof(std::array<S, 2>) + sizeof(detail::ConditionedEmission<S>) + sizeof(detail::ConditionedEnd<spectrum_scalar_t<S>>) +
    sizeof(detail::ClassJunctions<S>) + sizeof(detail::ConditionedStart<spectrum_scalar_t<S>>) + 2 * sizeof(std::uint32_t) +
    2 * sizeof(spectrum_scalar_t<S>) + sizeof(std::uint32_t) + 1 + sizeof(std::uint32_t);

/// Of conditioned_bytes_per_segment, what propagate_conditioned_pool allocates after it freed
/// the pool's end points (PoolGeometry::release): all but the class junctions and the light side.
template <Spectrum S>
inline constexpr std::size_t conditioned_bytes_after_release = conditioned_bytes_per_segment<S> - sizeof(detail::ClassJunctions<S>) -
                                                               2 * sizeof(spectrum_scalar_t<S>) - sizeof(std::uint32_t) - 1;

/// Whether a propagation over voxel clusters frees the pool's end points, directions, chain
/// throughputs and parents (Pool::release_geometry) once it reads them no more, before its own
/// arrays are allocated: a render does (its peak is the propagation's), a caller that reads the
/// pool afterwards does not. Over disks the pool is always kept (the sweeps read it by segment).
enum class PoolGeometry : std::uint8_t { keep, release };

/// G(s) w(s) = G(s) / D(s) per segment (0 where no technique could draw it).
template <Real T, Spectrum S>
void weighted_geometry_of(const Pool<T, S>& pool, std::vector<T>& weighted_geometry) {
  weighted_geometry.resize(pool.size());
  for (std::size_t i = 0; i < pool.size(); ++i)
    weighted_geometry[i] = pool.density[i] > T(0) ? pool.geometry[i] / pool.density[i] : T(0);
}

/// Per segment, the partner no chain goes a round trip with (PropagationInputs::backtrack,
/// ConditionedInputs::backtrack): a light segment's is its light predecessor, a camera
/// successor's (or next-event segment's) its parent; no_cluster elsewhere.
template <Real T, Spectrum S, ParallelFor P>
void backtrack_partners(const Pool<T, S>& pool, std::vector<std::uint32_t>& backtrack, const P& parallel_for) {
  backtrack.assign(pool.size(), no_cluster);
  parallel_for(pool.size(), [&](std::size_t i) {
    const std::uint32_t t = pool.parent[i];
    if (t >= pool.size()) return;
    // One light predecessor per parent, so no two i write the same entry.
    if (pool.flags[i] & camera_born) backtrack[i] = t;
    else if (!(pool.flags[i] & not_light_born)) backtrack[t] = std::uint32_t(i);
  });
}

/// Step 5: `iterations` Jacobi iterations of the paper's propagation over the pool's support.
/// Voxel clusters read the transfer from slot-ordered copies and a pair table built once per
/// pool, with the factorised O(n + m) sums where the options allow and the cluster qualifies;
/// disks evaluate the transfer by segment. Returns L and G w per segment.
template <LightSampledScene Scn, JunctionSupport J, ParallelFor P>
void propagate_pool(Context<Scn>& ctx, const J& support, int iterations, std::vector<typename Scn::Spectrum>& radiance,
                    std::vector<typename Scn::Scalar>& weighted_geometry, const P& parallel_for,
                    PoolGeometry geometry = PoolGeometry::keep) {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  const Scn& scene = ctx.scene;
  const auto& pool = ctx.pool;
  weighted_geometry_of(pool, weighted_geometry);
  std::vector<std::uint32_t> backtrack;
  backtrack_partners(pool, backtrack, parallel_for);
  PropagationWorkspace<S> workspace;
  if constexpr (J::factorisable) {
    std::vector<std::uint8_t> factorised;
    std::vector<S> diffuse;
    if (ctx.options.factorise) transfer_factorisation(ctx, support, factorised, diffuse, parallel_for);
    Transfer<Scn> transfer;
    transfer.build(pool, support, factorised, parallel_for);
    const TransferLink<Scn> link{scene.bsdf(), transfer};
    PairTable<S> table;
    table.build(support, ctx.options.transfer_cache_bytes, factorised,
                [&](std::size_t, std::uint32_t i, std::uint32_t j) { return link(0, 0, i, j); }, parallel_for);
    ctx.stats.transfer_cache_bytes = table.value_bytes();
    const CachedTransferLink<Scn> cached{link, table};
    // From here the link reads the transfer's copies and the table only.
    if (geometry == PoolGeometry::release) ctx.pool.release_geometry();
    propagate(PropagationInputs<S, CachedTransferLink<Scn>, J>{support, pool.emitted, weighted_geometry, cached, diffuse, factorised,
                                                               pool.pieces, backtrack},
              iterations, radiance, workspace, parallel_for);
    ctx.stats.lagged_bytes = workspace.lagged_bytes;
    ctx.stats.round_trip_bytes = workspace.round_trip_bytes;
  } else {
    const auto& bsdf = scene.bsdf();
    auto link = [&](std::uint32_t s, std::uint32_t sp) -> S {
      const S f = bsdf.eval(BsdfQuery<T>{pool.segments[s].y, -pool.last_direction[s], pool.first_direction[sp], Transport::radiance});
      return f * pool.chain[s];
    };
    propagate(PropagationInputs<S, decltype(link), J>{support, pool.emitted, weighted_geometry, link, {}, {}, pool.pieces, backtrack},
              iterations, radiance, workspace, parallel_for);
    ctx.stats.lagged_bytes = workspace.lagged_bytes;
    ctx.stats.round_trip_bytes = workspace.round_trip_bytes;
  }
}

/// Step 5 with the path-conditioned weighting; returns the weighted L per segment and G
/// (the weights are inside: a sensor segment's pixel value is W G L).
template <LightSampledScene Scn, class Support, ParallelFor P>
void propagate_conditioned_pool(Context<Scn>& ctx, const Support& support, const LightSide<typename Scn::Scalar>& side,
                                int iterations, std::vector<typename Scn::Spectrum>& radiance,
                                std::vector<typename Scn::Scalar>& geometry, const P& parallel_for,
                                PoolGeometry pool_geometry = PoolGeometry::keep) {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  const Scn& scene = ctx.scene;
  const auto& pool = ctx.pool;
  auto& stats = ctx.stats;
  const auto& bsdf = scene.bsdf();
  // The s-only part of q_l(s | s'), per segment (as light_side computes it).
  std::vector<T> scale(pool.size(), T(0));
  parallel_for(pool.size(), [&](std::size_t i) {
    const auto s = std::uint32_t(i);
    if constexpr (!Support::factorisable) {
      scale[s] = light_pair_scale<Scn>(pool, T(ctx.techniques.light_continuation), support.kernel(), s);
    } else {
      const std::uint32_t c = support.cluster_of_y(s);
      if (c != no_cluster) scale[s] = light_pair_scale<Scn>(pool, T(ctx.techniques.light_continuation), support.clusters()[c].kernel, s);
    }
  });
  auto light_pair = [&](std::uint32_t s, std::uint32_t sp) -> T { return light_pair_density(scene, pool, scale[s], s, sp); };
  std::vector<std::uint32_t> backtrack;
  backtrack_partners(pool, backtrack, parallel_for);
  if constexpr (!Support::factorisable) {
    auto link = [&](std::uint32_t s, std::uint32_t sp) -> S {
      return bsdf.eval(BsdfQuery<T>{pool.segments[s].y, -pool.last_direction[s], pool.first_direction[sp], Transport::radiance}) *
             pool.chain[s];
    };
    // D_lt = D_l (LightSide): side.density serves as both.
    const ConditionedInputs<S, decltype(link), decltype(light_pair)> inputs{
        pool.emitted, pool.geometry, pool.density, side.density, side.terms, side.density, side.flags, link, light_pair,
        pool.pieces, side.bridge_target_term, side.bridge_density, backtrack};
    const ConditionedMemory memory = propagate_conditioned(support, inputs, iterations, radiance, parallel_for);
    stats.lagged_bytes = memory.lagged;
    stats.round_trip_bytes = memory.round_trips;
    stats.forced_value_bytes = memory.forced_values;
  } else {
    std::vector<std::uint8_t> factorised;
    std::vector<S> diffuse;
    if (ctx.options.factorise) conditioned_factorisation(ctx, support, factorised, diffuse, parallel_for);
    // The general clusters read slot-ordered copies (Transfer, and the starts and s-only
    // factors of q_l): f_r and q_l by slot, as propagate_pool does.
    Transfer<Scn> transfer;
    transfer.build(pool, support, factorised, parallel_for);
    std::vector<SurfacePoint<T>> starting_x(transfer.starting_direction.size());
    std::vector<T> ending_scale(transfer.ending.size(), T(0));
    stats.propagation_copy_bytes = transfer.bytes() + starting_x.capacity() * sizeof(SurfacePoint<T>) + ending_scale.capacity() * sizeof(T);
    const auto clusters = support.clusters();
    parallel_for(clusters.size(), [&](std::size_t c) {
      if (!factorised.empty() && factorised[c]) return;
      const Cluster<T>& cl = clusters[c];
      for (std::uint32_t j = cl.slot; j < cl.slot + cl.starting_count(); ++j)
        starting_x[transfer.starting_record.empty() ? j : transfer.starting_record[j]] =
            pool.segments[support.starting_segments()[j]].x;
      const std::uint32_t first = cl.ending_slot(cl.middle);
      for (std::uint32_t i = first; i < first + cl.ending_count(); ++i)
        ending_scale[transfer.ending_record.empty() ? i : transfer.ending_record[i]] = scale[support.ending_segments()[i]];
    });
    // q_l(s | s') of a general cluster's pair, by slot (propagate_conditioned calls it only
    // where the junction depends on it, detail::needs_light_pair): light_pair_density from
    // the copies, the same product, the same number.
    struct SlotLightPair {
      decltype(light_pair) by_id;
      decltype(std::declval<const Scn&>().bsdf()) bsdf;
      const Transfer<Scn>& transfer;
      const std::vector<SurfacePoint<T>>& starting_x;
      const std::vector<T>& ending_scale;
      T operator()(std::uint32_t s, std::uint32_t sp) const noexcept { return by_id(s, sp); }
      T operator()(std::uint32_t, std::uint32_t, std::uint32_t i, std::uint32_t j) const noexcept {
        const std::uint32_t ir = transfer.ending_record.empty() ? i : transfer.ending_record[i];
        const std::uint32_t jr = transfer.starting_record.empty() ? j : transfer.starting_record[j];
        const T scale_s = ending_scale[ir];
        if (!(scale_s > T(0)) || starting_x[jr].kind != PointKind::surface) return T(0);
        const T q = scale_s * bsdf.pdf(BsdfQuery<T>{starting_x[jr], transfer.ending[ir].outgoing, transfer.starting_direction[jr],
                                                    Transport::importance});
        return std::isfinite(q) && q > T(0) ? q : T(0);
      }
    };
    // D_lt = D_l (LightSide): side.density serves as both.
    const ConditionedInputs<S, TransferLink<Scn>, SlotLightPair> slot_inputs{
        pool.emitted, pool.geometry, pool.density, side.density, side.terms, side.density, side.flags,
        TransferLink<Scn>{scene.bsdf(), transfer}, SlotLightPair{light_pair, scene.bsdf(), transfer, starting_x, ending_scale},
        pool.pieces, side.bridge_target_term, side.bridge_density, backtrack};
    // The junctions of the pairs that fit the cache budget are built once per pool. Once the
    // factorised clusters' q_l are in, everything reads the slot-ordered copies.
    auto by_id_done = [&] {
      if (pool_geometry != PoolGeometry::release) return;
      ctx.pool.release_geometry();
      scale = std::vector<T>{};
    };
    const ConditionedMemory memory =
        propagate_conditioned(support, slot_inputs, iterations, radiance, parallel_for, std::span<const std::uint8_t>(factorised),
                              std::span<const S>(diffuse), ctx.options.transfer_cache_bytes, by_id_done);
    stats.transfer_cache_bytes = memory.junction_table;
    stats.lagged_bytes = memory.lagged;
    stats.round_trip_bytes = memory.round_trips;
    stats.forced_value_bytes = memory.forced_values;
  }
  geometry.assign(pool.geometry.begin(), pool.geometry.end());
}

}  // namespace segpath::filtering
