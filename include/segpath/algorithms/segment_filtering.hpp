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
//  2. specular (delta) vertices are not junctions: a path folds them into its segment (a chain
//     x -> specular ... -> y, integrated in (area at x) x (solid angle at x)). Light paths from
//     area lights continue through delta reflections too (the caustic light -> mirror ->
//     diffuse): the light side's densities, in area x solid angle at y, reach the chain's
//     measure by the conservation of etendue, cos_y dA_y dw_y = cos_x dA_x dw_x. A delta
//     transmission, or a Dirac light, ends a light path, so such chains come from the camera
//     side only;
//  3. endpoints are clustered on a jittered voxel grid whose cell shrinks like a PPM radius;
//  4. every segment's MMIS denominator (N39)
//       D(s) = [sensor] n_p p_W(s) + [light end] N_L p_L(s)
//            + K_C(x) sum_{camera technique samples t ending in C(x)} p_w(s^ | y_t, s_t) |n_y . s^| / d^2
//            + K_C(y) sum_{light technique samples t starting in C(y)} p_w(-s^ | x_t, s_t) |n_x . s^| / d^2
//            [+ K_C(x) n_cam(C(x)) p_L(y | x) with next-event segments],
//     with the voxel kernel K_C = 1 / (area of the cluster's mean plane in the voxel). Dirac
//     light ends (point lights, the sun) only light sampling can produce: D = N_L p_L (plus
//     the next-event term);
//  5. propagation over clusters, max_length - 1 Jacobi iterations, from L_e; a segment never
//     joins itself, nor is it its own technique sample in step 4 (a chain that uses one sample
//     twice is not a path sample; propagation/propagate.hpp);
//  6. gather: pixel p += W G L(s_1) / D(s_1) over its sensor segments.
// BDPF weights a chain path-conditioned by default (FilteringWeighting): the paper's prod_i
// 1 / D(s_i) is biased where camera and light technique samples share clusters (D(s_i) counts
// a path neighbour as a technique sample only when it was born on the matching side); the
// path-conditioned weight is a forward-Markov MIS over the chain's side patterns (derivation in
// propagation/path_conditioned.hpp), with D split into its light side D_l (light start and
// light predecessors; compute_densities() with a LightSide, light_side() on disks) and the
// rest, and one pair density q_l(s | s')
// (light_pair_density()). Steps 5-6 then propagate four values per segment.
// Options beyond the paper's defaults: the disk support (every start within r of an end joins
// it, K = 1 / (pi r^2), pi r^2 = h^2) instead of voxel clusters, and for BDPF bridge segments
// from camera technique points to light-path starts (the bridge technique of SPEC 1.6), and for
// MVF and BDPF next-event segments from camera technique points to light points drawn by the
// emitter (SPEC 1.6's light-end bridge, N34); each technique's density joins every denominator.
// Known limits (measured, see tests/renderer/methods_test.cpp):
//  - max_length counts pooled segments and propagation iterations; a chain through specular
//    vertices is one segment, so paths with specular bounces may be longer than max_length
//    physical segments (PT counts every bounce). Negligible at length 10, visible at 3-4.
//  - MMIS with compactly supported conditionals is biased by the chance that no technique
//    sample covers a point (a cluster with no camera technique cannot continue a path): MVF has
//    no unconditional technique past the sensor segment, so it darkens as voxels empty.
//  - The disk support with approximate draws is biased O(r) where the density of technique
//    points varies (disks overlap, so the weights of a junction's candidates sum to one only in
//    expectation under a uniform density; voxel clusters partition, so they sum to one
//    exactly): +2.0 % / +0.8 % for MVF at r = 0.28 / 0.14 in the sphere furnace.
//  - Light-born chains leave area lights only: through a mirror, a point light's or the sun's
//    chain has no density in area x solid angle at x that a local computation gives (the
//    mirror's curvature enters), and no camera technique can draw it, so those caustics
//    (SmallVCM's boxes 0 and 2) are missing from MVF, PhF and BDPF.
//  - Delta-lobe selection probabilities are left out of every density of a chain: exact when
//    both sides select a reflection with the same probability (mirrors; Fresnel-selected
//    dielectric reflection, since the angle of incidence is the angle of reflection).
//  - The paper's weighting (FilteringWeighting::paper) is biased by its cross terms: on
//    SmallVCM's box 1 the glossy floor is +6.4 % +- 0.6 % brighter than PT at half the default
//    voxel (beta = 0.25), +3.7 % in the slab furnace with 16 x 16 voxels per period; the
//    path-conditioned weighting removes it (tests/algorithms/segment_filtering_test.cpp).
//  - Path-conditioned weighting: left is a technique sample that is the pool successor of a
//    chain segment without being in the chain (its presence depends on how the chain was
//    drawn), O(1 / technique samples per cluster); revisits of a sample other than s -> s;
//    bridge segments' density is taken as it is (its target count includes the path
//    neighbours); it costs ~1.6x the paper's iteration on box 1 (four values per segment, one
//    more BSDF pdf per junction, the light side of every denominator);
//    it reads light path depths from the pool order (build_pool keeps light paths contiguous;
//    a light-born chain counts as one segment there, while trace_light_path counts its delta
//    bounces against max_length, so D_lt is approximate for chains near max_length)
//    and takes every segment not camera-born nor a bridge as light-born (light_side_start).
// Beyond the paper: a cluster whose camera (light) technique points are all Lambertian with
// one shading normal has technique densities independent of the technique sample, so its sum
// is m p(s) (O(n) instead of O(n m)); with every ending point Lambertian with one normal, the
// transfer factorises too (propagation/propagate.hpp); black ends (an emitter that reflects
// nothing) factorise whatever their normal and directions.
#pragma once

#include "segpath/concepts/scene.hpp"
#include "segpath/integrand/contribution.hpp"
#include "segpath/core/framebuffer.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/kernels/progressive_radius.hpp"
#include "segpath/materials/scattering.hpp"
#include "segpath/propagation/clustering.hpp"
#include "segpath/propagation/disk_junctions.hpp"
#include "segpath/propagation/path_conditioned.hpp"
#include "segpath/propagation/propagate.hpp"
#include "segpath/samplers/light_start.hpp"
#include "segpath/samplers/sensor_start.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
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

/// The kernel support of the junctions (SPEC 1.2): the paper's voxel clusters, or disks.
enum class FilteringSupport : std::uint8_t {
  voxel,  ///< runs of equal position-and-normal voxel keys; K = 1 / (mean plane area in the voxel)
  disk,   ///< every start within r of an end (normals agreeing); K = 1 / (pi r^2), r = h / sqrt(pi)
};

[[nodiscard]] constexpr const char* to_string(FilteringSupport s) noexcept {
  return s == FilteringSupport::voxel ? "voxel" : "disk";
}

/// How a pooled chain is weighted (BDPF; MVF and PhF have one side past the sensor segment,
/// where both are the same weighting).
enum class FilteringWeighting : std::uint8_t {
  /// prod_i r_i, each segment's denominator conditioned on the sides its path neighbours were
  /// born on (propagation/path_conditioned.hpp): unbiased up to the kernel's own bias.
  path_conditioned,
  paper,  ///< prod_i 1 / D(s_i) (N39): biased where camera and light technique samples share clusters
};

[[nodiscard]] constexpr const char* to_string(FilteringWeighting w) noexcept {
  return w == FilteringWeighting::path_conditioned ? "path" : "paper";
}

template <Real T>
struct FilteringOptions {
  FilteringMode mode = FilteringMode::bdpf;
  std::size_t max_length = 10;  ///< segments per path (>= 2): propagation runs max_length - 1 iterations
  T light_path_ratio = T(0.25);  ///< beta: light paths per pixel per iteration (PhF, BDPF)
  T initial_cell_size = 0;       ///< voxel size of iteration 1; 0: 4x the average pixel footprint
  T alpha = T(0.67);             ///< progressive shrinking of the voxel (PPM schedule)
  bool factorise = true;         ///< use the O(n) sums in factorisable clusters (voxel support)
  /// The junctions' support. The disk has the voxel's area (pi r^2 = h^2) but is centred on
  /// each end, so supports overlap: no quantisation, no factorisation, memory per junction.
  FilteringSupport support = FilteringSupport::voxel;
  /// BDPF only: from every camera technique point y_t, one bridge segment to the start x_u of
  /// a light segment chosen uniformly among the pool's M light-born surface starts, kept when
  /// visible (SPEC 1.6 bridge, N34, with the approximate kernel draws of N33). Its technique
  /// density, for every plain segment s, is K(x_s) n_cam(x_s) K(y_s) n_light(y_s) / M.
  bool bridges = false;
  /// MVF and BDPF: from every camera technique point y_t, one next-event segment to a light
  /// point drawn by the emitter's sample_towards(y_t), kept when visible (the light-end bridge
  /// of SPEC 1.6, N34, approximate: it starts exactly at y_t). A camera-side technique like the
  /// BSDF successor: its density, for every plain segment s, is K(x_s) n_cam(C(x_s)) p_L(y_s | x_s).
  bool next_event = false;
  /// Voxel support: f_r(s, s') of the pairs of non-factorised clusters (with the
  /// path-conditioned weighting, each pair's whole junction: f_r, q_l and the weights r) is
  /// computed once per iteration instead of once per propagation sweep, for as many clusters (in
  /// order) as fit in this many bytes; the others are evaluated in every sweep. 0: no cache,
  /// memory O(#segments).
  std::size_t transfer_cache_bytes = std::size_t(1) << 30;
  /// Shift the voxel grid randomly each iteration (quantisation becomes noise). Off, the grid
  /// is aligned with the origin: on a periodic domain (canonical_position) whose period is a
  /// multiple of the voxel size, voxels then tile the fundamental cell exactly.
  bool jitter = true;
  /// BDPF: the chain weighting. path_conditioned propagates four values per segment and
  /// evaluates one light-technique density per junction (~2.4x the paper's propagation time
  /// on box 1, 1.5x its iteration).
  FilteringWeighting weighting = FilteringWeighting::path_conditioned;
  std::uint64_t seed = 1;
};

/// Counters of one iteration (pool size, clusters, how many were factorised).
struct FilteringStats {
  std::uint64_t segments = 0, camera_segments = 0, light_segments = 0, bridge_segments = 0, clusters = 0;
  std::uint64_t next_event_segments = 0;  ///< among the camera segments
  std::uint64_t junctions = 0;  ///< disk support: (end, start) pairs within r
  std::uint64_t factorised_camera_clusters = 0, factorised_light_clusters = 0, factorised_transfer_clusters = 0;
  std::uint64_t pair_evaluations = 0;  ///< technique-density and transfer evaluations
  double cell_size = 0;
  std::size_t bytes_per_segment = 0;    ///< O(#segments) memory, without the transfer cache
  std::size_t transfer_cache_bytes = 0;  ///< FilteringOptions::transfer_cache_bytes at most
  /// Wall time of the stages of render_iteration: paths (pool), support (clusters or disk
  /// junctions), densities (MMIS denominators, light side), propagation (with its pair
  /// evaluations), gather (pixels).
  double paths_seconds = 0, support_seconds = 0, densities_seconds = 0, propagation_seconds = 0, gather_seconds = 0;
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
    if (options.bridges && options.mode != FilteringMode::bdpf)
      throw std::invalid_argument(std::string("segpath::SegmentFiltering: bridge segments join camera and light paths, "
                                              "so they need mode bdpf, got ") + to_string(options.mode));
    if (options.next_event && options.mode == FilteringMode::phf)
      throw std::invalid_argument("segpath::SegmentFiltering: next-event segments start at camera technique points, "
                                  "which photon filtering does not have (mode phf)");
    if constexpr (HasCanonicalPosition<Scn>) {
      // A bridge joins two points at their real positions, but its density would have to count
      // every periodic image of the two supports: it is not defined on a periodic domain.
      if (options.bridges)
        throw std::invalid_argument("segpath::SegmentFiltering: bridge segments are not defined on a periodic domain "
                                    "(a scene with canonical_position)");
    }
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

  /// The disk radius with the area of a voxel face: pi r^2 = h^2.
  [[nodiscard]] static T disk_radius(T cell) noexcept { return cell / std::sqrt(pi<T>); }

  /// The voxel size of `iteration` (>= 1) given the first.
  [[nodiscard]] T cell_size(T initial, std::uint64_t iteration) const {
    return ProgressiveRadius<T>(initial, options_.alpha).radius(iteration);
  }

  /// Adds one iteration's estimate to `image` (one camera path per pixel). Deterministic for a
  /// given seed and iteration whatever `parallel_for` does.
  template <ParallelFor P = SerialFor>
  FilteringStats render_iteration(const Scn& scene, std::uint64_t iteration, T cell, Framebuffer<S>& image,
                                  DropCounters& drops, const P& parallel_for = {}) const {
    using Clock = std::chrono::steady_clock;
    auto lap = [last = Clock::now()](double& seconds) mutable {
      const auto now = Clock::now();
      seconds = std::chrono::duration<double>(now - last).count();
      last = now;
    };
    FilteringStats stats;
    Pool pool;
    build_pool(scene, iteration, pool, parallel_for);
    lap(stats.paths_seconds);
    stats.segments = pool.size();
    stats.next_event_segments = pool.next_event_segments;
    for (auto f : pool.flags)
      (f & camera_born ? stats.camera_segments : f & bridge_segment ? stats.bridge_segments : stats.light_segments) += 1;
    stats.cell_size = double(cell);

    // Junctions, MMIS denominators, propagation (Algorithm 1), then the per-pixel gather (N40).
    std::vector<S> radiance;
    std::vector<T> weighted_geometry;
    const int iterations = int(options_.max_length) - 1;
    std::size_t support_bytes = 0, propagation_bytes = 0;
    if (options_.support == FilteringSupport::voxel) {
      Clustering<T> clustering;
      cluster(scene, grid(cell, iteration), pool, clustering, parallel_for);
      stats.clusters = clustering.clusters().size();
      lap(stats.support_seconds);
      LightSide side;
      compute_densities(scene, pool, clustering, stats, parallel_for, path_conditioned() ? &side : nullptr);
      lap(stats.densities_seconds);
      support_bytes = clustering.bytes_per_segment();
      if (path_conditioned()) {
        propagate_conditioned_pool(scene, pool, clustering, side, iterations, radiance, weighted_geometry, stats, parallel_for);
        propagation_bytes = conditioned_bytes_per_segment;
      } else {
        propagate_pool(scene, pool, clustering, iterations, radiance, weighted_geometry, stats, parallel_for);
        // Propagation: diffuse when factorising, the transfer and the workspace.
        propagation_bytes = (options_.factorise ? sizeof(S) : 0) + Transfer::bytes_per_segment() +
                            PairCache::bytes_per_segment + PropagationWorkspace<S>::bytes_per_segment;
      }
    } else {
      DiskJunctions<T> junctions;
      join(scene, disk_radius(cell), pool, junctions, parallel_for);
      stats.junctions = junctions.junction_count();
      lap(stats.support_seconds);
      compute_densities(scene, pool, junctions, stats, parallel_for);
      LightSide side;
      if (path_conditioned()) light_side(scene, pool, junctions, side, parallel_for);
      lap(stats.densities_seconds);
      support_bytes = junctions.bytes_per_segment();
      if (path_conditioned()) {
        propagate_conditioned_pool(scene, pool, junctions, side, iterations, radiance, weighted_geometry, stats, parallel_for);
        propagation_bytes = conditioned_bytes_per_segment;
      } else {
        propagate_pool(scene, pool, junctions, iterations, radiance, weighted_geometry, parallel_for);
        propagation_bytes = sizeof(S);  // the second radiance buffer
      }
    }
    lap(stats.propagation_seconds);
    for (std::size_t i = 0; i < pool.size(); ++i) {
      if (!(pool.flags[i] & sensor_segment)) continue;
      const S value = radiance[i] * (pool.sensor_weight[i] * weighted_geometry[i]);
      if (is_finite(value)) image.add(pool.pixel[i], value);
      else drops.add(DropReason::non_finite);
    }
    stats.bytes_per_segment = pool.bytes_per_segment() + support_bytes + sizeof(T) + sizeof(S) + propagation_bytes;
    lap(stats.gather_seconds);
    return stats;
  }

  // ---- The stages of one iteration, public for tests and instrumentation ------------------

  static constexpr std::uint16_t sensor_segment = 1;     ///< s_1 of a camera path
  static constexpr std::uint16_t camera_born = 2;        ///< drawn by the camera side
  static constexpr std::uint16_t chain_segment = 4;      ///< contains delta vertices: (area x, solid angle x) measure
  static constexpr std::uint16_t camera_technique = 8;   ///< a camera successor draw was attempted from it
  static constexpr std::uint16_t light_technique = 16;   ///< a light predecessor draw was attempted from it
  static constexpr std::uint16_t light_start = 32;       ///< drawn by the light-start sampler
  static constexpr std::uint16_t delta_light = 64;       ///< its light end is a Dirac (point light, sun)
  static constexpr std::uint16_t bridge_segment = 128;   ///< drawn by the bridge technique
  static constexpr std::uint16_t transmission_chain = 256;  ///< a chain through a delta transmission (camera side only)

  /// One iteration's segments, structure of arrays (memory O(#segments)).
  struct Pool {
    std::vector<Segment<T>> segments;
    std::vector<Vec3<T>> first_direction, last_direction;  ///< unit, at x and at y (equal unless a chain)
    std::vector<S> chain, emitted;                         ///< delta-vertex throughput; chain * L_e(y)
    std::vector<T> geometry, density, sensor_weight;       ///< G, D and W for sensor segments
    std::vector<std::uint32_t> pixel;
    /// The segment whose technique sample drew this one: a camera successor's or next-event
    /// segment's predecessor on its camera path, a light predecessor's successor on its light
    /// path; no_parent for the unconditional draws (sensor, light start) and bridges.
    std::vector<std::uint32_t> parent;
    std::vector<std::uint16_t> flags;
    std::uint64_t bridge_targets = 0;       ///< M: light-born segments with a surface x (bridges on)
    std::uint64_t next_event_segments = 0;  ///< camera-born segments drawn by light sampling
    [[nodiscard]] std::size_t size() const noexcept { return segments.size(); }
    [[nodiscard]] std::size_t bytes_per_segment() const noexcept {
      return sizeof(Segment<T>) + 2 * sizeof(Vec3<T>) + 2 * sizeof(S) + 3 * sizeof(T) + 2 * sizeof(std::uint32_t) +
             sizeof(std::uint16_t);
    }
  };
  static constexpr std::uint32_t no_parent = 0xffffffffu;

  /// A segment as a path generator produces it, before pooling.
  struct Record {
    Segment<T> segment;
    Vec3<T> first_direction, last_direction;
    S chain;
    T geometry = 0, sensor_weight = 0;
    std::uint32_t pixel = 0;
    std::uint32_t parent = no_parent;  ///< index in the same generator's record list
    std::uint16_t flags = 0;
    bool next_event = false;
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
    camera.insert(camera.end(), std::make_move_iterator(light.begin()), std::make_move_iterator(light.end()));
    append(pool, camera, parallel_for);
    if (options_.bridges) add_bridges(scene, iteration, pool, parallel_for);
    const auto& emitter = scene.emitter();
    pool.emitted.resize(pool.size());
    detail::for_blocks(pool.size(), parallel_for, [&](std::size_t i) {
      pool.emitted[i] = emitter.radiance(EmissionQuery<T>{pool.segments[i].y, -pool.last_direction[i]}) * pool.chain[i];
    });
    pool.density.assign(pool.size(), T(0));
  }

  /// The targets of bridge segments: light-born segments whose x is a surface point.
  [[nodiscard]] static bool is_bridge_target(const Pool& pool, std::size_t i) noexcept {
    return !(pool.flags[i] & (camera_born | bridge_segment)) && pool.segments[i].x.kind == PointKind::surface;
  }

 private:
  /// Appends the generators' records, chunk after chunk (in parallel over chunks); a record's
  /// parent indexes its own chunk, the pool's the pool.
  template <class P>
  static void append(Pool& pool, const std::vector<std::vector<Record>>& chunks, const P& parallel_for) {
    std::vector<std::size_t> base(chunks.size() + 1, pool.size());
    for (std::size_t c = 0; c < chunks.size(); ++c) base[c + 1] = base[c] + chunks[c].size();
    const std::size_t total = base.back();
    pool.segments.resize(total), pool.first_direction.resize(total), pool.last_direction.resize(total);
    pool.chain.resize(total), pool.geometry.resize(total), pool.sensor_weight.resize(total), pool.pixel.resize(total);
    pool.parent.resize(total), pool.flags.resize(total);
    std::vector<std::uint64_t> next_event(chunks.size(), 0);
    parallel_for(chunks.size(), [&](std::size_t c) {
      std::size_t i = base[c];
      for (const Record& r : chunks[c]) {
        pool.segments[i] = r.segment;
        pool.first_direction[i] = r.first_direction;
        pool.last_direction[i] = r.last_direction;
        pool.chain[i] = r.chain;
        pool.geometry[i] = r.geometry;
        pool.sensor_weight[i] = r.sensor_weight;
        pool.pixel[i] = r.pixel;
        pool.parent[i] = r.parent == no_parent ? no_parent : std::uint32_t(base[c] + r.parent);
        pool.flags[i] = r.flags;
        next_event[c] += r.next_event ? 1 : 0;
        ++i;
      }
    });
    for (const auto n : next_event) pool.next_event_segments += n;
  }

  /// Bridge segments (BDPF option): every camera technique point y_t draws one light-born
  /// start x_u uniformly among the M targets and, when the two see each other, adds the
  /// segment y_t -> x_u. Failed draws (invisible, degenerate) still count as technique samples
  /// in the density (compute_densities), as for the other samplers.
  template <class P>
  void add_bridges(const Scn& scene, std::uint64_t iteration, Pool& pool, const P& parallel_for) const {
    std::vector<std::uint32_t> targets, sources;
    for (std::uint32_t i = 0; i < pool.size(); ++i) {
      if (is_bridge_target(pool, i)) targets.push_back(i);
      if (pool.flags[i] & camera_technique) sources.push_back(i);
    }
    pool.bridge_targets = targets.size();
    if (targets.empty()) return;
    std::vector<std::vector<Record>> bridges(chunk_count);
    parallel_for(chunk_count, [&](std::size_t c) {
      const std::size_t j0 = sources.size() * c / chunk_count, j1 = sources.size() * (c + 1) / chunk_count;
      for (std::size_t j = j0; j < j1; ++j) {
        const std::uint32_t t = sources[j];
        Pcg32 rng = Pcg32::for_sample(options_.seed ^ 0x627269646765ULL /* "bridge" */, t, iteration);
        const auto pick = std::min<std::size_t>(targets.size() - 1, std::size_t(rng.template uniform<double>() * double(targets.size())));
        Record r;
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
          if (is_transmission(y, -direction, next->direction)) r.flags |= transmission_chain;
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
      const auto index = std::uint32_t(out.size());
      out.push_back(r);
      if (attempted && options_.next_event) add_next_event(scene, index, rng, out);
      if (!continues) return;
      // The approximate successor (N33): starts exactly at y, direction from the BSDF at y.
      const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{y.position, next->direction}});
      Record successor;
      successor.segment.x = y;
      successor.first_direction = next->direction;
      successor.flags = camera_born;
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

  /// The next-event segment of the camera technique point y of `out[source]`: a light point
  /// from sample_towards(y), kept when visible. A failed draw is still a technique sample (the
  /// density counts every camera technique point).
  template <class R>
  void add_next_event(const Scn& scene, std::uint32_t source, R& rng, std::vector<Record>& out) const {
    const Vec2<T> u = uniform2<T>(rng);
    const T u_select = rng.template uniform<T>();
    const SurfacePoint<T> x = out[source].segment.y;
    const auto e = scene.emitter().sample_towards(EmitterTowardsQuery<T>{x, u, u_select});
    if (!e || !(e->pdf > T(0)) || !std::isfinite(e->pdf)) return;
    Record r;
    r.segment = Segment<T>{x, e->point};
    if (r.segment.y.kind != PointKind::direction && !(r.segment.length_squared() > T(0))) return;
    r.geometry = geometry_term(r.segment);
    if (!(r.geometry > T(0)) || !std::isfinite(r.geometry)) return;
    if (!scene.visible(VisibilityQuery<T>{r.segment.x, r.segment.y})) return;
    r.first_direction = r.last_direction = r.segment.direction();
    r.chain = S(T(1));
    r.flags = camera_born | (e->delta ? delta_light : 0);
    r.parent = source;
    r.next_event = true;
    out.push_back(r);
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
    // Through delta reflections the segment continues into a light-born chain, measured like
    // the camera's (area x solid angle at x); its density needs the light end's area measure
    // (light_measure), so only area lights continue, and a delta transmission (whose radiance
    // and importance throughputs differ) ends the path.
    const bool chains = !first->delta && r.segment.y.kind == PointKind::surface;
    for (std::size_t pieces = 1;; ++pieces) {
      const SurfacePoint<T>& x = r.segment.x;
      std::optional<BsdfSample<S>> prev;
      const bool attempted = x.kind == PointKind::surface && pieces + 1 < options_.max_length;
      if (attempted)
        prev = bsdf.sample(BsdfSampleQuery<T>{x, r.first_direction, uniform2<T>(rng), rng.template uniform<T>(), Transport::importance});
      if (chains && prev && prev->delta && prev->pdf > T(0) && !is_transmission(x, r.first_direction, prev->direction)) {
        const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{x.position, prev->direction}});
        if (!hit) return;  // the chain leaves the scene: no sensor segment can join it
        r.chain = r.chain * (prev->value * (std::abs(glm::dot(prev->direction, x.normal)) / prev->pdf));
        r.segment.x = hit->point;
        r.first_direction = -prev->direction;
        r.flags |= chain_segment;
        r.geometry = endpoint_cosine(r.segment.x, r.first_direction);
        continue;
      }
      // A technique sample whether or not its draw succeeded (see trace_camera_path); a
      // delta surface that does not continue the chain ends the light path.
      if (attempted && !(prev && prev->delta)) r.flags |= light_technique;
      const bool continues = prev && !prev->delta && prev->pdf > T(0);
      const auto index = std::uint32_t(out.size());
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
      predecessor.parent = index;
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
  /// f_r(s, s') chain(s) (N20) as propagation evaluates it, from copies in slot order
  /// (propagation/clustering.hpp), gathered once per pool: per ending slot what the BSDF needs
  /// of the ending segment, per starting slot the starting direction; only for the clusters
  /// that are not factorised (propagation never evaluates the link in the others), which then
  /// map slots to records. Memory: at most sizeof(Ending) + sizeof(Vec3) + 8 bytes per segment.
  struct Transfer {
    struct Ending {
      SurfacePoint<T> y;
      Vec3<T> outgoing;  ///< -last_direction: from y back along the segment
      S chain;
    };
    std::vector<Ending> ending;
    std::vector<Vec3<T>> starting_direction;
    std::vector<std::uint32_t> ending_record, starting_record;  ///< slot -> record; empty: the identity

    template <class P = SerialFor>
    void build(const Pool& pool, const Clustering<T>& clustering, std::span<const std::uint8_t> factorised = {},
               const P& parallel_for = {}) {
      const auto clusters = clustering.clusters();
      const bool compact = !factorised.empty();
      // Records: the slots of the clusters kept, in slot order.
      std::vector<std::uint32_t> first_ending, first_starting;
      std::size_t endings = clustering.ending_slot_count(), startings = clustering.starting_slot_count();
      if (compact) {
        first_ending.resize(clusters.size());
        first_starting.resize(clusters.size());
        endings = startings = 0;
        for (std::size_t c = 0; c < clusters.size(); ++c) {
          first_ending[c] = std::uint32_t(endings);
          first_starting[c] = std::uint32_t(startings);
          if (factorised[c]) continue;
          endings += clusters[c].ending_count();
          startings += clusters[c].starting_count();
        }
      }
      ending.resize(endings);
      starting_direction.resize(startings);
      ending_record.assign(compact ? clustering.ending_slot_count() : 0, 0);
      starting_record.assign(compact ? clustering.starting_slot_count() : 0, 0);
      const auto ending_segment = clustering.ending_segments();
      const auto starting_segment = clustering.starting_segments();
      parallel_for(clusters.size(), [&](std::size_t c) {
        if (compact && factorised[c]) return;
        const Cluster<T>& cl = clusters[c];
        for (std::uint32_t q = 0; q < cl.starting_count(); ++q) {
          const std::uint32_t j = cl.slot + q, record = compact ? first_starting[c] + q : j;
          if (compact) starting_record[j] = record;
          starting_direction[record] = pool.first_direction[starting_segment[j]];
        }
        const std::uint32_t first = cl.ending_slot(cl.middle);
        for (std::uint32_t q = 0; q < cl.ending_count(); ++q) {
          const std::uint32_t i = first + q, record = compact ? first_ending[c] + q : i;
          if (compact) ending_record[i] = record;
          const std::uint32_t s = ending_segment[i];
          ending[record] = Ending{pool.segments[s].y, -pool.last_direction[s], pool.chain[s]};
        }
      });
    }
    /// At most.
    [[nodiscard]] static constexpr std::size_t bytes_per_segment() noexcept {
      return sizeof(Ending) + sizeof(Vec3<T>) + 2 * sizeof(std::uint32_t);
    }
    [[nodiscard]] std::size_t bytes() const noexcept {
      return ending.capacity() * sizeof(Ending) + starting_direction.capacity() * sizeof(Vec3<T>) +
             (ending_record.capacity() + starting_record.capacity()) * sizeof(std::uint32_t);
    }
  };

  /// f_r(s, s') chain(s) of the paper weighting's propagation per (ending slot i, starting slot
  /// j) pair of the clusters that are not factorised, evaluated once per pool instead of once
  /// per sweep, cluster by cluster in order while they fit in a byte budget (a cluster that does
  /// not fit is skipped, later smaller ones may still fit). The path-conditioned weighting keeps
  /// whole junctions instead (propagate_conditioned's junction table).
  struct PairCache {
    using V = S;
    static constexpr std::int64_t no_row = -(std::int64_t(1) << 62);
    std::vector<V> value;
    std::vector<std::int64_t> row;  ///< per ending slot i: value[row[i] + j] for starting slot j, or no_row

    /// `pair(i, j)` the value of ending slot i and starting slot j.
    template <class Pair, class P = SerialFor>
    void build(const Pair& pair, const Clustering<T>& clustering, std::span<const std::uint8_t> factorised,
               std::size_t budget_bytes, const P& parallel_for = {}) {
      const auto clusters = clustering.clusters();
      row.assign(clustering.ending_slot_count(), no_row);
      constexpr std::size_t none = ~std::size_t(0);
      std::vector<std::size_t> offset(clusters.size(), none);
      const std::size_t budget = budget_bytes / sizeof(V);
      std::size_t total = 0;
      for (std::size_t c = 0; c < clusters.size(); ++c) {
        if (!factorised.empty() && factorised[c]) continue;
        const std::size_t pairs = std::size_t(clusters[c].ending_count()) * clusters[c].starting_count();
        if (pairs == 0 || total + pairs > budget) continue;
        offset[c] = total;
        total += pairs;
      }
      value.resize(total);
      parallel_for(clusters.size(), [&](std::size_t c) {
        if (offset[c] == none) return;
        const Cluster<T>& cl = clusters[c];
        const std::uint32_t first = cl.ending_slot(cl.middle), m = cl.starting_count();
        for (std::uint32_t e = 0; e < cl.ending_count(); ++e) {
          const std::size_t base = offset[c] + std::size_t(e) * m;
          row[first + e] = std::int64_t(base) - std::int64_t(cl.slot);
          for (std::uint32_t q = 0; q < m; ++q) value[base + q] = pair(first + e, cl.slot + q);
        }
      });
    }
    /// The value of pair (i, j), or nullptr where it is not cached.
    [[nodiscard]] const V* find(std::uint32_t i, std::uint32_t j) const noexcept {
      const std::int64_t r = row[i];
      return r != no_row ? &value[std::size_t(r + j)] : nullptr;
    }
    /// Besides the pairs.
    static constexpr std::size_t bytes_per_segment = sizeof(std::int64_t);
  };

  /// The link(s, s', i, j) of propagation over a Transfer.
  struct TransferLink {
    decltype(std::declval<const Scn&>().bsdf()) bsdf;
    const Transfer& transfer;
    S operator()(std::uint32_t, std::uint32_t, std::uint32_t i, std::uint32_t j) const noexcept {
      const auto& e = transfer.ending[transfer.ending_record.empty() ? i : transfer.ending_record[i]];
      const auto& w = transfer.starting_direction[transfer.starting_record.empty() ? j : transfer.starting_record[j]];
      return bsdf.eval(BsdfQuery<T>{e.y, e.outgoing, w, Transport::radiance}) * e.chain;
    }
  };

  /// A TransferLink that reads the pairs a PairCache holds.
  struct CachedTransferLink {
    TransferLink link;
    const PairCache& cache;
    S operator()(std::uint32_t s, std::uint32_t sp, std::uint32_t i, std::uint32_t j) const noexcept {
      const S* cached = cache.find(i, j);
      return cached ? *cached : link(s, sp, i, j);
    }
  };

  /// Step 5: `iterations` Jacobi iterations of propagation over the clustered pool, using the
  /// factorised O(n + m) sums where the options allow and the cluster qualifies. Returns L
  /// and G w per segment.
  template <class P = SerialFor>
  void propagate_pool(const Scn& scene, const Pool& pool, const Clustering<T>& clustering, int iterations,
                      std::vector<S>& radiance, std::vector<T>& weighted_geometry, FilteringStats& stats,
                      const P& parallel_for = {}) const {
    weighted_geometry_of(pool, weighted_geometry);
    std::vector<std::uint8_t> factorised;
    std::vector<S> diffuse;
    if (options_.factorise) transfer_factorisation(scene, pool, clustering, factorised, diffuse, stats, parallel_for);
    Transfer transfer;
    transfer.build(pool, clustering, factorised, parallel_for);
    const TransferLink link{scene.bsdf(), transfer};
    PairCache cache;
    cache.build([&](std::uint32_t i, std::uint32_t j) { return link(0, 0, i, j); }, clustering, factorised,
                options_.transfer_cache_bytes, parallel_for);
    stats.transfer_cache_bytes = cache.value.size() * sizeof(S);
    const CachedTransferLink cached{link, cache};
    const PropagationInputs<S, CachedTransferLink> inputs{clustering, pool.emitted, weighted_geometry, cached, diffuse, factorised};
    PropagationWorkspace<S> workspace;
    propagate(inputs, iterations, radiance, workspace, parallel_for);
  }

  /// Clusters a pool's endpoints on `grid` (by canonical position where the scene has one).
  template <ParallelFor P = SerialFor>
  void cluster(const Scn& scene, const VoxelGrid<T>& grid, const Pool& pool, Clustering<T>& clustering,
               const P& parallel_for = {}) const {
    clustering.build(grid, pool.segments, canonical_map(scene), parallel_for);
  }

  /// The disk support's junctions of a pool (by canonical position where the scene has one).
  template <class P = SerialFor>
  void join(const Scn& scene, T radius, const Pool& pool, DiskJunctions<T>& junctions, const P& parallel_for = {}) const {
    junctions.build(radius, std::span<const Segment<T>>(pool.segments), canonical_map(scene), T(0.5), parallel_for);
  }

  /// Where an end is keyed or measured: the scene's canonical position, or the position itself.
  [[nodiscard]] static auto canonical_map(const Scn& scene) noexcept {
    return [&scene](const SurfacePoint<T>& p) -> Vec3<T> {
      if constexpr (HasCanonicalPosition<Scn>) {
        return scene.canonical_position(p);
      } else {
        (void)scene;
        return p.position;
      }
    };
  }

  /// G(s) w(s) = G(s) / D(s) per segment (0 where no technique could draw it).
  static void weighted_geometry_of(const Pool& pool, std::vector<T>& weighted_geometry) {
    weighted_geometry.resize(pool.size());
    for (std::size_t i = 0; i < pool.size(); ++i)
      weighted_geometry[i] = pool.density[i] > T(0) ? pool.geometry[i] / pool.density[i] : T(0);
  }

  /// Step 5 over the disk support (no factorisation: every end has its own disk).
  template <class P = SerialFor>
  void propagate_pool(const Scn& scene, const Pool& pool, const DiskJunctions<T>& junctions, int iterations,
                      std::vector<S>& radiance, std::vector<T>& weighted_geometry, const P& parallel_for = {}) const {
    weighted_geometry_of(pool, weighted_geometry);
    const auto& bsdf = scene.bsdf();
    auto link = [&](std::uint32_t s, std::uint32_t sp) -> S {
      const S f = bsdf.eval(BsdfQuery<T>{pool.segments[s].y, -pool.last_direction[s], pool.first_direction[sp], Transport::radiance});
      return f * pool.chain[s];
    };
    const DiskPropagationInputs<S, decltype(link)> inputs{junctions, pool.emitted, weighted_geometry, link};
    std::vector<S> scratch;
    propagate(inputs, iterations, radiance, scratch, parallel_for);
  }

  // ---- Path-conditioned weighting (BDPF, propagation/path_conditioned.hpp) ---------------

  /// Whether this method weights chains path-conditioned (only BDPF has both sides).
  [[nodiscard]] bool path_conditioned() const noexcept {
    return options_.mode == FilteringMode::bdpf && options_.weighting == FilteringWeighting::path_conditioned;
  }

  /// What the path-conditioned weighting needs besides D(s): the light side D_l(s) of the
  /// denominator (light start and light technique samples), its number of positive terms, and
  /// the side flags (conditioned_*).
  struct LightSide {
    std::vector<T> density, technique_density;  ///< D_l, D_lt (propagation/path_conditioned.hpp)
    std::vector<std::uint32_t> terms, depth;    ///< positive terms of D_l; light path depth (light start 1)
    std::vector<std::uint8_t> flags;
  };
  static constexpr std::size_t conditioned_bytes_per_segment =
      4 * sizeof(ConditionedValues<S>) + 8 * sizeof(T) + 4 * sizeof(std::uint32_t) + 3 +
      3 * sizeof(detail::ConditionedJunction<S>);  // + the junction table (transfer_cache_bytes)

  /// q_l(s | s'), the one pair density of the weighting: the density with which a light
  /// technique sample at x_{s'} (the approximate light predecessor, N33) draws s, kernel
  /// included; in the measure of s (area at y, N31 mirrored). 0 where no light predecessor can
  /// be s. D_l(s) sums it over the light technique samples among the s' starting near y_s.
  /// `scale` is light_pair_scale(pool, kernel, s), the part that depends on s alone.
  template <class B>
  [[nodiscard]] static T light_pair_density(const B& bsdf, const Pool& pool, T scale, std::uint32_t s,
                                            std::uint32_t sp) noexcept {
    if (!(scale > T(0)) || pool.segments[sp].x.kind != PointKind::surface || (pool.flags[sp] & transmission_chain)) return T(0);
    const T q = scale * light_technique_pdf(bsdf, pool, sp, s);
    return std::isfinite(q) && q > T(0) ? q : T(0);
  }
  [[nodiscard]] static T light_pair_scale(const Pool& pool, T kernel, std::uint32_t s) noexcept {
    return light_reachable(pool, s) ? kernel * light_measure(pool, s) : T(0);
  }

  /// The light side of every denominator, disk support.
  template <class P = SerialFor>
  void light_side(const Scn& scene, const Pool& pool, const DiskJunctions<T>& junctions, LightSide& side,
                  const P& parallel_for = {}) const {
    light_side_start(scene, pool, side, parallel_for);
    const auto& bsdf = scene.bsdf();
    parallel_for(pool.size(), [&](std::size_t i) {
      const auto s = std::uint32_t(i);
      const T scale = light_pair_scale(pool, junctions.kernel(), s);
      if (!(scale > T(0))) return;
      for (const std::uint32_t u : junctions.starting_near(s)) {
        if (!(pool.flags[u] & light_technique)) continue;
        add_light_term(side, s, u, light_pair_density(bsdf, pool, scale, s, u));
      }
    });
  }

  /// Step 5 with the path-conditioned weighting; returns the weighted L per segment and G
  /// (the weights are inside: a sensor segment's pixel value is W G L).
  template <class Support, class P = SerialFor>
  void propagate_conditioned_pool(const Scn& scene, const Pool& pool, const Support& support, const LightSide& side,
                                  int iterations, std::vector<S>& radiance, std::vector<T>& geometry, FilteringStats& stats,
                                  const P& parallel_for = {}) const {
    const auto& bsdf = scene.bsdf();
    // The s-only part of q_l(s | s'), per segment (as light_side computes it).
    std::vector<T> scale(pool.size(), T(0));
    parallel_for(pool.size(), [&](std::size_t i) {
      const auto s = std::uint32_t(i);
      if constexpr (std::is_same_v<Support, DiskJunctions<T>>) {
        scale[s] = light_pair_scale(pool, support.kernel(), s);
      } else {
        const std::uint32_t c = support.cluster_of_y(s);
        if (c != no_cluster) scale[s] = light_pair_scale(pool, support.clusters()[c].kernel, s);
      }
    });
    auto light_pair = [&](std::uint32_t s, std::uint32_t sp) -> T { return light_pair_density(bsdf, pool, scale[s], s, sp); };
    if constexpr (std::is_same_v<Support, DiskJunctions<T>>) {
      auto link = [&](std::uint32_t s, std::uint32_t sp) -> S {
        return bsdf.eval(BsdfQuery<T>{pool.segments[s].y, -pool.last_direction[s], pool.first_direction[sp], Transport::radiance}) *
               pool.chain[s];
      };
      const ConditionedInputs<S, decltype(link), decltype(light_pair)> inputs{
          pool.emitted, pool.geometry, pool.density, side.density, side.terms, side.technique_density, side.flags, link, light_pair};
      propagate_conditioned(support, inputs, iterations, radiance, parallel_for);
      (void)stats;
    } else {
      std::vector<std::uint8_t> factorised;
      std::vector<S> diffuse;
      if (options_.factorise) conditioned_factorisation(scene, pool, support, factorised, diffuse, stats, parallel_for);
      // The general clusters read slot-ordered copies (Transfer, and the starts and s-only
      // factors of q_l): f_r and q_l by slot, as propagate_pool does.
      Transfer transfer;
      transfer.build(pool, support, factorised, parallel_for);
      std::vector<SurfacePoint<T>> starting_x(transfer.starting_direction.size());
      std::vector<T> ending_scale(transfer.ending.size(), T(0));
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
      // q_l(s | s') of a general cluster's pair, by slot (propagate_conditioned calls it for
      // potential light techniques s' only, which excludes chains through a delta transmission):
      // light_pair_density from the copies, the same product, the same number.
      struct SlotLightPair {
        decltype(light_pair) by_id;
        decltype(std::declval<const Scn&>().bsdf()) bsdf;
        const Transfer& transfer;
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
      const ConditionedInputs<S, TransferLink, SlotLightPair> slot_inputs{
          pool.emitted, pool.geometry, pool.density, side.density, side.terms, side.technique_density, side.flags,
          TransferLink{scene.bsdf(), transfer}, SlotLightPair{light_pair, scene.bsdf(), transfer, starting_x, ending_scale}};
      // The junctions of the pairs that fit the cache budget are built once per pool.
      stats.transfer_cache_bytes =
          propagate_conditioned(support, slot_inputs, iterations, radiance, parallel_for, std::span<const std::uint8_t>(factorised),
                                std::span<const S>(diffuse), options_.transfer_cache_bytes);
    }
    geometry.assign(pool.geometry.begin(), pool.geometry.end());
  }

  /// The clusters whose path-conditioned junction sums factorise: the transfer factorises
  /// (transfer_factorisation) and every start is Lambertian with one normal and leaves its
  /// front side, so q_l(s | s') is the same for every potential light technique s'.
  template <class P = SerialFor>
  void conditioned_factorisation(const Scn& scene, const Pool& pool, const Clustering<T>& clustering,
                                 std::vector<std::uint8_t>& factorised, std::vector<S>& diffuse, FilteringStats& stats,
                                 const P& parallel_for = {}) const {
    transfer_factorisation(scene, pool, clustering, factorised, diffuse, stats, parallel_for);
    const auto refs = clustering.refs();
    const auto x_of = [&](std::uint32_t s) -> const SurfacePoint<T>& { return pool.segments[s].x; };
    std::vector<std::uint8_t> dropped(factorised.size(), 0);
    parallel_for(factorised.size(), [&](std::size_t c) {
      if (!factorised[c]) return;
      const Cluster<T>& cl = clustering.clusters()[c];
      bool ok = common_lambertian_normal(scene, x_of, refs, cl.begin, cl.middle).has_value();
      for (std::uint32_t r = cl.begin; r < cl.middle && ok; ++r) {
        const std::uint32_t sp = refs[r].segment;
        ok = glm::dot(pool.first_direction[sp], pool.segments[sp].x.normal) > one_sided_epsilon<T>;
      }
      if (!ok) factorised[c] = 0, dropped[c] = 1;
    });
    for (const auto d : dropped) stats.factorised_transfer_clusters -= d;
  }

  /// Step 4: the MMIS denominators D(s) of every pooled segment (N39), voxel support; with
  /// `side`, also the light side of every denominator for the path-conditioned weighting.
  template <class P>
  void compute_densities(const Scn& scene, Pool& pool, const Clustering<T>& clustering, FilteringStats& stats,
                         const P& parallel_for, LightSide* side = nullptr) const {
    const auto clusters = clustering.clusters();
    const auto refs = clustering.refs();
    const auto& bsdf = scene.bsdf();
    if (side) light_side_start(scene, pool, *side, parallel_for);
    // A light technique sample u whose draw would itself try a predecessor (D_lt, add_light_term).
    const auto deep = [&](std::uint32_t u) { return side && std::size_t(side->depth[u]) + 2 < options_.max_length; };
    std::vector<T> camera_sum(pool.size(), T(0)), light_sum(pool.size(), T(0));
    std::vector<std::uint64_t> pairs(clusters.size(), 0);
    std::vector<std::uint8_t> camera_fact(clusters.size(), 0), light_fact(clusters.size(), 0);
    std::vector<std::uint32_t> camera_points(clusters.size(), 0), bridge_targets(clusters.size(), 0);
    parallel_for(clusters.size(), [&](std::size_t c) {
      const Cluster<T>& cl = clusters[c];
      // Camera technique samples: segments ending here that were continued; they could draw any
      // segment starting here (x' in the voxel). Density (N31) with the voxel kernel K_C.
      std::uint32_t m = 0;
      for (std::uint32_t q = cl.middle; q < cl.end; ++q) m += (pool.flags[refs[q].segment] & camera_technique) ? 1 : 0;
      camera_points[c] = m;
      if (options_.bridges)
        for (std::uint32_t q = cl.begin; q < cl.middle; ++q) bridge_targets[c] += is_bridge_target(pool, refs[q].segment) ? 1 : 0;
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
          if (!camera_reachable(pool, sp)) continue;
          const Vec3<T>& w = pool.first_direction[sp];
          T sum = T(0);
          if (common) {
            // Lambertian technique points with one normal: p_w = cos / pi for every t (+ one-sided
            // checks), s' itself not among them (a segment is not its own technique sample).
            const T cosine = glm::dot(w, *common);
            const bool self = clustering.cluster_of_y(sp) == c && (pool.flags[sp] & camera_technique) &&
                              glm::dot(-pool.last_direction[sp], any_y.normal) > one_sided_epsilon<T>;
            if (glm::dot(w, any_y.normal) > one_sided_epsilon<T> && cosine > T(0))
              sum = T(valid_camera - (self ? 1 : 0)) * cosine * inv_pi<T>;
            pairs[c] += 1;
          } else {
            for (std::uint32_t q = cl.middle; q < cl.end; ++q) {
              const std::uint32_t t = refs[q].segment;
              if (!(pool.flags[t] & camera_technique) || t == sp) continue;
              sum += camera_technique_pdf(bsdf, pool, t, sp);
              pairs[c] += 1;
            }
          }
          camera_sum[sp] = cl.kernel * sum * camera_measure(pool, sp);
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
        std::uint32_t valid_light = 0, valid_deep = 0;
        if (common)
          for (std::uint32_t q = cl.begin; q < cl.middle; ++q) {
            const std::uint32_t t = refs[q].segment;
            if ((pool.flags[t] & light_technique) && glm::dot(pool.first_direction[t], any_x.normal) > one_sided_epsilon<T>) {
              ++valid_light;
              valid_deep += deep(t) ? 1 : 0;
            }
          }
        for (std::uint32_t r = cl.middle; r < cl.end; ++r) {
          const std::uint32_t sp = refs[r].segment;
          if (!light_reachable(pool, sp)) continue;
          const Vec3<T> to_sensor = -pool.last_direction[sp];
          const T scale = cl.kernel * light_measure(pool, sp);
          T sum = T(0);
          if (common) {
            const T cosine = glm::dot(to_sensor, *common);
            // s' itself is not among the technique samples.
            const bool self = clustering.cluster_of_x(sp) == c && (pool.flags[sp] & light_technique) &&
                              glm::dot(pool.first_direction[sp], any_x.normal) > one_sided_epsilon<T>;
            const std::uint32_t light_count = valid_light - (self ? 1 : 0);
            const std::uint32_t deep_count = valid_deep - (self && deep(sp) ? 1 : 0);
            if (glm::dot(to_sensor, any_x.normal) > one_sided_epsilon<T> && cosine > T(0)) {
              sum = T(light_count) * cosine * inv_pi<T>;
              if (side && scale * cosine > T(0)) {
                side->terms[sp] += light_count;
                side->technique_density[sp] += scale * T(deep_count) * cosine * inv_pi<T>;
              }
            }
            pairs[c] += 1;
          } else {
            for (std::uint32_t q = cl.begin; q < cl.middle; ++q) {
              const std::uint32_t t = refs[q].segment;
              if (!(pool.flags[t] & light_technique) || t == sp) continue;
              const T pdf = light_technique_pdf(bsdf, pool, t, sp);
              sum += pdf;
              pairs[c] += 1;
              if (side && scale * pdf > T(0)) {
                side->terms[sp] += 1;
                if (deep(t)) side->technique_density[sp] += scale * pdf;
              }
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
    const bool bridges = options_.bridges && pool.bridge_targets > 0;
    std::vector<T> camera_points_at_x, bridge_sum;
    if (bridges || options_.next_event) {
      camera_points_at_x.assign(pool.size(), T(0));
      if (bridges) bridge_sum.assign(pool.size(), T(0));
      parallel_for(pool.size(), [&](std::size_t i) {
        const std::uint32_t cx = clustering.cluster_of_x(std::uint32_t(i)), cy = clustering.cluster_of_y(std::uint32_t(i));
        if (cx == no_cluster) return;
        // Not counting segment i itself, as a camera point at x or as a bridge target at y.
        const bool self_point = (pool.flags[i] & camera_technique) && cy == cx;
        camera_points_at_x[i] = clusters[cx].kernel * T(camera_points[cx] - (self_point ? 1 : 0));
        const bool self_target = is_bridge_target(pool, i) && cy == cx;
        if (bridges && cy != no_cluster && bridge_reachable(pool, i))
          bridge_sum[i] =
              camera_points_at_x[i] * clusters[cy].kernel * T(bridge_targets[cy] - (self_target ? 1 : 0)) / T(pool.bridge_targets);
      });
      if (!options_.next_event) camera_points_at_x.clear();
    }
    finish_densities(scene, pool, camera_sum, light_sum, bridge_sum, camera_points_at_x, parallel_for);
  }

  /// Step 4 over the disk support: the technique samples of a segment are its neighbour lists
  /// (every camera technique end whose disk holds x_s, every light technique start in the disk
  /// of y_s), K = 1 / (pi r^2).
  template <class P>
  void compute_densities(const Scn& scene, Pool& pool, const DiskJunctions<T>& junctions, FilteringStats& stats,
                         const P& parallel_for) const {
    const auto& bsdf = scene.bsdf();
    const T kernel = junctions.kernel();
    const bool bridges = options_.bridges && pool.bridge_targets > 0;
    std::vector<T> camera_sum(pool.size(), T(0)), light_sum(pool.size(), T(0)), bridge_sum(bridges ? pool.size() : 0, T(0));
    std::vector<T> camera_points_at_x(options_.next_event ? pool.size() : 0, T(0));
    constexpr std::size_t chunk = 1024;
    const std::size_t chunks = (pool.size() + chunk - 1) / chunk;
    std::vector<std::uint64_t> pairs(chunks, 0);
    parallel_for(chunks, [&](std::size_t c) {
      for (std::size_t i = c * chunk; i < std::min(pool.size(), (c + 1) * chunk); ++i) {
        const auto sp = std::uint32_t(i);
        std::uint32_t camera_points = 0, targets = 0;
        T sum = T(0);
        for (const std::uint32_t t : junctions.ending_near(sp)) {
          if (!(pool.flags[t] & camera_technique)) continue;
          ++camera_points;
          if (!camera_reachable(pool, sp)) continue;
          sum += camera_technique_pdf(bsdf, pool, t, sp);
          pairs[c] += 1;
        }
        if (sum > T(0)) camera_sum[sp] = kernel * sum * camera_measure(pool, sp);
        sum = T(0);
        for (const std::uint32_t u : junctions.starting_near(sp)) {
          targets += (bridges && is_bridge_target(pool, u)) ? 1 : 0;
          if (!(pool.flags[u] & light_technique) || !light_reachable(pool, sp)) continue;
          sum += light_technique_pdf(bsdf, pool, u, sp);
          pairs[c] += 1;
        }
        if (sum > T(0)) light_sum[sp] = kernel * sum * light_measure(pool, sp);
        if (bridges && bridge_reachable(pool, sp))
          bridge_sum[sp] = kernel * T(camera_points) * kernel * T(targets) / T(pool.bridge_targets);
        if (options_.next_event) camera_points_at_x[sp] = kernel * T(camera_points);
      }
    });
    for (const auto p : pairs) stats.pair_evaluations += p;
    finish_densities(scene, pool, camera_sum, light_sum, bridge_sum, camera_points_at_x, parallel_for);
  }

 private:
  /// Which segments each conditional technique can produce: a camera successor any segment
  /// but one with a Dirac light end (N31); a light predecessor ends its ray at a surface hit,
  /// so never a segment whose x is off the manifold (a sensor segment), a chain through a delta
  /// transmission, or a Dirac light end; a bridge any straight segment between two surface points.
  [[nodiscard]] static bool camera_reachable(const Pool& pool, std::size_t s) noexcept { return !(pool.flags[s] & delta_light); }
  [[nodiscard]] static bool light_reachable(const Pool& pool, std::size_t s) noexcept {
    return !(pool.flags[s] & (transmission_chain | delta_light)) && pool.segments[s].x.kind == PointKind::surface;
  }
  /// Whether a delta scattering at p from `fixed` to `sampled` crosses the surface.
  [[nodiscard]] static bool is_transmission(const SurfacePoint<T>& p, const Vec3<T>& fixed, const Vec3<T>& sampled) noexcept {
    return glm::dot(fixed, p.normal) * glm::dot(sampled, p.normal) < T(0);
  }
  [[nodiscard]] static bool bridge_reachable(const Pool& pool, std::size_t s) noexcept {
    return !(pool.flags[s] & (chain_segment | delta_light)) && pool.segments[s].x.kind == PointKind::surface &&
           pool.segments[s].y.kind == PointKind::surface;
  }
  /// p_w(s' | t) of the camera successor from t's end y_t (solid angle at y_t).
  template <class B>
  [[nodiscard]] static T camera_technique_pdf(const B& bsdf, const Pool& pool, std::uint32_t t, std::uint32_t sp) noexcept {
    return bsdf.pdf(BsdfQuery<T>{pool.segments[t].y, -pool.last_direction[t], pool.first_direction[sp], Transport::radiance});
  }
  /// p_w(-s' | u) of the light predecessor from u's start x_u (solid angle at x_u).
  template <class B>
  [[nodiscard]] static T light_technique_pdf(const B& bsdf, const Pool& pool, std::uint32_t u, std::uint32_t sp) noexcept {
    return bsdf.pdf(BsdfQuery<T>{pool.segments[u].x, -pool.last_direction[sp], pool.first_direction[u], Transport::importance});
  }
  /// Solid angle at the technique point to the segment's measure: area at y (plain segments);
  /// chains are measured in solid angle at x already.
  [[nodiscard]] static T camera_measure(const Pool& pool, std::size_t s) noexcept {
    return (pool.flags[s] & chain_segment) ? T(1) : solid_angle_to_area(T(1), pool.segments[s].x, pool.segments[s].y);
  }
  /// Area x solid angle at y (light techniques) to the segment's measure: area at x for a plain
  /// segment; for a chain, area x solid angle at x, through mirrors by the conservation of
  /// etendue, cos_y dA_y dw_y = cos_x dA_x dw_x: cos_x / cos_y. (With Fresnel-selected delta
  /// reflections both sides pick the same lobe with the same probability, so the selection
  /// factors, left out of every density of a chain, agree.)
  [[nodiscard]] static T light_measure(const Pool& pool, std::size_t s) noexcept {
    if (!(pool.flags[s] & chain_segment)) return solid_angle_to_area(T(1), pool.segments[s].y, pool.segments[s].x);
    const T cos_y = endpoint_cosine(pool.segments[s].y, pool.last_direction[s]);
    return cos_y > T(0) ? endpoint_cosine(pool.segments[s].x, pool.first_direction[s]) / cos_y : T(0);
  }

  /// The flags of the path-conditioned weighting and the light-start term of D_l (as
  /// finish_densities computes it).
  template <class P>
  void light_side_start(const Scn& scene, const Pool& pool, LightSide& side, const P& parallel_for) const {
    const std::uint64_t light_paths = light_path_count(scene);
    side.density.assign(pool.size(), T(0));
    side.technique_density.assign(pool.size(), T(0));
    side.terms.assign(pool.size(), 0);
    side.flags.assign(pool.size(), 0);
    // Light paths are pooled in path order (build_pool): a light predecessor follows the
    // segment that drew it.
    side.depth.assign(pool.size(), 0);
    for (std::size_t i = 0; i < pool.size(); ++i) {
      if (pool.flags[i] & light_start) side.depth[i] = 1;
      else if (i > 0 && !(pool.flags[i] & (camera_born | bridge_segment)) && side.depth[i - 1] > 0) side.depth[i] = side.depth[i - 1] + 1;
    }
    parallel_for(pool.size(), [&](std::size_t i) {
      const auto f = pool.flags[i];
      const Segment<T>& s = pool.segments[i];
      std::uint8_t flags = 0;
      if (!(f & (camera_born | bridge_segment))) flags |= conditioned_light_born;
      if (f & light_technique) flags |= conditioned_light_technique | conditioned_potential;
      // A light path could have reached x (through delta reflections too) and tried a predecessor there.
      if (s.x.kind == PointKind::surface && !(f & transmission_chain)) flags |= conditioned_potential;
      side.flags[i] = flags;
      const T d = light_start_density(scene, pool, i, light_paths);
      if (!(std::isfinite(d) && d > T(0))) return;
      side.density[i] = d;
      side.terms[i] = 1;
      if (2 < options_.max_length) side.technique_density[i] = d;  // a light start tries a predecessor
    });
  }

  /// One light technique sample u's term of D_l(s) (and of D_lt(s) if the segment u draws
  /// would itself try a predecessor: trace_light_path's depth rule).
  void add_light_term(LightSide& side, std::uint32_t s, std::uint32_t u, T ql) const noexcept {
    if (!(ql > T(0))) return;
    side.density[s] += ql;
    side.terms[s] += 1;
    if (std::size_t(side.depth[u]) + 2 < options_.max_length) side.technique_density[s] += ql;
  }

  /// N_L p_L(s) (N30) of any segment whose light end could be emitted: plain segments, and
  /// light-born chains, which leave area lights only (trace_light_path); 0 otherwise. For a
  /// distant light end pdf_emission reads a point on the ray (concepts/emitter.hpp).
  [[nodiscard]] static T light_start_density(const Scn& scene, const Pool& pool, std::size_t i, std::uint64_t light_paths) {
    const auto f = pool.flags[i];
    const Segment<T>& s = pool.segments[i];
    const bool light_chain = (f & chain_segment) && s.y.kind == PointKind::surface && light_reachable(pool, i);
    if (light_paths == 0 || s.x.kind != PointKind::surface || ((f & chain_segment) && !light_chain)) return T(0);
    const Vec3<T> leaving = s.y.kind == PointKind::direction ? s.x.position : -pool.last_direction[i];
    const EmissionPdf<T> e = scene.emitter().pdf_emission(EmissionPdfQuery<T>{s.y, leaving});
    const T p_light = e.position * e.direction;
    if (!(p_light > T(0))) return T(0);
    return T(light_paths) * p_light *
           (s.y.kind == PointKind::direction ? endpoint_cosine(s.x, pool.last_direction[i]) : light_measure(pool, i));
  }

  /// The unconditional techniques (sensor, light start), next-event segments (from K(x) n_cam
  /// per segment, empty when off) and the total D(s).
  template <class P>
  void finish_densities(const Scn& scene, Pool& pool, const std::vector<T>& camera_sum, const std::vector<T>& light_sum,
                        const std::vector<T>& bridge_sum, const std::vector<T>& camera_points_at_x,
                        const P& parallel_for) const {
    const std::uint64_t light_paths = light_path_count(scene);
    parallel_for(pool.size(), [&](std::size_t i) {
      const std::uint16_t f = pool.flags[i];
      const Segment<T>& s = pool.segments[i];
      T d = camera_sum[i] + light_sum[i] + (bridge_sum.empty() ? T(0) : bridge_sum[i]);
      if (f & sensor_segment) {
        const SensorPdf<T> p = scene.sensor().pdf(SensorQuery<T>{s.x, pool.first_direction[i]});
        d += p.position * p.direction * ((f & chain_segment) ? T(1) : solid_angle_to_area(T(1), s.x, s.y));
      }
      if (const T p_light = light_start_density(scene, pool, i, light_paths); p_light > T(0)) {
        if (f & delta_light) d = T(0);  // only light sampling produces a Dirac light end
        d += p_light;
      }
      if (!camera_points_at_x.empty() && camera_points_at_x[i] > T(0) && s.x.kind == PointKind::surface && !(f & chain_segment)) {
        // Next-event segments: K(x) n_cam(C(x)) p_L(y | x), in y's measure (a Dirac's coefficient).
        const T p_towards = scene.emitter().pdf_towards(EmitterPdfTowardsQuery<T>{s.x, s.y});
        if (p_towards > T(0)) d += camera_points_at_x[i] * p_towards;
      }
      pool.density[i] = std::isfinite(d) ? d : T(0);
    });
  }

  /// Where every segment ending in a cluster has a Lambertian end with one normal, and every
  /// segment starting there leaves above it, f_r(s, s') = chain(s) albedo(y_s) / pi: the
  /// propagation sum is computed once per cluster.
  template <class P = SerialFor>
  void transfer_factorisation(const Scn& scene, const Pool& pool, const Clustering<T>& clustering,
                              std::vector<std::uint8_t>& factorised, std::vector<S>& diffuse, FilteringStats& stats,
                              const P& parallel_for = {}) const {
    using B = std::remove_cvref_t<decltype(scene.bsdf())>;
    factorised.assign(clustering.clusters().size(), 0);
    diffuse.assign(pool.size(), S(T(0)));
    if constexpr (HasLambertianAlbedo<B, S>) {
      const auto& bsdf = scene.bsdf();
      const auto refs = clustering.refs();
      parallel_for(factorised.size(), [&](std::size_t c) {
        const Cluster<T>& cl = clustering.clusters()[c];
        if (cl.middle == cl.end || cl.begin == cl.middle) return;
        // A black Lambertian end (an emitter that reflects nothing) has f_r = 0 = diffuse
        // whatever its normal and directions: next-event segments end on such lights in crowds.
        const SurfacePoint<T>* first = nullptr;
        bool ok = true;
        for (std::uint32_t q = cl.middle; q < cl.end && ok; ++q) {
          const std::uint32_t s = refs[q].segment;
          const SurfacePoint<T>& y = pool.segments[s].y;
          const auto albedo = bsdf.lambertian_albedo(y);
          if (albedo && is_black(*albedo)) continue;
          if (!first) first = &y;
          ok = albedo && y.normal == first->normal && glm::dot(-pool.last_direction[s], y.normal) > one_sided_epsilon<T>;
          if (ok) diffuse[s] = *albedo * inv_pi<T> * pool.chain[s];
        }
        for (std::uint32_t r = cl.begin; r < cl.middle && ok && first; ++r)
          ok = glm::dot(pool.first_direction[refs[r].segment], first->normal) > one_sided_epsilon<T>;
        factorised[c] = ok ? 1 : 0;
      });
      for (const auto f : factorised) stats.factorised_transfer_clusters += f;
    }
  }

  FilteringOptions<T> options_;
};

}  // namespace segpath
