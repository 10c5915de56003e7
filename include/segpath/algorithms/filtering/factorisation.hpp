// Where voxel clusters let the O(n m) sums of filtering factorise into O(n + m): a cluster
// whose points are all Lambertian with one shading normal has technique densities and a
// transfer f_r(s, s') independent of the pair (concepts/bsdf.hpp's lambertian_albedo tells).
#pragma once

#include "segpath/algorithms/filtering/context.hpp"
#include "segpath/concepts/bsdf.hpp"
#include "segpath/materials/scattering.hpp"
#include "segpath/propagation/clustering.hpp"

#include <cstdint>
#include <optional>
#include <span>
#include <type_traits>
#include <vector>

namespace segpath::filtering {

/// Whether the given end of every one of `segments` has a Lambertian BSDF and one shading
/// normal; returns that normal.
template <Scene Scn, class Ends>
std::optional<Vec3<typename Scn::Scalar>> common_lambertian_normal(const Scn& scene, const Ends& end_of,
                                                                   std::span<const std::uint32_t> segments) {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  using B = std::remove_cvref_t<decltype(scene.bsdf())>;
  if constexpr (!HasLambertianAlbedo<B, S>) {
    return std::nullopt;
  } else {
    if (segments.empty()) return std::nullopt;
    const auto& bsdf = scene.bsdf();
    const SurfacePoint<T>& first = end_of(segments.front());
    const Vec3<T> n = first.shading_normal;
    for (const std::uint32_t s : segments) {
      const SurfacePoint<T>& p = end_of(s);
      if (!(p.shading_normal == n) || !(p.normal == first.normal) || !bsdf.lambertian_albedo(p)) return std::nullopt;
    }
    return n;
  }
}

/// Where every segment ending in a cluster has a Lambertian end with one normal, and every
/// segment starting there leaves above it, f_r(s, s') = chain(s) albedo(y_s) / pi: the
/// propagation sum is computed once per cluster.
template <LightSampledScene Scn, ParallelFor P>
void transfer_factorisation(Context<Scn>& ctx, const Clustering<typename Scn::Scalar>& clustering,
                            std::vector<std::uint8_t>& factorised, std::vector<typename Scn::Spectrum>& diffuse,
                            const P& parallel_for) {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  const Scn& scene = ctx.scene;
  const auto& pool = ctx.pool;
  auto& stats = ctx.stats;
  using B = std::remove_cvref_t<decltype(scene.bsdf())>;
  factorised.assign(clustering.clusters().size(), 0);
  diffuse.assign(pool.size(), S(T(0)));
  if constexpr (HasLambertianAlbedo<B, S>) {
    const auto& bsdf = scene.bsdf();
    parallel_for(factorised.size(), [&](std::size_t c) {
      const auto starting = clustering.starting_segments(c), ending = clustering.ending_segments(c);
      if (starting.empty() || ending.empty()) return;
      // A black Lambertian end (an emitter that reflects nothing) has f_r = 0 = diffuse
      // whatever its normal and directions: next-event segments end on such lights in crowds.
      const SurfacePoint<T>* first = nullptr;
      bool ok = true;
      for (std::size_t q = 0; q < ending.size() && ok; ++q) {
        const std::uint32_t s = ending[q];
        const SurfacePoint<T>& y = pool.segments[s].y;
        const auto albedo = bsdf.lambertian_albedo(y);
        if (albedo && is_black(*albedo)) continue;
        if (!first) first = &y;
        ok = albedo && y.normal == first->normal && glm::dot(-pool.last_direction[s], y.normal) > one_sided_epsilon<T>;
        if (ok) diffuse[s] = *albedo * inv_pi<T> * pool.chain[s];
      }
      for (std::size_t r = 0; r < starting.size() && ok && first; ++r)
        ok = glm::dot(pool.first_direction[starting[r]], first->normal) > one_sided_epsilon<T>;
      factorised[c] = ok ? 1 : 0;
    });
    for (const auto f : factorised) stats.factorised_transfer_clusters += f;
  }
}

/// The clusters whose path-conditioned junction sums factorise: the transfer factorises
/// (transfer_factorisation) and every start is Lambertian with one normal and leaves its
/// front side, so q_l(s | s') is the same for every potential light technique s'.
template <LightSampledScene Scn, ParallelFor P>
void conditioned_factorisation(Context<Scn>& ctx, const Clustering<typename Scn::Scalar>& clustering,
                               std::vector<std::uint8_t>& factorised, std::vector<typename Scn::Spectrum>& diffuse,
                               const P& parallel_for) {
  using T = typename Scn::Scalar;
  const Scn& scene = ctx.scene;
  const auto& pool = ctx.pool;
  auto& stats = ctx.stats;
  transfer_factorisation(ctx, clustering, factorised, diffuse, parallel_for);
  const auto x_of = [&](std::uint32_t s) -> const SurfacePoint<T>& { return pool.segments[s].x; };
  std::vector<std::uint8_t> dropped(factorised.size(), 0);
  parallel_for(factorised.size(), [&](std::size_t c) {
    if (!factorised[c]) return;
    const auto starting = clustering.starting_segments(c);
    bool ok = common_lambertian_normal(scene, x_of, starting).has_value();
    for (std::size_t r = 0; r < starting.size() && ok; ++r) {
      const std::uint32_t sp = starting[r];
      ok = glm::dot(pool.first_direction[sp], pool.segments[sp].x.normal) > one_sided_epsilon<T>;
    }
    if (!ok) factorised[c] = 0, dropped[c] = 1;
  });
  for (const auto d : dropped) stats.factorised_transfer_clusters -= d;
}

}  // namespace segpath::filtering
