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
/// the side flags (conditioned_*). D_lt = D_l (propagation/path_conditioned.hpp): light paths
/// have no depth limit, so every segment a light technique draws tries a predecessor in turn.
template <Real T>
struct LightSide {
  std::vector<T> density;            ///< D_l, also D_lt
  std::vector<std::uint32_t> terms;  ///< positive terms of D_l
  std::vector<std::uint8_t> flags;
  /// With bridges (empty without): q_b(s), the term of B(s) that each bridge target starting
  /// near y_s adds, and B(s), the bridge density in D(s) (compute_densities).
  std::vector<T> bridge_target_term, bridge_density;
};
/// q_l(s | s'), the one pair density of the weighting: the density with which a light
/// technique sample at x_{s'} (the approximate light predecessor, N33) draws s, kernel
/// included; in the measure of s (area at y, N31 mirrored). 0 where no light predecessor can
/// be s. D_l(s) sums it over the light technique samples among the s' starting near y_s.
/// `scale` is light_pair_scale(pool, kernel, s), the part that depends on s alone.
template <LightSampledScene Scn, Real T>
[[nodiscard]] T light_pair_density(const Scn& scene, const Pool<T, typename Scn::Spectrum>& pool, T scale, std::uint32_t s,
                                   std::uint32_t sp) noexcept {
  if (!(scale > T(0)) || pool.segments[sp].x.kind != PointKind::surface) return T(0);
  const T q = scale * light_technique_pdf(scene, pool, sp, s);
  return std::isfinite(q) && q > T(0) ? q : T(0);
}
/// `continuation` is the roulette's c (TechniqueSet::light_continuation), part of every light
/// predecessor's density.
template <LightSampledScene Scn, Real T>
[[nodiscard]] T light_pair_scale(const Pool<T, typename Scn::Spectrum>& pool, T continuation, T kernel, std::uint32_t s) noexcept {
  return light_reachable(pool, s) ? continuation * kernel * light_measure<Scn>(pool, s) : T(0);
}

/// The flags of the path-conditioned weighting and the light-start term of D_l (as
/// finish_densities computes it).
template <LightSampledScene Scn, ParallelFor P>
void light_side_start(const Context<Scn>& ctx, LightSide<typename Scn::Scalar>& side, const P& parallel_for) {
  using T = typename Scn::Scalar;
  const auto& pool = ctx.pool;
  const std::uint64_t light_paths = ctx.light_paths();
  side.density.assign(pool.size(), T(0));
  side.terms.assign(pool.size(), 0);
  side.flags.assign(pool.size(), 0);
  parallel_for(pool.size(), [&](std::size_t i) {
    const auto f = pool.flags[i];
    const Segment<T>& s = pool.segments[i];
    std::uint8_t flags = 0;
    if (!(f & not_light_born)) flags |= conditioned_light_born;
    if (f & light_technique) flags |= conditioned_light_technique | conditioned_potential;
    // A light path could have reached x (through delta reflections too) and tried a predecessor there.
    if (s.x.kind == PointKind::surface) flags |= conditioned_potential;
    if (f & bridge_segment) flags |= conditioned_bridge_born;
    side.flags[i] = flags;
    const T d = light_start_density(ctx.scene, pool, i, light_paths);
    if (!(std::isfinite(d) && d > T(0))) return;
    side.density[i] = d;
    side.terms[i] = 1;
  });
}

/// One light technique sample's term of D_l(s) (= D_lt(s)).
template <Real T>
void add_light_term(LightSide<T>& side, std::uint32_t s, T ql) noexcept {
  if (!(ql > T(0))) return;
  side.density[s] += ql;
  side.terms[s] += 1;
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
    const T scale = light_pair_scale<Scn>(pool, T(ctx.techniques.light_continuation), junctions.kernel(), s);
    if (!(scale > T(0))) return;
    for (const std::uint32_t u : junctions.starting_near(s)) {
      if (!(pool.flags[u] & light_technique)) continue;
      add_light_term(side, s, light_pair_density(ctx.scene, pool, scale, s, u));
    }
  });
}

}  // namespace segpath::filtering
