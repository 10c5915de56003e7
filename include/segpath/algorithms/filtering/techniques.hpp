// A user's own technique in the filtering's technique set: any unconditional SegmentSampler
// (concepts/sampler.hpp, Technique default-constructible, no Dirac) drawing `per_pixel` x
// #pixels segments per iteration. Its segments join the pool (flag extra_technique) and take
// part in propagation like any other; its density N_u p_u(s) joins the MMIS denominator of
// every pooled segment it could have drawn (N39: the balance heuristic sums over every
// technique of the set), so the weights stay a partition of unity with it.
//
// It draws straight segments: its density of a chain (a segment through delta vertices, in a
// measure the sampler does not know) and of a Dirac light end is 0.
#pragma once

#include "segpath/algorithms/filtering/context.hpp"
#include "segpath/concepts/sampler.hpp"
#include "segpath/core/geometry.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/rng.hpp"

#include <cmath>
#include <concepts>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace segpath {

/// What a sampler needs to join segment filtering's technique set: a SegmentSampler whose
/// technique parameter is empty (unconditional) and whose density has no Dirac part.
template <class Smp, class Scn>
concept UnconditionalSegmentSampler = SegmentSampler<Smp, Scn> && std::default_initializable<typename Smp::Technique> &&
                                      (!Smp::is_dirac);

/// A technique of the user's: the sampler and how many segments it draws per pixel and iteration.
template <class Smp>
struct FilteringTechnique {
  Smp sampler;
  double per_pixel = 1;
};

namespace filtering {

/// N_u: the technique's draws in the context's pass, its share (pass_share) of the iteration's
/// per_pixel x #pixels.
template <class Smp, LightSampledScene Scn>
[[nodiscard]] std::uint64_t draw_count(const FilteringTechnique<Smp>& technique, const Context<Scn>& ctx) {
  if (!(technique.per_pixel > 0) || !std::isfinite(technique.per_pixel))
    throw std::invalid_argument("segpath::FilteringTechnique: per_pixel must be > 0, got " + std::to_string(technique.per_pixel));
  const auto draws = std::uint64_t(std::llround(technique.per_pixel * double(ctx.scene.sensor().pixel_count())));
  return pass_share(draws, ctx.pass, ctx.passes);
}

/// Draws a user technique's segments into the pool; the k-th technique of the list draws from
/// its own random streams. An occluded or degenerate draw is not pooled (it is still a
/// technique sample: the density counts every draw).
template <LightSampledScene Scn, class Smp, ParallelFor P>
void draw_extra(Context<Scn>& ctx, const FilteringTechnique<Smp>& technique, std::uint64_t k, const P& parallel_for) {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  const Scn& scene = ctx.scene;
  const std::uint64_t draws = draw_count(technique, ctx);
  constexpr std::size_t chunks = 64;
  std::vector<RecordList<T, S>> records(chunks);
  const std::uint64_t salt = ctx.options.seed ^ (0x6578747261ULL /* "extra" */ + (k << 40));
  parallel_for(chunks, [&](std::size_t c) {
    for (std::uint64_t i = draws * c / chunks, e = draws * (c + 1) / chunks; i < e; ++i) {
      Pcg32 rng = Pcg32::for_sample(salt, ctx.draw_index(i), ctx.stream);
      const auto sample = technique.sampler.sample(scene, typename Smp::Technique{}, rng);
      if (!sample || !(sample->pdf > T(0))) continue;
      Record<T, S> r;
      r.segment = sample->segment;
      if (r.segment.x.kind != PointKind::surface || r.segment.y.kind == PointKind::point) continue;
      r.geometry = geometry_term(r.segment);
      if (!(r.geometry > T(0)) || !std::isfinite(r.geometry)) continue;
      if (!scene.visible(VisibilityQuery<T>{r.segment.x, r.segment.y})) continue;
      r.first_direction = r.last_direction = r.segment.direction();
      r.chain = S(T(1));
      r.flags = extra_technique;
      records[c].push_back(r);
    }
  });
  append(ctx.pool, records, parallel_for);
}

/// N_u p_u(s) of pooled segment i (0 for chains and Dirac light ends).
template <LightSampledScene Scn, class Smp>
[[nodiscard]] typename Scn::Scalar extra_density(const Context<Scn>& ctx, const FilteringTechnique<Smp>& technique,
                                                 std::size_t i) {
  using T = typename Scn::Scalar;
  if (ctx.pool.flags[i] & (chain_segment | delta_light | kept_density)) return T(0);
  const T p = technique.sampler.unoccluded_pdf(ctx.scene, typename Smp::Technique{}, ctx.pool.segments[i]);
  return std::isfinite(p) && p > T(0) ? T(draw_count(technique, ctx)) * p : T(0);
}

}  // namespace filtering
}  // namespace segpath
