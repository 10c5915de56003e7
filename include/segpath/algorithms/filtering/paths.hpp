// Stage 1 of a filtering iteration: the techniques draw the pool. Camera paths (the sensor
// segment, then approximate successors, N33, and next-event segments from each camera technique
// point), light paths (the light-start segment, N30, then approximate predecessors), bridge
// segments, and the draws of the user's own techniques (FilteringTechnique). A delta bounce does
// not end a segment: the path folds it into a chain (area at x x solid angle at x).
#pragma once

#include "segpath/algorithms/filtering/context.hpp"
#include "segpath/algorithms/filtering/support.hpp"
#include "segpath/concepts/bsdf.hpp"
#include "segpath/core/geometry.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/rng.hpp"
#include "segpath/materials/scattering.hpp"
#include "segpath/samplers/light_start.hpp"
#include "segpath/samplers/sensor_start.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <optional>
#include <vector>

namespace segpath::filtering {

/// Path generators draw in this many chunks (the pool is the same whatever the thread count).
inline constexpr std::size_t path_chunks = 64;

/// The next-event segment of the camera technique point x, the y end of record `source` of
/// `out`: a light point from sample_towards(x), kept when visible. A failed draw is still a
/// technique sample (the density counts every camera technique point).
template <LightSampledScene Scn, class R>
void add_next_event(const Scn& scene, std::uint32_t source, const SurfacePoint<typename Scn::Scalar>& x, R& rng,
                    RecordList<typename Scn::Scalar, typename Scn::Spectrum>& out) {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  const Vec2<T> u = uniform2<T>(rng);
  const T u_select = rng.template uniform<T>();
  const auto e = scene.emitter().sample_towards(EmitterTowardsQuery<T>{x, u, u_select});
  if (!e || !(e->pdf > T(0)) || !std::isfinite(e->pdf)) return;
  Record<T, S> r;
  r.segment = Segment<T>{x, e->point};
  if (r.segment.y.kind != PointKind::direction && !(r.segment.length_squared() > T(0))) return;
  r.geometry = geometry_term(r.segment);
  if (!(r.geometry > T(0)) || !std::isfinite(r.geometry)) return;
  r.first_direction = r.last_direction = r.segment.direction();
  // A light behind x's one-sided surface (the sun seen from the back of a wall) lights nothing
  // there (HasScattersFrom): not pooled, no shadow ray; the draw still counts as a technique
  // sample (see trace_light_path for why nothing else changes).
  if (!scatters_from<S>(scene.bsdf(), x, r.first_direction)) return;
  if (!scene.visible(VisibilityQuery<T>{r.segment.x, r.segment.y})) return;
  r.chain = S(T(1));
  r.flags = camera_born | (e->delta ? delta_light : 0);
  r.parent = source;
  r.next_event = true;
  out.push_back(r);
}

/// Where a path drew its technique samples so far: their voxels (Context::visit_grid) or their
/// positions (Context::visit_radius). Scratch, cleared per path.
template <Real T>
struct PathVisits {
  std::vector<VoxelKey> voxels;
  std::vector<Vec3<T>> positions;
  void clear() noexcept { voxels.clear(), positions.clear(); }
};

/// Whether a draw at p is its path's first visit of p's voxel (over disks: whether no earlier
/// technique sample of the path lies within twice the disk radius, so that no disk holds two),
/// which `visits` then records; true where every visit counts.
/// Measured as the support measures an end (support.hpp): by the scene's canonical position, so
/// that on a periodic domain a path that comes round to its voxel's image visits it again.
template <LightSampledScene Scn>
[[nodiscard]] bool first_visit_of(const Context<Scn>& ctx, const SurfacePoint<typename Scn::Scalar>& p,
                                  PathVisits<typename Scn::Scalar>& visits) {
  using T = typename Scn::Scalar;
  if (!ctx.visit_grid && !(ctx.visit_radius > T(0))) return true;
  if (p.kind != PointKind::surface) return true;
  const Vec3<T> at = canonical_map(ctx.scene)(p);
  if (ctx.visit_grid) {
    SurfacePoint<T> q = p;
    q.position = at;
    const auto k = ctx.visit_grid->key(q);
    if (!k.valid) return true;
    if (std::find(visits.voxels.begin(), visits.voxels.end(), k.key) != visits.voxels.end()) return false;
    visits.voxels.push_back(k.key);
    return true;
  }
  const T r2 = T(4) * ctx.visit_radius * ctx.visit_radius;  // (2 r)^2
  for (const Vec3<T>& v : visits.positions)
    if (glm::dot(at - v, at - v) < r2) return false;
  visits.positions.push_back(at);
  return true;
}

/// Records p as visited by its path (first_visit_of without the answer): a point the path holds
/// though it drew no technique sample there, such as its light point.
template <LightSampledScene Scn>
void mark_visited(const Context<Scn>& ctx, const SurfacePoint<typename Scn::Scalar>& p, PathVisits<typename Scn::Scalar>& visits) {
  (void)first_visit_of(ctx, p, visits);
}

/// One camera path: the sensor segment, then approximate successors (N33) from each
/// non-delta end; delta bounces extend the current segment into a chain. No depth limit: the
/// roulette c_c ends the path, and past max_length segments the tail's
/// (TechniqueSet::camera_tail_continuation); only one segment's delta bounces are capped at
/// max_length. PhF keeps only the sensor segment.
template <LightSampledScene Scn>
void trace_camera_path(const Context<Scn>& ctx, std::uint32_t pixel,
                       RecordList<typename Scn::Scalar, typename Scn::Spectrum>& out, PathVisits<typename Scn::Scalar>& visits) {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  const Scn& scene = ctx.scene;
  Pcg32 rng = Pcg32::for_sample(ctx.options.seed, pixel, 2 * ctx.stream);
  const auto first = SensorStartSampler<Scn>{}.sample(scene, {pixel}, rng);
  if (!first) return;
  const auto ray = scene.sensor().pdf(SensorQuery<T>{first->segment.x, first->direction});
  const auto response = scene.sensor().importance(SensorQuery<T>{first->segment.x, first->direction});
  if (!response || !(ray.position * ray.direction > T(0))) return;
  const std::size_t max_pieces = ctx.options.max_length;
  // The roulette's c_c, and past max_length the tail's. No depth limit, as for light paths: a
  // segment whose end draws no successor leaves its chains no technique sample of their own in
  // the next cluster, and a limit lost the chains through a path's last segment where no other
  // path's sample was near (MVF -2.3 % in the closed box at 32 x 32 and max length 4 with c_c
  // 0.7, -3.6 % with c_c 1; docs/filtering.md, "Known limits").
  const T continuation = T(ctx.techniques.camera_continuation);
  const T tail_continuation = T(ctx.techniques.camera_tail_continuation);
  Record<T, S> r;
  r.segment.x = first->segment.x;
  r.first_direction = first->direction;
  r.flags = sensor_segment | camera_born;
  r.pixel = pixel;
  r.sensor_weight = response->importance;
  SurfacePoint<T> y = first->segment.y;
  Vec3<T> direction = first->direction;
  T distance = std::sqrt(first->segment.length_squared());
  S chain(T(1));
  std::size_t pieces = 1;
  const auto& bsdf = scene.bsdf();
  visits.clear();
  for (;;) {
    // Follow delta bounces: the segment continues through them.
    std::optional<BsdfSample<S>> next;
    if (y.kind == PointKind::surface && r.pieces < max_pieces) {
      next = bsdf.sample(BsdfSampleQuery<T>{y, -direction, uniform2<T>(rng), rng.template uniform<T>(), Transport::radiance});
      if (next && next->delta && next->pdf > T(0)) {
        chain = chain * (next->value * (std::abs(glm::dot(next->direction, y.normal)) / next->pdf));
        if (is_transmission(y, -direction, next->direction)) r.flags |= transmission_chain;
        const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{y.position, next->direction}});
        direction = next->direction;
        ++pieces;
        if (r.pieces < 0xffff) ++r.pieces;
        r.flags |= chain_segment;
        if (hit) {
          y = hit->point;
        } else {
          y = SurfacePoint<T>::at_infinity(direction);
        }
        continue;
      }
    }
    // Close the segment at y.
    r.segment.y = y;
    r.last_direction = direction;
    r.chain = chain;
    // A repeat visit's draw stays in no chain (G = 0), through delta bounces too.
    if (!(r.flags & repeat_visit_born))
      r.geometry = (r.flags & chain_segment) ? endpoint_cosine(r.segment.x, r.first_direction)
                                             : geometry_term(r.segment, direction, distance);
    // Every attempted successor draw at a first visit is a technique sample, including draws
    // that failed: SMIS/MMIS denominators sum over all technique samples (N11, N39); leaving
    // the failed ones out would underestimate D and bias the image upwards (glossy lobes at
    // grazing angles fail often).
    const bool attempted = ctx.techniques.camera_successors && y.kind == PointKind::surface;
    const bool tail = pieces >= max_pieces;
    const T c = tail ? tail_continuation : continuation;
    // A technique sample only at the path's first visit of a voxel (Context::visit_grid), as a
    // light path's: a later visit exists only if the successor drawn at the first does, so
    // counted in that successor's D_c it would raise it exactly where it was drawn. The
    // next-event draw, whose density counts the camera technique points, goes with it.
    const bool first_visit = !attempted || first_visit_of(ctx, y, visits);
    const bool technique = attempted && first_visit;
    if (technique) r.flags |= camera_technique | (tail && c != continuation ? camera_tail : 0);
    // The roulette is part of the draw (as in trace_light_path); no coin is drawn without one.
    const bool continues = attempted && next && !next->delta && next->pdf > T(0) &&
                           (c >= T(1) || rng.template uniform<T>() < c);
    const auto index = std::uint32_t(out.size());
    out.push_back(r);
    if (technique && ctx.techniques.next_event) add_next_event(scene, index, r.segment.y, rng, out);
    if (!continues) return;
    // The approximate successor (N33): starts exactly at y, direction from the BSDF at y.
    const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{y.position, next->direction}});
    Record<T, S> successor;
    successor.segment.x = y;
    successor.first_direction = next->direction;
    successor.flags = std::uint16_t(camera_born | (first_visit ? 0 : repeat_visit_born));
    successor.parent = index;
    r = successor;
    direction = next->direction;
    chain = S(T(1));
    ++pieces;
    if (hit) {
      y = hit->point;
      distance = hit->distance;
    } else {
      y = SurfacePoint<T>::at_infinity(direction);
      distance = T(1);
    }
  }
}

/// One light path: the light-start segment (N30), then approximate light-side
/// predecessors (N33) from each non-delta sensor end; it ends at a delta surface.
/// `visits`: scratch for where the path drew its technique samples (first_visit_of).
template <LightSampledScene Scn>
void trace_light_path(const Context<Scn>& ctx, std::uint64_t index,
                      RecordList<typename Scn::Scalar, typename Scn::Spectrum>& out, PathVisits<typename Scn::Scalar>& visits) {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  const Scn& scene = ctx.scene;
  Pcg32 rng = Pcg32::for_sample(ctx.options.seed, ctx.draw_index(index), 2 * ctx.stream + 1);
  const auto first = LightStartSampler<Scn>{}.sample(scene, {}, rng);
  if (!first) return;
  Record<T, S> r;
  r.segment = first->segment;
  r.first_direction = r.last_direction = first->direction;
  r.chain = S(T(1));
  r.flags = light_start | (first->delta ? delta_light : 0);
  // G in the segment's product measure; for a distant light the end at infinity drops 1/d^2.
  r.geometry = geometry_term(first->segment);
  const auto& bsdf = scene.bsdf();
  // Through delta reflections a segment continues into a light-born chain, measured like the
  // camera's (area x solid angle at x). Its density needs its light-side end's area measure
  // (light_measure, by etendue): a light predecessor's end is a surface point whatever the
  // light, so every predecessor chains, and so does the light start from an area light. From a
  // Dirac light (point, sun) the chain has no local density (a curved mirror's Jacobian enters)
  // but only the light start draws it: a kept_chain keeps the first segment's G and N_L p
  // (pool.hpp). A sky's chain is drawn by camera successors too (a diffuse point's chain through
  // glass to the sky), whose density would need the chain's disk point: where camera successors
  // draw (MVF, BDPF) it ends the light path and camera chains carry it; where they do not (PhF)
  // only the light start draws it, and it is kept like a Dirac chain. Through delta
  // transmissions too: between two media the radiance throughput is (n_x / n_y)^2 times the
  // importance throughput, and light_measure leaves the same factor out of the light side's
  // densities, so each light technique's f / p stays exact and the balance weights still sum
  // to one (docs/filtering.md, "Known limits").
  const bool sky_chain = !first->delta && r.segment.y.kind == PointKind::direction && !ctx.techniques.camera_successors;
  bool kept = first->delta || sky_chain;  // a chain of the light start's own would be a kept_chain
  bool chains = kept || r.segment.y.kind == PointKind::surface;
  if (kept) r.density = T(ctx.light_paths()) * first->pdf;  // used if it becomes a chain
  // No depth limit (Russian roulette with c at every non-delta vertex, TechniqueSet::
  // light_continuation): a depth limit would make a light-born segment's ability to draw a
  // predecessor depend on its depth, which the path-conditioned weighting cannot see (it deduces
  // "s was drawn by its chain successor" and then needs the successor's whole run of light
  // ancestors to fit; docs/bias-notes.md). Only the delta bounces of one chain are capped.
  const T continuation = T(ctx.techniques.light_continuation);
  visits.clear();
  // The light point y counts as visited: a later technique sample of the path near it exists
  // only if this segment was drawn, and would be counted in its D_l.
  mark_visited(ctx, r.segment.y, visits);
  for (std::size_t delta_bounces = 0;;) {
    const SurfacePoint<T>& x = r.segment.x;
    std::optional<BsdfSample<S>> prev;
    const bool attempted = x.kind == PointKind::surface && continuation > T(0);
    if (attempted)
      prev = bsdf.sample(BsdfSampleQuery<T>{x, r.first_direction, uniform2<T>(rng), rng.template uniform<T>(), Transport::importance});
    if (chains && prev && prev->delta && prev->pdf > T(0) && ++delta_bounces < ctx.options.max_length) {
      if (is_transmission(x, r.first_direction, prev->direction)) r.flags |= transmission_chain;
      const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{x.position, prev->direction}});
      if (!hit) return;  // the chain leaves the scene: no sensor segment can join it
      r.chain = r.chain * (prev->value * (std::abs(glm::dot(prev->direction, x.normal)) / prev->pdf));
      r.segment.x = hit->point;
      r.first_direction = -prev->direction;
      if (r.pieces < 0xffff) ++r.pieces;
      r.flags |= chain_segment | (kept ? kept_density : 0);
      // A kept chain keeps its first G; a repeat visit's draw stays in no chain (G = 0).
      if (!kept && !(r.flags & repeat_visit_born)) r.geometry = endpoint_cosine(r.segment.x, r.first_direction);
      continue;
    }
    // Light arriving at x from behind a one-sided surface (the sun's and the sky's rays on the
    // outside of a closed box) goes nowhere (HasScattersFrom): x's own BSDF passes none of it
    // on and gives every draw from x density 0, so the segment is not pooled. Clusters and disks
    // join points of one normal, where its direction is behind as well, so it carried light into
    // no junction (at most, through a curved surface's kernel, light leaking through it). Pooled,
    // it kept most wall clusters from factorising. Bridges then choose among the other targets.
    if (x.kind == PointKind::surface && !scatters_from<S>(bsdf, x, r.first_direction)) return;
    // A technique sample whether or not its draw succeeded (see trace_camera_path); a
    // delta surface that does not continue the chain ends the light path.
    const bool tries_predecessor = attempted && ctx.techniques.light_predecessors && !(prev && prev->delta);
    // A technique sample only at the path's first visit of a voxel (Context::visit_grid): the
    // predecessor drawn at a repeat visit is no technique's sample. Light technique samples
    // per path and voxel are then 0 or 1, fixed before the draw, as the weighting assumes.
    const bool first_visit = !tries_predecessor || first_visit_of(ctx, x, visits);
    if (tries_predecessor && first_visit) r.flags |= light_technique;
    // The roulette is part of the draw: a technique sample whose coin fails is a failed draw.
    const bool continues = tries_predecessor && prev && prev->pdf > T(0) && rng.template uniform<T>() < continuation;
    const auto index = std::uint32_t(out.size());
    out.push_back(r);
    if (!continues) return;
    // The approximate predecessor: y' = x exactly, x' the first hit towards the sensor side.
    const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{x.position, prev->direction}});
    if (!hit) return;
    Record<T, S> predecessor;
    predecessor.segment = Segment<T>{hit->point, x};
    predecessor.first_direction = predecessor.last_direction = -prev->direction;
    predecessor.chain = S(T(1));
    predecessor.geometry = geometry_term(predecessor.segment, -prev->direction, hit->distance);
    predecessor.parent = index;
    if (!first_visit) {
      predecessor.geometry = T(0);
      predecessor.flags = repeat_visit_born;
    }
    r = predecessor;
    delta_bounces = 0;
    chains = true;
    kept = false;  // a predecessor's chain is drawn by every light predecessor: not kept
  }
}

/// Bridge segments (BDPF option): every camera technique point y_t draws one light-born
/// start x_u uniformly among the M targets and, when the two see each other, adds the
/// segment y_t -> x_u. Failed draws (invisible, degenerate) still count as technique samples
/// in the density (compute_densities), as for the other samplers.
template <LightSampledScene Scn, ParallelFor P>
void add_bridges(Context<Scn>& ctx, const P& parallel_for) {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  const Scn& scene = ctx.scene;
  auto& pool = ctx.pool;
  std::vector<std::uint32_t> targets, sources;
  for (std::uint32_t i = 0; i < pool.size(); ++i) {
    if (is_bridge_target(pool, i)) targets.push_back(i);
    if (pool.flags[i] & camera_technique) sources.push_back(i);
  }
  pool.bridge_targets = targets.size();
  if (targets.empty()) return;
  std::vector<RecordList<T, S>> bridges(path_chunks);
  parallel_for(path_chunks, [&](std::size_t c) {
    const std::size_t j0 = sources.size() * c / path_chunks, j1 = sources.size() * (c + 1) / path_chunks;
    for (std::size_t j = j0; j < j1; ++j) {
      const std::uint32_t t = sources[j];
      Pcg32 rng = Pcg32::for_sample(ctx.options.seed ^ 0x627269646765ULL /* "bridge" */, ctx.draw_index(t), ctx.stream);
      const auto pick = std::min<std::size_t>(targets.size() - 1, std::size_t(rng.template uniform<double>() * double(targets.size())));
      Record<T, S> r;
      r.segment = Segment<T>{pool.segments[t].y, pool.segments[targets[pick]].x};
      const Vec3<T> d = r.segment.y.position - r.segment.x.position;
      const T distance = std::sqrt(glm::dot(d, d));
      if (!(distance > T(0)) || !std::isfinite(distance)) continue;
      if (!scene.visible(VisibilityQuery<T>{r.segment.x, r.segment.y})) continue;
      r.first_direction = r.last_direction = d / distance;
      r.chain = S(T(1));
      r.geometry = geometry_term(r.segment, r.first_direction, distance);
      r.flags = bridge_segment;
      if (!(r.geometry > T(0))) continue;
      bridges[c].push_back(r);
    }
  });
  append(pool, bridges, parallel_for);
}

/// Step 1: the camera and light paths of an iteration, pooled (camera paths in pixel
/// order, then light paths in index order), then the bridges; finish_pool completes the pool
/// once every technique has drawn. `later_draws`: how many segments the techniques that draw
/// after the paths (the user's, draw_extra) may add, reserved with the paths' and bridges'.
template <LightSampledScene Scn, ParallelFor P>
void draw_paths(Context<Scn>& ctx, const P& parallel_for, std::size_t later_draws = 0) {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  auto& pool = ctx.pool;
  const std::uint32_t pixels = ctx.pixels();
  const std::uint64_t light_paths = ctx.drawn_light_paths();
  ctx.stats.light_paths = light_paths;
  std::vector<RecordList<T, S>> camera(path_chunks), light(path_chunks);
  parallel_for(path_chunks, [&](std::size_t c) {
    const std::uint64_t p0 = pixels * c / path_chunks, p1 = pixels * (c + 1) / path_chunks;
    PathVisits<T> visits;
    for (std::uint64_t p = p0; p < p1; ++p) trace_camera_path(ctx, ctx.pixel(std::uint32_t(p)), camera[c], visits);
    const std::uint64_t l0 = light_paths * c / path_chunks, l1 = light_paths * (c + 1) / path_chunks;
    for (std::uint64_t l = l0; l < l1; ++l) trace_light_path(ctx, l, light[c], visits);
  });
  camera.insert(camera.end(), std::make_move_iterator(light.begin()), std::make_move_iterator(light.end()));
  std::size_t records = 0, bridge_sources = 0;
  for (const RecordList<T, S>& list : camera) {
    ctx.stats.record_bytes += list.capacity_bytes() - list.unfilled_bytes();
    ctx.stats.record_slack_bytes += list.unfilled_bytes();
    records += list.size();
    if (ctx.techniques.bridges) bridge_sources += list.count(camera_technique);
  }
  // Room for the bridges (one per camera technique point at most) and the later draws too:
  // their appends then move no array, which would leave the old ones as holes the later
  // stages' arrays do not fit, and hold both copies at once while it moves.
  pool.reserve(pool.size() + records + bridge_sources + later_draws);
  append(pool, camera, parallel_for);
  // The records are in the pool: freed before the bridges' draw grows it.
  std::vector<RecordList<T, S>>().swap(camera);
  if (ctx.techniques.bridges) add_bridges(ctx, parallel_for);
}

/// L_e of every pooled segment (through its chain), and room for its denominator.
template <LightSampledScene Scn, ParallelFor P>
void finish_pool(Context<Scn>& ctx, const P& parallel_for) {
  using T = typename Scn::Scalar;
  auto& pool = ctx.pool;
  const auto& emitter = ctx.scene.emitter();
  pool.emitted.resize(pool.size());
  for_blocks(pool.size(), parallel_for, [&](std::size_t i) {
    pool.emitted[i] = emitter.radiance(EmissionQuery<T>{pool.segments[i].y, -pool.last_direction[i]}) * pool.chain[i];
  });
}

}  // namespace segpath::filtering
