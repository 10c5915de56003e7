// The options and per-iteration counters of segment filtering (MVF, PhF, BDPF; SPEC 1.9):
// which method, the kernel support and its schedule, the chain weighting, the optional
// techniques (next-event, bridge segments) and the memory budget of the pair table.
#pragma once

#include "segpath/core/format.hpp"
#include "segpath/core/vec.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

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
  /// Segments per path (>= 2), a chain through delta bounces counting its pieces (as in VCM and
  /// PT): propagation runs max_length - 1 iterations (propagation/segment_budget.hpp).
  std::size_t max_length = 10;
  T light_path_ratio = T(1);  ///< beta: light paths per pixel per iteration (PhF, BDPF); 1: BDPF's best at equal time on box 1
  /// PhF, BDPF: an iteration (pass) draws a Poisson(N_L) number of light paths, N_L = beta x
  /// #pixels, and every density still counts N_L. The light paths are then a Poisson process
  /// on path space, whose rest, given one of its paths, is the process itself (Slivnyak-Mecke):
  /// what the path-conditioned weighting assumes when it takes D_l(s) less the successor's term
  /// (its path's only term there, by the first-visit rule) for the light density of the rest of
  /// the pool. False: exactly N_L light paths, O(1 / N_L) bright where a light path often holds
  /// a technique sample in a chain's cluster (few light paths, large voxels; docs/filtering.md).
  bool poisson_light_paths = true;
  /// PhF, BDPF: the probability c that a light path draws a predecessor at a non-delta vertex
  /// (Russian roulette, the same at every depth). Light paths have no depth limit, so whether a
  /// light-born segment can draw a predecessor never depends on its depth: every light-born
  /// segment at a non-delta surface is a light technique sample, of density c q. Negative:
  /// (max_length - 2) / (max_length - 1), light paths of max_length - 1 segments on average.
  T light_continuation = T(-1);
  /// MVF, BDPF: the probability c_c that a camera path draws a successor at a non-delta vertex
  /// (Russian roulette, the same at every depth), in (0, 1]. A camera successor's density
  /// carries it, as a light predecessor's carries c. 1: no roulette. Camera paths have no depth
  /// limit, as light paths: past max_length segments they continue with the tail's roulette,
  /// c_c, or 1/2 where c_c is 1 (TechniqueSet::camera_tail_continuation; docs/filtering.md).
  /// Negative: automatic, filtering::automatic_camera_continuation(mode).
  T camera_continuation = T(-1);
  T initial_cell_size = 0;       ///< voxel size of iteration 1; 0: 4x the average pixel footprint
  T alpha = T(0.67);             ///< progressive shrinking of the voxel (PPM schedule)
  bool factorise = true;         ///< use the O(n) sums in factorisable clusters (voxel support)
  /// The junctions' support. The disk has the voxel's area (pi r^2 = h^2) but is centred on
  /// each end, so supports overlap: no quantisation, no factorisation, memory per junction.
  FilteringSupport support = FilteringSupport::voxel;
  /// BDPF only: from every camera technique point y_t, one bridge segment to the start x_u of
  /// a light segment chosen uniformly among the pool's M light technique samples, kept when
  /// visible (SPEC 1.6 bridge, N34, with the approximate kernel draws of N33). Its technique
  /// density, for every plain segment s, is K(x_s) n_cam(x_s) K(y_s) n_tgt(y_s) / M.
  bool bridges = false;
  /// MVF and BDPF (PhF has no camera technique points and ignores it): from every camera
  /// technique point y_t, one next-event segment to a light
  /// point drawn by the emitter's sample_towards(y_t), kept when visible (the light-end bridge
  /// of SPEC 1.6, N34, approximate: it starts exactly at y_t). A camera-side technique like the
  /// BSDF successor: its density, for every plain segment s, is K(x_s) n_cam(C(x_s)) p_L(y_s | x_s).
  bool next_event = true;
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
  /// An iteration draws its pool in this many passes, pass k over pixels k, k + passes, ...
  /// with its share of the light paths and of the user's draws (Context::light_paths): each
  /// pass estimates its own pixels from a pool 1 / passes the size, so memory falls that much
  /// and the noise per second rises (fewer paths to reuse). For pools that do not fit.
  std::uint32_t pixel_passes = 1;
  std::uint64_t seed = 1;
};

/// Counters of one iteration (pool size, clusters, how many were factorised).
struct FilteringStats {
  std::uint64_t segments = 0, camera_segments = 0, light_segments = 0, bridge_segments = 0, clusters = 0;
  std::uint64_t light_paths = 0;  ///< drawn (Context::drawn_light_paths)
  std::uint64_t next_event_segments = 0;  ///< among the camera segments
  std::uint64_t extra_segments = 0;  ///< drawn by the user's techniques (FilteringTechnique)
  /// Among the light (camera) segments: drawn at a light (camera) path's repeat visit of a
  /// voxel, in no chain (filtering::repeat_visit_born).
  std::uint64_t repeat_visit_segments = 0, camera_repeat_visit_segments = 0;
  std::uint64_t junctions = 0;  ///< disk support: (end, start) pairs within r
  std::uint64_t factorised_camera_clusters = 0, factorised_light_clusters = 0, factorised_transfer_clusters = 0;
  std::uint64_t pair_evaluations = 0;  ///< technique-density and transfer evaluations
  double cell_size = 0;
  /// O(#segments) memory at the iteration's peak, without the transfer cache: the largest of the
  /// drawing's (the path records and the pool they are copied into), the support's on voxels (the
  /// pool, the clustering's build and the renumbering's buffer: slot_order.hpp) and the
  /// propagation's (on voxels it frees the pool's end points first: filtering::PoolGeometry).
  std::size_t bytes_per_segment = 0;
  std::size_t transfer_cache_bytes = 0;  ///< FilteringOptions::transfer_cache_bytes at most
  /// In bytes_per_segment: what the propagation copied into slot order for the clusters it
  /// does not factorise (voxel support), for the whole pool.
  std::size_t propagation_copy_bytes = 0;
  /// In bytes_per_segment: the propagation's lagged values of chains (ConditionedMemory::lagged,
  /// PropagationWorkspace::lagged_bytes), for the whole pool.
  std::size_t lagged_bytes = 0;
  /// In bytes_per_segment: the path-conditioned propagation's U values, kept only for the
  /// segments a junction can force, and their indices (ConditionedMemory::forced_values), for
  /// the whole pool.
  std::size_t forced_value_bytes = 0;
  /// In bytes_per_segment: what the propagation's round trips held at once (the pairs'
  /// entries, and the search's indices or the parts: propagation/round_trips.hpp), for the
  /// whole pool.
  std::size_t round_trip_bytes = 0;
  /// In bytes_per_segment: the camera and light paths' records (RecordList) when they were
  /// pooled, for the whole pool.
  std::size_t record_bytes = 0;
  /// Not in bytes_per_segment: what the path records' blocks held unfilled when they were pooled
  /// (about one block per generator's list, whatever the pool's size).
  std::size_t record_slack_bytes = 0;
  /// Wall time of the stages of render_iteration: paths (pool), support (clusters or disk
  /// junctions, and the pool's renumbering in slot order), densities (MMIS denominators, light
  /// side), propagation (with its pair evaluations), gather (pixels).
  double paths_seconds = 0, support_seconds = 0, densities_seconds = 0, propagation_seconds = 0, gather_seconds = 0;
  std::uint32_t passes = 1;  ///< the pools (FilteringOptions::pixel_passes) the counts and seconds sum over

  /// Adds a later pass of the same iteration: counts and seconds sum, memory is the larger pass's.
  void add_pass(const FilteringStats& p) noexcept {
    segments += p.segments, camera_segments += p.camera_segments, light_segments += p.light_segments;
    light_paths += p.light_paths;
    bridge_segments += p.bridge_segments, clusters += p.clusters, next_event_segments += p.next_event_segments;
    extra_segments += p.extra_segments, junctions += p.junctions, repeat_visit_segments += p.repeat_visit_segments;
    camera_repeat_visit_segments += p.camera_repeat_visit_segments;
    factorised_camera_clusters += p.factorised_camera_clusters, factorised_light_clusters += p.factorised_light_clusters;
    factorised_transfer_clusters += p.factorised_transfer_clusters, pair_evaluations += p.pair_evaluations;
    bytes_per_segment = std::max(bytes_per_segment, p.bytes_per_segment);
    transfer_cache_bytes = std::max(transfer_cache_bytes, p.transfer_cache_bytes);
    propagation_copy_bytes = std::max(propagation_copy_bytes, p.propagation_copy_bytes);
    lagged_bytes = std::max(lagged_bytes, p.lagged_bytes);
    forced_value_bytes = std::max(forced_value_bytes, p.forced_value_bytes);
    round_trip_bytes = std::max(round_trip_bytes, p.round_trip_bytes);
    record_bytes = std::max(record_bytes, p.record_bytes);
    record_slack_bytes = std::max(record_slack_bytes, p.record_slack_bytes);
    paths_seconds += p.paths_seconds, support_seconds += p.support_seconds, densities_seconds += p.densities_seconds;
    propagation_seconds += p.propagation_seconds, gather_seconds += p.gather_seconds;
    passes += p.passes;
  }
};

/// Throws std::invalid_argument naming the first option out of range.
template <Real T>
void validate(const FilteringOptions<T>& options) {
  // Enumerations cast from a number out of their range would render as some other choice.
  if (options.mode > FilteringMode::bdpf || options.support > FilteringSupport::disk || options.weighting > FilteringWeighting::paper)
    throw std::invalid_argument("segpath::SegmentFiltering: mode, support or weighting out of its enumeration's range (" +
                                std::to_string(int(options.mode)) + ", " + std::to_string(int(options.support)) + ", " +
                                std::to_string(int(options.weighting)) + ")");
  if (options.max_length < 2)
    throw std::invalid_argument("segpath::SegmentFiltering: max_length must be >= 2 (k >= 1 propagation iterations), got " +
                                std::to_string(options.max_length));
  if (options.mode != FilteringMode::mvf && !(options.light_path_ratio > T(0) && std::isfinite(options.light_path_ratio)))
    throw std::invalid_argument("segpath::SegmentFiltering: beta (light paths per pixel) must be > 0, got " +
                                format_number(double(options.light_path_ratio)));
  if (!(options.initial_cell_size >= T(0)) || !std::isfinite(options.initial_cell_size))
    throw std::invalid_argument("segpath::SegmentFiltering: voxel size must be > 0 (or 0 for automatic), got " +
                                format_number(double(options.initial_cell_size)));
  // The kernel is about 1 / h^2 (a voxel's plane area, a disk's pi r^2 = h^2): beyond T's range
  // it is 0 or infinite, and every pixel black with nothing dropped.
  if (const T h = options.initial_cell_size; h > T(0) && !(T(1) / (h * h) > T(0) && std::isfinite(T(1) / (h * h))))
    throw std::invalid_argument("segpath::SegmentFiltering: voxel size " + format_number(double(h)) +
                                " puts the kernel 1 / h^2 out of the scalar type's range");
  if (options.bridges && options.mode != FilteringMode::bdpf)
    throw std::invalid_argument(std::string("segpath::SegmentFiltering: bridge segments join camera and light paths, "
                                            "so they need mode bdpf, got ") + to_string(options.mode));
  if (!(options.light_continuation < T(1)) || std::isnan(options.light_continuation))
    throw std::invalid_argument("segpath::SegmentFiltering: the light continuation probability must be < 1 (negative: automatic), got " +
                                format_number(double(options.light_continuation)));
  // 0 draws light starts only: BDPF's camera side still reaches the rest, PhF nothing beyond
  // the light's first bounce (its indirect light would be missing without a word).
  if (options.mode == FilteringMode::phf && options.light_continuation == T(0))
    throw std::invalid_argument("segpath::SegmentFiltering: phf with light continuation 0 samples no light beyond a light path's "
                                "first segment; use a value in (0, 1) (negative: automatic)");
  if (!(options.camera_continuation > T(0) && options.camera_continuation <= T(1)) && !(options.camera_continuation < T(0)))
    throw std::invalid_argument("segpath::SegmentFiltering: the camera continuation probability must lie in (0, 1] (negative: automatic), got " +
                                format_number(double(options.camera_continuation)));
  if (options.pixel_passes < 1)
    throw std::invalid_argument("segpath::SegmentFiltering: pixel_passes must be >= 1, got 0");
  if (!(options.alpha > T(0) && options.alpha < T(1)))
    throw std::invalid_argument("segpath::SegmentFiltering: alpha must lie in (0, 1), got " + format_number(double(options.alpha)));
}

/// Whether chains are weighted path-conditioned (only BDPF has both sides).
template <Real T>
[[nodiscard]] constexpr bool path_conditioned(const FilteringOptions<T>& options) noexcept {
  return options.mode == FilteringMode::bdpf && options.weighting == FilteringWeighting::path_conditioned;
}

}  // namespace segpath
