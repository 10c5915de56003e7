// Multi-vertex path filtering (MVF), photon filtering (PhF) and the paper's bidirectional path
// filtering (BDPF) (SPEC 1.9): approximate sequential segments (N33) from the sensor and/or the
// lights are pooled, clustered by voxel (SPEC 1.2), weighted by the recursive MMIS estimator's
// balance heuristic over every technique sample touching each cluster (N39, N40), and
// propagated (SPEC 1.8, Algorithm 1).
//
// One iteration:
//  1. one camera path per pixel (MVF, BDPF; PhF: only its sensor segment) and, for PhF and
//     BDPF, N_L = beta x #pixels light paths, all with the approximate samplers: a successor
//     starts exactly where its predecessor ended (N33);
//  2. specular (delta) vertices are not junctions: a camera path folds them into its segment
//     (a chain x -> specular ... -> y, integrated in (area at x) x (solid angle at x)); a light
//     path ends at a delta surface (light-born chains would need the other side's density in
//     a common measure), so every chain comes from the camera side only and needs no other
//     technique in its MMIS sum;
//  3. endpoints are clustered on a jittered voxel grid whose cell shrinks like a PPM radius;
//  4. every segment's MMIS denominator (N39)
//       D(s) = [sensor] n_p p_W(s) + [light end] N_L p_L(s)
//            + K_C(x) sum_{camera technique samples t ending in C(x)} p_w(s^ | y_t, s_t) |n_y . s^| / d^2
//            + K_C(y) sum_{light technique samples t starting in C(y)} p_w(-s^ | x_t, s_t) |n_x . s^| / d^2,
//     with the voxel kernel K_C = 1 / (area of the cluster's mean plane in the voxel). Dirac
//     light ends (point lights, the sun) only light sampling can produce: D = N_L p_L;
//  5. propagation over clusters, max_length - 1 Jacobi iterations, from L_e;
//  6. gather: pixel p += W G L(s_1) / D(s_1) over its sensor segments.
// Known limits (measured, see tests/renderer/methods_test.cpp):
//  - max_length counts pooled segments and propagation iterations; a chain through specular
//    vertices is one segment, so paths with specular bounces may be longer than max_length
//    physical segments (PT counts every bounce). Negligible at length 10, visible at 3-4.
//  - MMIS with compactly supported conditionals is biased by the chance that no technique
//    sample covers a point (a cluster with no camera technique cannot continue a path): MVF has
//    no unconditional technique past the sensor segment, so it darkens as voxels empty.
//  - On SmallVCM's box 1 the glossy floor drifts brighter than PT as the voxel shrinks at
//    beta = 0.25 (+7.6 % +- 1.4 % at half the default voxel), not at beta = 2; not explained yet.
// Beyond the paper: a cluster whose camera (light) technique points are all Lambertian with
// one shading normal has technique densities independent of the technique sample, so its sum
// is m p(s) (O(n) instead of O(n m)); with every ending point Lambertian with one normal, the
// transfer factorises too (propagation/propagate.hpp).
#pragma once

#include "segpath/concepts/scene.hpp"
#include "segpath/core/contribution.hpp"
#include "segpath/core/framebuffer.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/kernels/progressive_radius.hpp"
#include "segpath/materials/scattering.hpp"
#include "segpath/propagation/clustering.hpp"
#include "segpath/propagation/propagate.hpp"
#include "segpath/samplers/light_start.hpp"
#include "segpath/samplers/sensor_start.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace segpath {

enum class FilteringMode : std::uint8_t {
  mvf,   ///< camera paths only: multi-vertex path filtering
  phf,   ///< light paths and sensor segments: photon filtering
  bdpf,  ///< both: bidirectional path filtering (the paper's method)
};

[[nodiscard]] constexpr const char* to_string(FilteringMode m) noexcept {
  switch (m) {
    case FilteringMode::mvf: return "mvf";
    case FilteringMode::phf: return "phf";
    case FilteringMode::bdpf: return "bdpf";
  }
  return "?";
}

template <Real T>
struct FilteringOptions {
  FilteringMode mode = FilteringMode::bdpf;
  std::size_t max_length = 10;  ///< segments per path (>= 2): propagation runs max_length - 1 iterations
  T light_path_ratio = T(0.25);  ///< beta: light paths per pixel per iteration (PhF, BDPF)
  T initial_cell_size = 0;       ///< voxel size of iteration 1; 0: 4x the average pixel footprint
  T alpha = T(0.67);             ///< progressive shrinking of the voxel (PPM schedule)
  bool factorise = true;         ///< use the O(n) sums in factorisable clusters
  /// Shift the voxel grid randomly each iteration (quantisation becomes noise). Off, the grid
  /// is aligned with the origin: on a periodic domain (canonical_position) whose period is a
  /// multiple of the voxel size, voxels then tile the fundamental cell exactly.
  bool jitter = true;
  std::uint64_t seed = 1;
};

/// Counters of one iteration (pool size, clusters, how many were factorised).
struct FilteringStats {
  std::uint64_t segments = 0, camera_segments = 0, light_segments = 0, clusters = 0;
  std::uint64_t factorised_camera_clusters = 0, factorised_light_clusters = 0, factorised_transfer_clusters = 0;
  std::uint64_t pair_evaluations = 0;  ///< technique-density and transfer evaluations
  double cell_size = 0;
  std::size_t bytes_per_segment = 0;
};

template <LightSampledScene Scn>
class SegmentFiltering {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;

  explicit SegmentFiltering(FilteringOptions<T> options) : options_(options) {
    if (options.max_length < 2)
      throw std::invalid_argument("segpath::SegmentFiltering: max_length must be >= 2 (k >= 1 propagation iterations), got " +
                                  std::to_string(options.max_length));
    if (options.mode != FilteringMode::mvf && !(options.light_path_ratio > T(0) && std::isfinite(options.light_path_ratio)))
      throw std::invalid_argument("segpath::SegmentFiltering: beta (light paths per pixel) must be > 0, got " +
                                  std::to_string(options.light_path_ratio));
    if (!(options.initial_cell_size >= T(0)) || !std::isfinite(options.initial_cell_size))
      throw std::invalid_argument("segpath::SegmentFiltering: voxel size must be > 0 (or 0 for automatic), got " +
                                  std::to_string(options.initial_cell_size));
    if (!(options.alpha > T(0) && options.alpha < T(1)))
      throw std::invalid_argument("segpath::SegmentFiltering: alpha must lie in (0, 1), got " + std::to_string(options.alpha));
  }
  [[nodiscard]] const FilteringOptions<T>& options() const noexcept { return options_; }

  /// The voxel size of iteration 1: the option, or 4x the average pixel footprint (distance
  /// to the first hit times the side of a pixel's solid angle), from the pixel centres of
  /// every 7th pixel — deterministic and cheap.
  [[nodiscard]] T initial_cell_size(const Scn& scene) const {
    if (options_.initial_cell_size > T(0)) return options_.initial_cell_size;
    const auto& sensor = scene.sensor();
    double sum = 0;
    std::uint64_t count = 0;
    for (std::uint32_t p = 0; p < sensor.pixel_count(); p += 7) {
      const auto ray = sensor.sample_ray(SensorSampleQuery<T>{p, Vec2<T>(T(0.5)), Vec2<T>(T(0.5))});
      if (!ray || !(ray->pdf_direction > T(0))) continue;
      const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{ray->origin.position, ray->direction}});
      if (!hit) continue;
      sum += double(hit->distance) / std::sqrt(double(ray->pdf_direction));
      ++count;
    }
    if (count == 0) return T(1e-2);
    return T(4.0 * sum / double(count));
  }

  /// The voxel grid of an iteration: jittered from the iteration's own stream, or aligned.
  [[nodiscard]] VoxelGrid<T> grid(T cell, std::uint64_t iteration) const {
    return options_.jitter ? VoxelGrid<T>::jittered(cell, options_.seed, iteration) : VoxelGrid<T>(cell);
  }

  /// The voxel size of `iteration` (>= 1) given the first.
  [[nodiscard]] T cell_size(T initial, std::uint64_t iteration) const {
    return ProgressiveRadius<T>(initial, options_.alpha).radius(iteration);
  }

  /// Adds one iteration's estimate to `image` (one camera path per pixel). Deterministic for a
  /// given seed and iteration whatever `parallel_for` does.
  template <ParallelFor P = SerialFor>
  FilteringStats render_iteration(const Scn& scene, std::uint64_t iteration, T cell, Framebuffer<S>& image,
                                  DropCounters& drops, const P& parallel_for = {}) const {
    Pool pool;
    build_pool(scene, iteration, pool, parallel_for);
    FilteringStats stats;
    stats.segments = pool.size();
    for (auto f : pool.flags) (f & camera_born ? stats.camera_segments : stats.light_segments) += 1;
    stats.cell_size = double(cell);

    Clustering<T> clustering;
    cluster(scene, grid(cell, iteration), pool, clustering);
    stats.clusters = clustering.clusters().size();
    compute_densities(scene, pool, clustering, stats, parallel_for);

    // Propagation (Algorithm 1) and the per-pixel gather (N40).
    std::vector<S> radiance;
    std::vector<T> weighted_geometry;
    propagate_pool(scene, pool, clustering, int(options_.max_length) - 1, radiance, weighted_geometry, stats, parallel_for);
    for (std::size_t i = 0; i < pool.size(); ++i) {
      if (!(pool.flags[i] & sensor_segment)) continue;
      const S value = radiance[i] * (pool.sensor_weight[i] * weighted_geometry[i]);
      if (is_finite(value)) image.add(pool.pixel[i], value);
      else drops.add(DropReason::non_finite);
    }
    stats.bytes_per_segment = pool.bytes_per_segment() + clustering.bytes_per_segment() + sizeof(T) +
                              (options_.factorise ? 3 : 2) * sizeof(S);
    return stats;
  }

  // ---- The stages of one iteration, public for tests and instrumentation ------------------

  static constexpr std::uint8_t sensor_segment = 1;     ///< s_1 of a camera path
  static constexpr std::uint8_t camera_born = 2;        ///< drawn by the camera side
  static constexpr std::uint8_t chain_segment = 4;      ///< contains delta vertices: (area x, solid angle x) measure
  static constexpr std::uint8_t camera_technique = 8;   ///< a camera successor draw was attempted from it
  static constexpr std::uint8_t light_technique = 16;   ///< a light predecessor draw was attempted from it
  static constexpr std::uint8_t light_start = 32;       ///< drawn by the light-start sampler
  static constexpr std::uint8_t delta_light = 64;       ///< its light end is a Dirac (point light, sun)

  /// One iteration's segments, structure of arrays (memory O(#segments)).
  struct Pool {
    std::vector<Segment<T>> segments;
    std::vector<Vec3<T>> first_direction, last_direction;  ///< unit, at x and at y (equal unless a chain)
    std::vector<S> chain, emitted;                         ///< delta-vertex throughput; chain * L_e(y)
    std::vector<T> geometry, density, sensor_weight;       ///< G, D and W for sensor segments
    std::vector<std::uint32_t> pixel;
    std::vector<std::uint8_t> flags;
    [[nodiscard]] std::size_t size() const noexcept { return segments.size(); }
    [[nodiscard]] std::size_t bytes_per_segment() const noexcept {
      return sizeof(Segment<T>) + 2 * sizeof(Vec3<T>) + 2 * sizeof(S) + 3 * sizeof(T) + sizeof(std::uint32_t) + 1;
    }
  };

  /// A segment as a path generator produces it, before pooling.
  struct Record {
    Segment<T> segment;
    Vec3<T> first_direction, last_direction;
    S chain;
    T geometry = 0, sensor_weight = 0;
    std::uint32_t pixel = 0;
    std::uint8_t flags = 0;
  };

  /// N_L: light paths per iteration.
  std::uint64_t light_path_count(const Scn& scene) const {
    if (options_.mode == FilteringMode::mvf) return 0;
    return std::uint64_t(std::llround(double(options_.light_path_ratio) * double(scene.sensor().pixel_count())));
  }

  static constexpr std::size_t chunk_count = 64;

  /// Step 1: the camera and light paths of an iteration, pooled (camera paths in pixel
  /// order, then light paths in index order).
  template <class P>
  void build_pool(const Scn& scene, std::uint64_t iteration, Pool& pool, const P& parallel_for) const {
    const std::uint32_t pixels = scene.sensor().pixel_count();
    const std::uint64_t light_paths = light_path_count(scene);
    std::vector<std::vector<Record>> camera(chunk_count), light(chunk_count);
    parallel_for(chunk_count, [&](std::size_t c) {
      const std::uint64_t p0 = pixels * c / chunk_count, p1 = pixels * (c + 1) / chunk_count;
      for (std::uint64_t p = p0; p < p1; ++p) trace_camera_path(scene, std::uint32_t(p), iteration, camera[c]);
      const std::uint64_t l0 = light_paths * c / chunk_count, l1 = light_paths * (c + 1) / chunk_count;
      for (std::uint64_t l = l0; l < l1; ++l) trace_light_path(scene, l, iteration, light[c]);
    });
    std::size_t total = 0;
    for (std::size_t c = 0; c < chunk_count; ++c) total += camera[c].size() + light[c].size();
    auto reserve = [&](auto& v) { v.reserve(total); };
    reserve(pool.segments), reserve(pool.first_direction), reserve(pool.last_direction), reserve(pool.chain);
    reserve(pool.geometry), reserve(pool.sensor_weight), reserve(pool.pixel), reserve(pool.flags);
    const auto& emitter = scene.emitter();
    auto append = [&](const Record& r) {
      pool.segments.push_back(r.segment);
      pool.first_direction.push_back(r.first_direction);
      pool.last_direction.push_back(r.last_direction);
      pool.chain.push_back(r.chain);
      pool.geometry.push_back(r.geometry);
      pool.sensor_weight.push_back(r.sensor_weight);
      pool.pixel.push_back(r.pixel);
      pool.flags.push_back(r.flags);
    };
    for (const auto& chunk : camera)
      for (const auto& r : chunk) append(r);
    for (const auto& chunk : light)
      for (const auto& r : chunk) append(r);
    pool.emitted.resize(total);
    for (std::size_t i = 0; i < total; ++i)
      pool.emitted[i] = emitter.radiance(EmissionQuery<T>{pool.segments[i].y, -pool.last_direction[i]}) * pool.chain[i];
    pool.density.assign(total, T(0));
    (void)iteration;
  }

 private:
  /// One camera path: the sensor segment, then approximate successors (N33) from each
  /// non-delta end; delta bounces extend the current segment into a chain. MVF and BDPF go
  /// to max_length segments (delta bounces count), PhF keeps only the sensor segment.
  void trace_camera_path(const Scn& scene, std::uint32_t pixel, std::uint64_t iteration, std::vector<Record>& out) const {
    Pcg32 rng = Pcg32::for_sample(options_.seed, pixel, 2 * iteration);
    const auto first = SensorStartSampler<Scn>{}.sample(scene, {pixel}, rng);
    if (!first) return;
    const auto ray = scene.sensor().pdf(SensorQuery<T>{first->segment.x, first->direction});
    const auto response = scene.sensor().importance(SensorQuery<T>{first->segment.x, first->direction});
    if (!response || !(ray.position * ray.direction > T(0))) return;
    const std::size_t max_pieces = options_.max_length;
    Record r;
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
    for (;;) {
      // Follow delta bounces: the segment continues through them.
      std::optional<BsdfSample<S>> next;
      if (y.kind == PointKind::surface && pieces < max_pieces) {
        next = bsdf.sample(BsdfSampleQuery<T>{y, -direction, uniform2<T>(rng), rng.template uniform<T>(), Transport::radiance});
        if (next && next->delta && next->pdf > T(0)) {
          chain = chain * (next->value * (std::abs(glm::dot(next->direction, y.normal)) / next->pdf));
          const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{y.position, next->direction}});
          direction = next->direction;
          ++pieces;
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
      r.geometry = (r.flags & chain_segment) ? endpoint_cosine(r.segment.x, r.first_direction)
                                             : geometry_term(r.segment, direction, distance);
      // Every attempted successor draw is a technique sample, including draws that failed:
      // SMIS/MMIS denominators sum over all technique samples (N11, N39); leaving the failed
      // ones out would underestimate D and bias the image upwards (glossy lobes at grazing
      // angles fail often).
      const bool attempted = options_.mode != FilteringMode::phf && pieces < max_pieces && y.kind == PointKind::surface;
      if (attempted) r.flags |= camera_technique;
      const bool continues = attempted && next && !next->delta && next->pdf > T(0);
      out.push_back(r);
      if (!continues) return;
      // The approximate successor (N33): starts exactly at y, direction from the BSDF at y.
      const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{y.position, next->direction}});
      Record successor;
      successor.segment.x = y;
      successor.first_direction = next->direction;
      successor.flags = camera_born;
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
  void trace_light_path(const Scn& scene, std::uint64_t index, std::uint64_t iteration, std::vector<Record>& out) const {
    Pcg32 rng = Pcg32::for_sample(options_.seed, index, 2 * iteration + 1);
    const auto first = LightStartSampler<Scn>{}.sample(scene, {}, rng);
    if (!first) return;
    Record r;
    r.segment = first->segment;
    r.first_direction = r.last_direction = first->direction;
    r.chain = S(T(1));
    r.flags = light_start | (first->delta ? delta_light : 0);
    // G in the segment's product measure; for a distant light the end at infinity drops 1/d^2.
    r.geometry = geometry_term(first->segment);
    const auto& bsdf = scene.bsdf();
    for (std::size_t pieces = 1;; ++pieces) {
      const SurfacePoint<T>& x = r.segment.x;
      std::optional<BsdfSample<S>> prev;
      const bool attempted = x.kind == PointKind::surface && pieces + 1 < options_.max_length;
      if (attempted)
        prev = bsdf.sample(BsdfSampleQuery<T>{x, r.first_direction, uniform2<T>(rng), rng.template uniform<T>(), Transport::importance});
      // A technique sample whether or not its draw succeeded (see trace_camera_path); a
      // delta surface ends the light path and has no density for any segment anyway.
      if (attempted && !(prev && prev->delta)) r.flags |= light_technique;
      const bool continues = prev && !prev->delta && prev->pdf > T(0);
      out.push_back(r);
      if (!continues) return;
      // The approximate predecessor: y' = x exactly, x' the first hit towards the sensor side.
      const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{x.position, prev->direction}});
      if (!hit) return;
      Record predecessor;
      predecessor.segment = Segment<T>{hit->point, x};
      predecessor.first_direction = predecessor.last_direction = -prev->direction;
      predecessor.chain = S(T(1));
      predecessor.geometry = geometry_term(predecessor.segment, -prev->direction, hit->distance);
      r = predecessor;
    }
  }

  /// Whether every point in [begin, end) of `refs` (the given end of each segment) has a
  /// Lambertian BSDF and one shading normal; returns that normal.
  template <class Ends>
  static std::optional<Vec3<T>> common_lambertian_normal(const Scn& scene, const Ends& end_of, std::span<const EndpointRef> refs,
                                                         std::uint32_t begin, std::uint32_t end) {
    using B = std::remove_cvref_t<decltype(scene.bsdf())>;
    if constexpr (!HasLambertianAlbedo<B, S>) {
      return std::nullopt;
    } else {
      if (begin == end) return std::nullopt;
      const auto& bsdf = scene.bsdf();
      const Vec3<T> n = end_of(refs[begin].segment).shading_normal;
      for (std::uint32_t r = begin; r < end; ++r) {
        const SurfacePoint<T>& p = end_of(refs[r].segment);
        if (!(p.shading_normal == n) || !(p.normal == end_of(refs[begin].segment).normal) || !bsdf.lambertian_albedo(p)) return std::nullopt;
      }
      return n;
    }
  }

 public:
  /// Step 5: `iterations` Jacobi iterations of propagation over the clustered pool, using the
  /// factorised O(n + m) sums where the options allow and the cluster qualifies. Returns L
  /// and G w per segment.
  template <class P = SerialFor>
  void propagate_pool(const Scn& scene, const Pool& pool, const Clustering<T>& clustering, int iterations,
                      std::vector<S>& radiance, std::vector<T>& weighted_geometry, FilteringStats& stats,
                      const P& parallel_for = {}) const {
    weighted_geometry.resize(pool.size());
    for (std::size_t i = 0; i < pool.size(); ++i)
      weighted_geometry[i] = pool.density[i] > T(0) ? pool.geometry[i] / pool.density[i] : T(0);
    std::vector<std::uint8_t> factorised;
    std::vector<S> diffuse;
    if (options_.factorise) transfer_factorisation(scene, pool, clustering, factorised, diffuse, stats);
    const auto& bsdf = scene.bsdf();
    auto link = [&](std::uint32_t s, std::uint32_t sp) -> S {
      const S f = bsdf.eval(BsdfQuery<T>{pool.segments[s].y, -pool.last_direction[s], pool.first_direction[sp], Transport::radiance});
      return f * pool.chain[s];
    };
    const PropagationInputs<S, decltype(link)> inputs{clustering, pool.emitted, weighted_geometry, link, diffuse, factorised};
    std::vector<S> scratch;
    propagate(inputs, iterations, radiance, scratch, parallel_for);
  }

  /// Clusters a pool's endpoints on `grid` (by canonical position where the scene has one).
  void cluster(const Scn& scene, const VoxelGrid<T>& grid, const Pool& pool, Clustering<T>& clustering) const {
    if constexpr (HasCanonicalPosition<Scn>) {
      clustering.build(grid, pool.segments, [&](const SurfacePoint<T>& p) { return scene.canonical_position(p); });
    } else {
      clustering.build(grid, pool.segments);
    }
  }

  /// Step 4: the MMIS denominators D(s) of every pooled segment (N39).
  template <class P>
  void compute_densities(const Scn& scene, Pool& pool, const Clustering<T>& clustering, FilteringStats& stats,
                         const P& parallel_for) const {
    const auto clusters = clustering.clusters();
    const auto refs = clustering.refs();
    const auto& bsdf = scene.bsdf();
    std::vector<T> camera_sum(pool.size(), T(0)), light_sum(pool.size(), T(0));
    std::vector<std::uint64_t> pairs(clusters.size(), 0);
    std::vector<std::uint8_t> camera_fact(clusters.size(), 0), light_fact(clusters.size(), 0);
    parallel_for(clusters.size(), [&](std::size_t c) {
      const Cluster<T>& cl = clusters[c];
      // Camera technique samples: segments ending here that were continued; they could draw any
      // segment starting here (x' in the voxel). Density (N31) with the voxel kernel K_C.
      std::uint32_t m = 0;
      for (std::uint32_t q = cl.middle; q < cl.end; ++q) m += (pool.flags[refs[q].segment] & camera_technique) ? 1 : 0;
      if (m > 0) {
        const auto y_of = [&](std::uint32_t s) -> const SurfacePoint<T>& { return pool.segments[s].y; };
        std::optional<Vec3<T>> common;
        if (options_.factorise) common = common_lambertian_normal(scene, y_of, refs, cl.middle, cl.end);
        camera_fact[c] = common ? 1 : 0;
        // The technique samples whose incoming direction the (one-sided) BSDF accepts.
        const SurfacePoint<T>& any_y = pool.segments[refs[cl.middle].segment].y;
        std::uint32_t valid_camera = 0;
        if (common)
          for (std::uint32_t q = cl.middle; q < cl.end; ++q) {
            const std::uint32_t t = refs[q].segment;
            if ((pool.flags[t] & camera_technique) && glm::dot(-pool.last_direction[t], any_y.normal) > one_sided_epsilon<T>)
              ++valid_camera;
          }
        for (std::uint32_t r = cl.begin; r < cl.middle; ++r) {
          const std::uint32_t sp = refs[r].segment;
          // Any segment starting here (camera- or light-born) but a Dirac light end.
          if (pool.flags[sp] & delta_light) continue;
          const Vec3<T>& w = pool.first_direction[sp];
          T sum = T(0);
          if (common) {
            // Lambertian technique points with one normal: p_w = cos / pi for every t (+ one-sided checks).
            const T cosine = glm::dot(w, *common);
            if (glm::dot(w, any_y.normal) > one_sided_epsilon<T> && cosine > T(0)) sum = T(valid_camera) * cosine * inv_pi<T>;
            pairs[c] += 1;
          } else {
            for (std::uint32_t q = cl.middle; q < cl.end; ++q) {
              const std::uint32_t t = refs[q].segment;
              if (!(pool.flags[t] & camera_technique)) continue;
              sum += bsdf.pdf(BsdfQuery<T>{pool.segments[t].y, -pool.last_direction[t], w, Transport::radiance});
              pairs[c] += 1;
            }
          }
          const T measure = (pool.flags[sp] & chain_segment)
                                ? T(1)
                                : solid_angle_to_area(T(1), pool.segments[sp].x, pool.segments[sp].y);
          camera_sum[sp] = cl.kernel * sum * measure;
        }
      }
      // Light technique samples: segments starting here that were continued backwards; they
      // could draw any plain segment ending here (y' in the voxel).
      std::uint32_t n = 0;
      for (std::uint32_t q = cl.begin; q < cl.middle; ++q) n += (pool.flags[refs[q].segment] & light_technique) ? 1 : 0;
      if (n > 0) {
        const auto x_of = [&](std::uint32_t s) -> const SurfacePoint<T>& { return pool.segments[s].x; };
        std::optional<Vec3<T>> common;
        if (options_.factorise) common = common_lambertian_normal(scene, x_of, refs, cl.begin, cl.middle);
        light_fact[c] = common ? 1 : 0;
        const SurfacePoint<T>& any_x = pool.segments[refs[cl.begin].segment].x;
        std::uint32_t valid_light = 0;
        if (common)
          for (std::uint32_t q = cl.begin; q < cl.middle; ++q) {
            const std::uint32_t t = refs[q].segment;
            if ((pool.flags[t] & light_technique) && glm::dot(pool.first_direction[t], any_x.normal) > one_sided_epsilon<T>)
              ++valid_light;
          }
        for (std::uint32_t r = cl.middle; r < cl.end; ++r) {
          const std::uint32_t sp = refs[r].segment;
          // Light predecessors end their ray at a surface hit: they never draw a segment whose
          // x is off the manifold (a sensor segment), a chain, or a Dirac light end.
          if ((pool.flags[sp] & (chain_segment | delta_light)) || pool.segments[sp].x.kind != PointKind::surface) continue;
          const Vec3<T> to_sensor = -pool.last_direction[sp];
          T sum = T(0);
          if (common) {
            const T cosine = glm::dot(to_sensor, *common);
            if (glm::dot(to_sensor, any_x.normal) > one_sided_epsilon<T> && cosine > T(0)) sum = T(valid_light) * cosine * inv_pi<T>;
            pairs[c] += 1;
          } else {
            for (std::uint32_t q = cl.begin; q < cl.middle; ++q) {
              const std::uint32_t t = refs[q].segment;
              if (!(pool.flags[t] & light_technique)) continue;
              sum += bsdf.pdf(BsdfQuery<T>{pool.segments[t].x, to_sensor, pool.first_direction[t], Transport::importance});
              pairs[c] += 1;
            }
          }
          light_sum[sp] = cl.kernel * sum * solid_angle_to_area(T(1), pool.segments[sp].y, pool.segments[sp].x);
        }
      }
    });
    for (std::size_t c = 0; c < clusters.size(); ++c) {
      stats.pair_evaluations += pairs[c];
      stats.factorised_camera_clusters += camera_fact[c];
      stats.factorised_light_clusters += light_fact[c];
    }
    // The unconditional techniques and the total.
    const std::uint64_t light_paths = light_path_count(scene);
    parallel_for(pool.size(), [&](std::size_t i) {
      const std::uint8_t f = pool.flags[i];
      const Segment<T>& s = pool.segments[i];
      T d = camera_sum[i] + light_sum[i];
      if (f & sensor_segment) {
        const SensorPdf<T> p = scene.sensor().pdf(SensorQuery<T>{s.x, pool.first_direction[i]});
        d += p.position * p.direction * ((f & chain_segment) ? T(1) : solid_angle_to_area(T(1), s.x, s.y));
      }
      if (light_paths > 0 && !(f & chain_segment)) {
        // N_L p_L(s) (N30) for any plain segment whose light end could be emitted.
        // For a distant light end pdf_emission reads a point on the ray (concepts/emitter.hpp).
        const Vec3<T> leaving = s.y.kind == PointKind::direction ? s.x.position : -pool.last_direction[i];
        const EmissionPdf<T> e = scene.emitter().pdf_emission(EmissionPdfQuery<T>{s.y, leaving});
        T p_light = e.position * e.direction;
        if (p_light > T(0) && s.x.kind == PointKind::surface) {
          p_light *= s.y.kind == PointKind::direction ? endpoint_cosine(s.x, pool.last_direction[i])
                                                      : solid_angle_to_area(T(1), s.y, s.x);
          if (f & delta_light) d = T(0);  // only light sampling produces a Dirac light end
          d += T(light_paths) * p_light;
        }
      }
      pool.density[i] = std::isfinite(d) ? d : T(0);
    });
  }

 private:
  /// Where every segment ending in a cluster has a Lambertian end with one normal, and every
  /// segment starting there leaves above it, f_r(s, s') = chain(s) albedo(y_s) / pi: the
  /// propagation sum is computed once per cluster.
  void transfer_factorisation(const Scn& scene, const Pool& pool, const Clustering<T>& clustering,
                              std::vector<std::uint8_t>& factorised, std::vector<S>& diffuse, FilteringStats& stats) const {
    using B = std::remove_cvref_t<decltype(scene.bsdf())>;
    factorised.assign(clustering.clusters().size(), 0);
    diffuse.assign(pool.size(), S(T(0)));
    if constexpr (HasLambertianAlbedo<B, S>) {
      const auto& bsdf = scene.bsdf();
      const auto refs = clustering.refs();
      for (std::size_t c = 0; c < factorised.size(); ++c) {
        const Cluster<T>& cl = clustering.clusters()[c];
        if (cl.middle == cl.end || cl.begin == cl.middle) continue;
        const SurfacePoint<T>& first = pool.segments[refs[cl.middle].segment].y;
        bool ok = true;
        for (std::uint32_t q = cl.middle; q < cl.end && ok; ++q) {
          const std::uint32_t s = refs[q].segment;
          const SurfacePoint<T>& y = pool.segments[s].y;
          const auto albedo = bsdf.lambertian_albedo(y);
          ok = albedo && y.normal == first.normal && glm::dot(-pool.last_direction[s], y.normal) > one_sided_epsilon<T>;
          if (ok) diffuse[s] = *albedo * inv_pi<T> * pool.chain[s];
        }
        for (std::uint32_t r = cl.begin; r < cl.middle && ok; ++r)
          ok = glm::dot(pool.first_direction[refs[r].segment], first.normal) > one_sided_epsilon<T>;
        factorised[c] = ok ? 1 : 0;
        stats.factorised_transfer_clusters += ok ? 1 : 0;
      }
    }
  }

  FilteringOptions<T> options_;
};

}  // namespace segpath
