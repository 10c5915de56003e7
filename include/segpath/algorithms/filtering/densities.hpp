// Stage 4 of a filtering iteration: the MMIS denominator of every pooled segment (N39),
//   D(s) = [sensor] n_p p_W(s) + [light end] N_L p_L(s)
//        + K(x) sum_{camera technique samples t near x} p_w(s^ | y_t, s_t) |n_y . s^| / d^2
//        + K(y) sum_{light technique samples t near y} p_w(-s^ | x_t, s_t) |n_x . s^| / d^2
//        [+ K(x) n_cam(x) p_L(y | x), next-event] [+ bridges] [+ N_u p_u(s), the user's techniques],
// a segment never its own technique sample. Dirac light ends only light sampling produces.
// Voxel clusters sum per cluster (O(n) where the technique points are Lambertian with one
// normal); disks over each end's neighbour lists, K = 1 / (pi r^2).
#pragma once

#include "segpath/algorithms/filtering/context.hpp"
#include "segpath/algorithms/filtering/factorisation.hpp"
#include "segpath/algorithms/filtering/light_side.hpp"
#include "segpath/algorithms/filtering/technique_densities.hpp"
#include "segpath/propagation/clustering.hpp"
#include "segpath/propagation/disk_junctions.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

namespace segpath::filtering {

/// The unconditional techniques (sensor, light start), next-event segments (from K(x) n_cam
/// per segment, empty when off) and the total D(s).
template <LightSampledScene Scn, ParallelFor P>
void finish_densities(Context<Scn>& ctx, const std::vector<typename Scn::Scalar>& camera_sum,
                      const std::vector<typename Scn::Scalar>& light_sum, const std::vector<typename Scn::Scalar>& bridge_sum,
                      const std::vector<typename Scn::Scalar>& camera_points_at_x, const P& parallel_for) {
  using T = typename Scn::Scalar;
  const Scn& scene = ctx.scene;
  auto& pool = ctx.pool;
  const std::uint64_t light_paths = ctx.light_paths();
  parallel_for(pool.size(), [&](std::size_t i) {
    const std::uint16_t f = pool.flags[i];
        T d = camera_sum[i] + light_sum[i] + (bridge_sum.empty() ? T(0) : bridge_sum[i]);
    if (f & sensor_segment) d += sensor_density(scene, pool, i);
    if (const T p_light = light_start_density(scene, pool, i, light_paths); p_light > T(0)) {
      if (f & (delta_light | kept_density)) d = T(0);  // only the light start draws a Dirac end or a kept chain
      d += p_light;
    }
    if (!camera_points_at_x.empty() && camera_points_at_x[i] > T(0)) {
      // Next-event segments: K(x) n_cam(C(x)) p_L(y | x).
      const T p_towards = next_event_density(scene, pool, i);
      if (p_towards > T(0)) d += camera_points_at_x[i] * p_towards;
    }
    if (!ctx.extra_density.empty()) d += ctx.extra_density[i];  // the user's techniques
    pool.density[i] = std::isfinite(d) ? d : T(0);
  });
}

/// Step 4: the MMIS denominators D(s) of every pooled segment (N39), voxel support; with
/// `side`, also the light side of every denominator for the path-conditioned weighting.
template <LightSampledScene Scn, ParallelFor P>
void compute_densities(Context<Scn>& ctx, const Clustering<typename Scn::Scalar>& clustering, const P& parallel_for,
                       LightSide<typename Scn::Scalar>* side = nullptr) {
  using T = typename Scn::Scalar;
  const Scn& scene = ctx.scene;
  auto& pool = ctx.pool;
  auto& stats = ctx.stats;
  const auto clusters = clustering.clusters();
  if (side) light_side_start(ctx, *side, parallel_for);
  // Technique densities carry the roulettes' c (TechniqueSet::light_continuation and
  // camera_continuation).
  const T continuation = T(ctx.techniques.light_continuation);
  const T camera_continuation = T(ctx.techniques.camera_continuation);
  const T tail_continuation = T(ctx.techniques.camera_tail_continuation);  // camera_tail samples
  std::vector<T> camera_sum(pool.size(), T(0)), light_sum(pool.size(), T(0));
  std::vector<std::uint64_t> pairs(clusters.size(), 0);
  std::vector<std::uint8_t> camera_fact(clusters.size(), 0), light_fact(clusters.size(), 0);
  std::vector<std::uint32_t> camera_points(clusters.size(), 0), bridge_targets(clusters.size(), 0);
  // The segments of `segments` for which keep(segment) holds.
  const auto count = [&](std::span<const std::uint32_t> segments, const auto& keep) {
    std::uint32_t n = 0;
    for (const std::uint32_t s : segments) n += keep(s) ? 1 : 0;
    return n;
  };
  const auto flagged = [&](std::uint16_t flag) { return [&pool, flag](std::uint32_t s) { return (pool.flags[s] & flag) != 0; }; };
  parallel_for(clusters.size(), [&](std::size_t c) {
    const Cluster<T>& cl = clusters[c];
    const auto starting = clustering.starting_segments(c), ending = clustering.ending_segments(c);
    // Camera technique samples: segments ending here that tried a successor; they could draw any
    // segment starting here (x' in the voxel). Density (N31) with the voxel kernel K_C.
    const std::uint32_t m = count(ending, flagged(camera_technique));
    camera_points[c] = m;
    if (ctx.techniques.bridges)
      bridge_targets[c] = count(starting, [&](std::uint32_t s) { return is_bridge_target(pool, s); });
    if (m > 0) {
      const auto y_of = [&](std::uint32_t s) -> const SurfacePoint<T>& { return pool.segments[s].y; };
      std::optional<Vec3<T>> common;
      if (ctx.options.factorise) common = common_lambertian_normal(scene, y_of, ending);
      camera_fact[c] = common ? 1 : 0;
      // The technique samples whose incoming direction the (one-sided) BSDF accepts.
      const SurfacePoint<T>& any_y = pool.segments[ending.front()].y;
      // Valid technique points drawing with c_c, and with the tail's c (camera_tail).
      const auto valid = [&](std::uint32_t t, bool tail) {
        return (pool.flags[t] & camera_technique) && ((pool.flags[t] & camera_tail) != 0) == tail &&
               glm::dot(-pool.last_direction[t], any_y.normal) > one_sided_epsilon<T>;
      };
      const std::uint32_t valid_camera = !common ? 0 : count(ending, [&](std::uint32_t t) { return valid(t, false); });
      const std::uint32_t valid_tail = !common ? 0 : count(ending, [&](std::uint32_t t) { return valid(t, true); });
      for (const std::uint32_t sp : starting) {
        if (!camera_reachable(pool, sp)) continue;
        const Vec3<T>& w = pool.first_direction[sp];
        T sum = T(0), tail_sum = T(0);  // the p_w of the technique points drawing with c_c, with the tail's c
        if (common) {
          // Lambertian technique points with one normal: p_w = cos / pi for every t (+ one-sided
          // checks), s' itself not among them (a segment is not its own technique sample).
          const T cosine = glm::dot(w, *common);
          const bool self = clustering.cluster_of_y(sp) == c && valid(sp, false);
          const bool self_tail = clustering.cluster_of_y(sp) == c && valid(sp, true);
          if (glm::dot(w, any_y.normal) > one_sided_epsilon<T> && cosine > T(0)) {
            sum = T(valid_camera - (self ? 1 : 0)) * cosine * inv_pi<T>;
            tail_sum = T(valid_tail - (self_tail ? 1 : 0)) * cosine * inv_pi<T>;
          }
          pairs[c] += 1;
        } else {
          for (const std::uint32_t t : ending) {
            if (!(pool.flags[t] & camera_technique) || t == sp) continue;
            ((pool.flags[t] & camera_tail) ? tail_sum : sum) += camera_technique_pdf(scene, pool, t, sp);
            pairs[c] += 1;
          }
        }
        camera_sum[sp] = (camera_continuation * cl.kernel * sum + tail_continuation * cl.kernel * tail_sum) * camera_measure<Scn>(pool, sp);
      }
    }
    // Light technique samples: segments starting here that were continued backwards; they
    // could draw any plain segment ending here (y' in the voxel).
    if (count(starting, flagged(light_technique)) > 0) {
      const auto x_of = [&](std::uint32_t s) -> const SurfacePoint<T>& { return pool.segments[s].x; };
      std::optional<Vec3<T>> common;
      if (ctx.options.factorise) common = common_lambertian_normal(scene, x_of, starting);
      light_fact[c] = common ? 1 : 0;
      const SurfacePoint<T>& any_x = pool.segments[starting.front()].x;
      const std::uint32_t valid_light = !common ? 0 : count(starting, [&](std::uint32_t t) {
        return (pool.flags[t] & light_technique) && glm::dot(pool.first_direction[t], any_x.normal) > one_sided_epsilon<T>;
      });
      for (const std::uint32_t sp : ending) {
        if (!light_reachable(pool, sp)) continue;
        const Vec3<T> to_sensor = -pool.last_direction[sp];
        const T scale = continuation * cl.kernel * light_measure<Scn>(pool, sp);
        T sum = T(0);
        if (common) {
          const T cosine = glm::dot(to_sensor, *common);
          // s' itself is not among the technique samples.
          const bool self = clustering.cluster_of_x(sp) == c && (pool.flags[sp] & light_technique) &&
                            glm::dot(pool.first_direction[sp], any_x.normal) > one_sided_epsilon<T>;
          const std::uint32_t light_count = valid_light - (self ? 1 : 0);
          if (glm::dot(to_sensor, any_x.normal) > one_sided_epsilon<T> && cosine > T(0)) {
            sum = T(light_count) * cosine * inv_pi<T>;
            if (side && scale * cosine > T(0)) side->terms[sp] += light_count;
          }
          pairs[c] += 1;
        } else {
          for (const std::uint32_t t : starting) {
            if (!(pool.flags[t] & light_technique) || t == sp) continue;
            const T pdf = light_technique_pdf(scene, pool, t, sp);
            sum += pdf;
            pairs[c] += 1;
            if (side && scale * pdf > T(0)) side->terms[sp] += 1;
          }
        }
        light_sum[sp] = scale * sum;
        if (side) side->density[sp] += light_sum[sp];
      }
    }
  });
  for (std::size_t c = 0; c < clusters.size(); ++c) {
    stats.pair_evaluations += pairs[c];
    stats.factorised_camera_clusters += camera_fact[c];
    stats.factorised_light_clusters += light_fact[c];
  }
  // Camera technique points per unit area at x, K(x) n_cam(C(x)), for the techniques that
  // draw their segment's x from any of them: bridges, K(x) n_cam(C(x)) K(y) n_light(C(y)) / M,
  // and next-event segments (finish_densities).
  const bool bridges = ctx.techniques.bridges && pool.bridge_targets > 0;
  std::vector<T> camera_points_at_x, bridge_sum;
  if (bridges || ctx.techniques.next_event) {
    camera_points_at_x.assign(pool.size(), T(0));
    if (bridges) bridge_sum.assign(pool.size(), T(0));
    if (bridges && side) side->bridge_target_term.assign(pool.size(), T(0));
    parallel_for(pool.size(), [&](std::size_t i) {
      const std::uint32_t cx = clustering.cluster_of_x(std::uint32_t(i)), cy = clustering.cluster_of_y(std::uint32_t(i));
      if (cx == no_cluster) return;
      // Not counting segment i itself, as a camera point at x or as a bridge target at y.
      const bool self_point = (pool.flags[i] & camera_technique) && cy == cx;
      camera_points_at_x[i] = clusters[cx].kernel * T(camera_points[cx] - (self_point ? 1 : 0));
      const bool self_target = is_bridge_target(pool, i) && cy == cx;
      if (bridges && cy != no_cluster && bridge_reachable(pool, i)) {
        const T term = camera_points_at_x[i] * clusters[cy].kernel / T(pool.bridge_targets);  // one target's
        bridge_sum[i] = term * T(bridge_targets[cy] - (self_target ? 1 : 0));
        if (side) side->bridge_target_term[i] = term;
      }
    });
    if (bridges && side) side->bridge_density = bridge_sum;
    if (!ctx.techniques.next_event) camera_points_at_x.clear();
  }
  finish_densities(ctx, camera_sum, light_sum, bridge_sum, camera_points_at_x, parallel_for);
}

/// Step 4 over the disk support: the technique samples of a segment are its neighbour lists
/// (every camera technique end whose disk holds x_s, every light technique start in the disk
/// of y_s), K = 1 / (pi r^2).
template <LightSampledScene Scn, ParallelFor P>
void compute_densities(Context<Scn>& ctx, const DiskJunctions<typename Scn::Scalar>& junctions, const P& parallel_for,
                       LightSide<typename Scn::Scalar>* side = nullptr) {
  using T = typename Scn::Scalar;
  const Scn& scene = ctx.scene;
  auto& pool = ctx.pool;
  auto& stats = ctx.stats;
  const T kernel = junctions.kernel();
  const bool bridges = ctx.techniques.bridges && pool.bridge_targets > 0;
  std::vector<T> camera_sum(pool.size(), T(0)), light_sum(pool.size(), T(0)), bridge_sum(bridges ? pool.size() : 0, T(0));
  std::vector<T> camera_points_at_x(ctx.techniques.next_event ? pool.size() : 0, T(0));
  if (bridges && side) side->bridge_target_term.assign(pool.size(), T(0));
  constexpr std::size_t chunk = 1024;
  const std::size_t chunks = (pool.size() + chunk - 1) / chunk;
  std::vector<std::uint64_t> pairs(chunks, 0);
  parallel_for(chunks, [&](std::size_t c) {
    for (std::size_t i = c * chunk; i < std::min(pool.size(), (c + 1) * chunk); ++i) {
      const auto sp = std::uint32_t(i);
      std::uint32_t camera_points = 0, targets = 0;
      T sum = T(0), tail_sum = T(0);  // the p_w of the technique points drawing with c_c, with the tail's c
      for (const std::uint32_t t : junctions.ending_near(sp)) {
        if (!(pool.flags[t] & camera_technique)) continue;
        ++camera_points;
        if (!camera_reachable(pool, sp)) continue;
        ((pool.flags[t] & camera_tail) ? tail_sum : sum) += camera_technique_pdf(scene, pool, t, sp);
        pairs[c] += 1;
      }
      if (sum > T(0) || tail_sum > T(0))
        camera_sum[sp] = (T(ctx.techniques.camera_continuation) * kernel * sum + T(ctx.techniques.camera_tail_continuation) * kernel * tail_sum) *
                         camera_measure<Scn>(pool, sp);
      sum = T(0);
      for (const std::uint32_t u : junctions.starting_near(sp)) {
        targets += (bridges && is_bridge_target(pool, u)) ? 1 : 0;
        if (!(pool.flags[u] & light_technique) || !light_reachable(pool, sp)) continue;
        sum += light_technique_pdf(scene, pool, u, sp);
        pairs[c] += 1;
      }
      if (sum > T(0)) light_sum[sp] = T(ctx.techniques.light_continuation) * kernel * sum * light_measure<Scn>(pool, sp);
      if (bridges && bridge_reachable(pool, sp)) {
        const T term = kernel * T(camera_points) * kernel / T(pool.bridge_targets);  // one target's
        bridge_sum[sp] = term * T(targets);
        if (side) side->bridge_target_term[sp] = term;
      }
      if (ctx.techniques.next_event) camera_points_at_x[sp] = kernel * T(camera_points);
    }
  });
  for (const auto p : pairs) stats.pair_evaluations += p;
  if (bridges && side) side->bridge_density = bridge_sum;
  finish_densities(ctx, camera_sum, light_sum, bridge_sum, camera_points_at_x, parallel_for);
}

}  // namespace segpath::filtering
