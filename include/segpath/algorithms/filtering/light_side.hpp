// The light side of the MMIS denominators for the path-conditioned weighting (BDPF,
// propagation/path_conditioned.hpp): D_l(s), the part of D(s) from the light start and the light
// technique samples, its number of positive terms, D_lt (the light technique samples whose drawn
// segment itself tries a predecessor) and the side flags; and q_l(s | s'), the one pair density
// of the weighting.
#pragma once

#include "segpath/algorithms/filtering/context.hpp"
#include "segpath/algorithms/filtering/technique_densities.hpp"
#include "segpath/propagation/disk_junctions.hpp"
#include "segpath/propagation/path_conditioned.hpp"

#include <cmath>
#include <cstdint>
#include <vector>

namespace segpath::filtering {

/// Segments no light path drew.
inline constexpr std::uint16_t not_light_born = camera_born | bridge_segment | extra_technique;

/// What the path-conditioned weighting needs besides D(s): the light side D_l(s) of the
/// denominator (light start and light technique samples), its number of positive terms, and
/// the side flags (conditioned_*).
template <Real T>
struct LightSide {
  std::vector<T> density, technique_density;  ///< D_l, D_lt (propagation/path_conditioned.hpp)
  std::vector<std::uint32_t> terms, depth;    ///< positive terms of D_l; light path depth (light start 1)
  std::vector<std::uint8_t> flags;
};
/// q_l(s | s'), the one pair density of the weighting: the density with which a light
/// technique sample at x_{s'} (the approximate light predecessor, N33) draws s, kernel
/// included; in the measure of s (area at y, N31 mirrored). 0 where no light predecessor can
/// be s. D_l(s) sums it over the light technique samples among the s' starting near y_s.
/// `scale` is light_pair_scale(pool, kernel, s), the part that depends on s alone.
template <LightSampledScene Scn, Real T>
[[nodiscard]] T light_pair_density(const Scn& scene, const Pool<T, typename Scn::Spectrum>& pool, T scale, std::uint32_t s,
                                   std::uint32_t sp) noexcept {
  if (!(scale > T(0)) || pool.segments[sp].x.kind != PointKind::surface || (pool.flags[sp] & transmission_chain)) return T(0);
  const T q = scale * light_technique_pdf(scene, pool, sp, s);
  return std::isfinite(q) && q > T(0) ? q : T(0);
}
template <LightSampledScene Scn, Real T>
[[nodiscard]] T light_pair_scale(const Pool<T, typename Scn::Spectrum>& pool, T kernel, std::uint32_t s) noexcept {
  return light_reachable(pool, s) ? kernel * light_measure<Scn>(pool, s) : T(0);
}

/// The flags of the path-conditioned weighting and the light-start term of D_l (as
/// finish_densities computes it).
template <LightSampledScene Scn, ParallelFor P>
void light_side_start(const Context<Scn>& ctx, LightSide<typename Scn::Scalar>& side, const P& parallel_for) {
  using T = typename Scn::Scalar;
  const auto& pool = ctx.pool;
  const std::uint64_t light_paths = ctx.light_paths();
  side.density.assign(pool.size(), T(0));
  side.technique_density.assign(pool.size(), T(0));
  side.terms.assign(pool.size(), 0);
  side.flags.assign(pool.size(), 0);
  // Light paths are pooled in path order (build_pool): a light predecessor follows the
  // segment that drew it.
  side.depth.assign(pool.size(), 0);
  for (std::size_t i = 0; i < pool.size(); ++i) {
    if (pool.flags[i] & light_start) side.depth[i] = 1;
    else if (i > 0 && !(pool.flags[i] & not_light_born) && side.depth[i - 1] > 0) side.depth[i] = side.depth[i - 1] + 1;
  }
  parallel_for(pool.size(), [&](std::size_t i) {
    const auto f = pool.flags[i];
    const Segment<T>& s = pool.segments[i];
    std::uint8_t flags = 0;
    if (!(f & not_light_born)) flags |= conditioned_light_born;
    if (f & light_technique) flags |= conditioned_light_technique | conditioned_potential;
    // A light path could have reached x (through delta reflections too) and tried a predecessor there.
    if (s.x.kind == PointKind::surface && !(f & transmission_chain)) flags |= conditioned_potential;
    side.flags[i] = flags;
    const T d = light_start_density(ctx.scene, pool, i, light_paths);
    if (!(std::isfinite(d) && d > T(0))) return;
    side.density[i] = d;
    side.terms[i] = 1;
    if (2 < ctx.options.max_length) side.technique_density[i] = d;  // a light start tries a predecessor
  });
}

/// One light technique sample u's term of D_l(s) (and of D_lt(s) if the segment u draws
/// would itself try a predecessor: trace_light_path's depth rule).
template <LightSampledScene Scn, Real T>
void add_light_term(const Context<Scn>& ctx, LightSide<T>& side, std::uint32_t s, std::uint32_t u, T ql) noexcept {
  if (!(ql > T(0))) return;
  side.density[s] += ql;
  side.terms[s] += 1;
  if (ctx.deep(side.depth[u])) side.technique_density[s] += ql;
}

/// The light side of every denominator, disk support.
template <LightSampledScene Scn, ParallelFor P>
void light_side(const Context<Scn>& ctx, const DiskJunctions<typename Scn::Scalar>& junctions, LightSide<typename Scn::Scalar>& side,
                const P& parallel_for) {
  using T = typename Scn::Scalar;
  const auto& pool = ctx.pool;
  light_side_start(ctx, side, parallel_for);
  parallel_for(pool.size(), [&](std::size_t i) {
    const auto s = std::uint32_t(i);
    const T scale = light_pair_scale<Scn>(pool, junctions.kernel(), s);
    if (!(scale > T(0))) return;
    for (const std::uint32_t u : junctions.starting_near(s)) {
      if (!(pool.flags[u] & light_technique)) continue;
      add_light_term(ctx, side, s, u, light_pair_density(ctx.scene, pool, scale, s, u));
    }
  });
}

}  // namespace segpath::filtering
