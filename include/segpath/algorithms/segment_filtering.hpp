// Multi-vertex path filtering (MVF), photon filtering (PhF) and the paper's bidirectional path
// filtering (BDPF) (SPEC 1.9), and any technique set a user extends them with. One iteration
// runs the stages of algorithms/filtering/, each in a header of its own:
//  1. paths.hpp, techniques.hpp: the technique set (technique_set.hpp: the method's techniques
//     as data) draws the pool (approximate sequential segments, N33; delta bounces fold into
//     chains), then the user's own samplers;
//  2. support.hpp: voxel clusters or disks join ends to starts (the kernel, SPEC 1.2);
//     slot_order.hpp: on voxels, for the path-conditioned weighting, the pool renumbered in the
//     clusters' ending-slot order;
//  3. densities.hpp, light_side.hpp: every segment's MMIS denominator over every technique
//     sample of the set (N39);
//  4. propagation.hpp: Algorithm 1's Jacobi sweeps with the paper's or the path-conditioned
//     weighting;
//  5. gather: pixel p += W G L(s_1) w(s_1) over its sensor segments (N40).
// docs/filtering.md derives the weightings and lists what is known to be biased and why.
#pragma once

#include "segpath/algorithms/filtering/context.hpp"
#include "segpath/algorithms/filtering/densities.hpp"
#include "segpath/algorithms/filtering/light_side.hpp"
#include "segpath/algorithms/filtering/options.hpp"
#include "segpath/algorithms/filtering/paths.hpp"
#include "segpath/algorithms/filtering/pool.hpp"
#include "segpath/algorithms/filtering/propagation.hpp"
#include "segpath/algorithms/filtering/slot_order.hpp"
#include "segpath/algorithms/filtering/support.hpp"
#include "segpath/algorithms/filtering/technique_set.hpp"
#include "segpath/algorithms/filtering/techniques.hpp"
#include "segpath/core/drop.hpp"
#include "segpath/core/format.hpp"
#include "segpath/core/framebuffer.hpp"
#include "segpath/core/parallel.hpp"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace segpath {

/// MVF, PhF or BDPF (FilteringOptions::mode) on a scene, with the user's own unconditional
/// samplers `Extra...` in the technique set (FilteringTechnique; none by default).
template <LightSampledScene Scn, class... Extra>
  requires(UnconditionalSegmentSampler<Extra, Scn> && ...)
class SegmentFiltering {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  using Pool = filtering::Pool<T, S>;
  using Context = filtering::Context<Scn>;

  explicit SegmentFiltering(FilteringOptions<T> options, FilteringTechnique<Extra>... extra)
      : options_(options), extra_(std::move(extra)...) {
    validate(options);
    if constexpr (HasCanonicalPosition<Scn>) {
      // A bridge joins two points at their real positions, but its density would have to count
      // every periodic image of the two supports: it is not defined on a periodic domain.
      if (options.bridges)
        throw std::invalid_argument("segpath::SegmentFiltering: bridge segments are not defined on a periodic domain "
                                    "(a scene with canonical_position)");
    }
    std::apply([](const auto&... t) { (check_technique(t), ...); }, extra_);
  }
  [[nodiscard]] const FilteringOptions<T>& options() const noexcept { return options_; }

  /// N_L: light paths per iteration, beta x #pixels (with pixel_passes, each pass draws its
  /// share: Context::light_paths).
  [[nodiscard]] std::uint64_t light_path_count(const Scn& scene) const noexcept {
    return filtering::light_path_count(scene, filtering::technique_set(options_));
  }

  /// The voxel size of iteration 0: the option, or filtering::cell_in_footprints (4) average
  /// pixel footprints (sensors/pixel_footprint.hpp).
  [[nodiscard]] T initial_cell_size(const Scn& scene) const {
    return options_.initial_cell_size > T(0) ? options_.initial_cell_size : filtering::pixel_footprint_cell(scene);
  }
  /// The voxel size of every iteration: from initial_cell_size, shrinking by the PPM schedule.
  [[nodiscard]] KernelSchedule<T> kernel_schedule(const Scn& scene) const {
    return KernelSchedule<T>(initial_cell_size(scene), options_.alpha);
  }

  /// A fresh context for `iteration` (0-based) and its pass `pass` of pixel_passes, for running
  /// the stages one by one. Its support is the iteration's at voxel size `cell` (the
  /// schedule's by default): on voxels the grid (Context::visit_grid), on disks the radius with a
  /// voxel face's area (Context::visit_radius). The paths key their first visits on it and the
  /// support stage (filtering::cluster, filtering::join) builds on it, so the two agree.
  [[nodiscard]] Context context(const Scn& scene, std::uint64_t iteration, std::uint32_t pass = 0,
                                std::optional<T> cell = std::nullopt) const {
    if (pass >= options_.pixel_passes)
      throw std::invalid_argument("segpath::SegmentFiltering: pass " + std::to_string(pass) + " of " +
                                  std::to_string(options_.pixel_passes) + " pixel passes");
    if (cell && !(*cell > T(0) && std::isfinite(*cell)))
      throw std::invalid_argument("segpath::SegmentFiltering: a context's voxel size must be finite and > 0, got " +
                                  format_number(double(*cell)));
    Context ctx{scene, options_, iteration + 1};
    ctx.pass = pass;
    ctx.passes = options_.pixel_passes;
    const T size = cell ? *cell : kernel_schedule(scene).at(iteration);
    if (options_.support == FilteringSupport::voxel)
      ctx.visit_grid = filtering::grid(options_, size, ctx.stream);
    else
      ctx.visit_radius = filtering::disk_radius(size);
    return ctx;
  }

  /// Stage 1: every technique of the set draws into the context's pool, and the user
  /// techniques' densities of every pooled segment are summed (stage 3 adds them to D).
  template <ParallelFor P = SerialFor>
  void build_pool(Context& ctx, const P& parallel_for = {}) const {
    // Each draw of a user technique pools one segment at most.
    const std::size_t later_draws = std::apply(
        [&](const auto&... t) { return (std::size_t(0) + ... + filtering::draw_count(t, ctx)); }, extra_);
    filtering::draw_paths(ctx, parallel_for, later_draws);
    std::uint64_t k = 0;
    std::apply([&](const auto&... t) { (filtering::draw_extra(ctx, t, k++, parallel_for), ...); }, extra_);
    filtering::finish_pool(ctx, parallel_for);
    if constexpr (sizeof...(Extra) > 0) {
      ctx.extra_density.assign(ctx.pool.size(), T(0));
      for_blocks(ctx.pool.size(), parallel_for, [&](std::size_t i) {
        std::apply([&](const auto&... t) { ((ctx.extra_density[i] += filtering::extra_density(ctx, t, i)), ...); }, extra_);
      });
    }
  }

  /// Adds one iteration's estimate to `image` (one camera path per pixel), at the voxel size of
  /// the schedule. Deterministic for a given seed and iteration whatever `parallel_for` does.
  template <ParallelFor P = SerialFor>
  FilteringStats render_iteration(const Scn& scene, std::uint64_t iteration, Framebuffer<S>& image, DropCounters& drops,
                                  const P& parallel_for = {}) const {
    return render_iteration_at(scene, iteration, kernel_schedule(scene).at(iteration), image, drops, parallel_for);
  }

  /// render_iteration with an explicit voxel size `cell` (e.g. a schedule computed once, or a
  /// fixed size to measure kernel bias).
  template <ParallelFor P = SerialFor>
  FilteringStats render_iteration_at(const Scn& scene, std::uint64_t iteration, T cell, Framebuffer<S>& image,
                                     DropCounters& drops, const P& parallel_for = {}) const {
    filtering::check_passes(scene, options_);
    FilteringStats stats = render_pass(scene, iteration, 0, cell, image, drops, parallel_for);
    for (std::uint32_t pass = 1; pass < options_.pixel_passes; ++pass)
      stats.add_pass(render_pass(scene, iteration, pass, cell, image, drops, parallel_for));
    return stats;
  }

  /// One pass of render_iteration_at: the pool of the pass's pixels, filtered into `image`.
  template <ParallelFor P = SerialFor>
  FilteringStats render_pass(const Scn& scene, std::uint64_t iteration, std::uint32_t pass, T cell, Framebuffer<S>& image,
                             DropCounters& drops, const P& parallel_for = {}) const {
    using Clock = std::chrono::steady_clock;
    auto lap = [last = Clock::now()](double& seconds) mutable {
      const auto now = Clock::now();
      seconds = std::chrono::duration<double>(now - last).count();
      last = now;
    };
    Context ctx = context(scene, iteration, pass, cell);
    FilteringStats& stats = ctx.stats;
    const Pool& pool = ctx.pool;
    build_pool(ctx, parallel_for);
    lap(stats.paths_seconds);
    stats.segments = pool.size();
    stats.next_event_segments = pool.next_event_segments;
    for (auto f : pool.flags) {
      if (f & filtering::repeat_visit_born) ++(f & filtering::camera_born ? stats.camera_repeat_visit_segments : stats.repeat_visit_segments);
      (f & filtering::camera_born      ? stats.camera_segments
       : f & filtering::bridge_segment ? stats.bridge_segments
       : f & filtering::extra_technique ? stats.extra_segments
                                        : stats.light_segments) += 1;
    }
    stats.cell_size = double(cell);

    const std::size_t n = std::max<std::size_t>(pool.size(), 1);  // for the bytes per segment
    std::vector<S> radiance;
    std::vector<T> weighted_geometry;
    const int iterations = int(options_.max_length) - 1;
    // after_release: what the propagation allocates per segment after it freed the pool's end
    // points (PoolGeometry::release; voxels only): the peak is the larger of before and after.
    std::size_t support_bytes = 0, propagation_bytes = 0, after_release = 0;
    std::size_t support_stage = 0;  // the support stage's own peak, the pool included (voxels)
    filtering::LightSide<T> side;
    const bool conditioned = path_conditioned(options_);
    if (options_.support == FilteringSupport::voxel) {
      Clustering<T> clustering;
      // The path-conditioned propagation reads the pool by slot the most: there the renumbering
      // pays for itself; with the paper's weighting it costs what it saves (docs/figures.md).
      if (conditioned) filtering::cluster_in_slot_order(ctx, clustering, parallel_for);
      else filtering::cluster(ctx, clustering, parallel_for);
      stats.clusters = clustering.clusters().size();
      lap(stats.support_seconds);
      filtering::compute_densities(ctx, clustering, parallel_for, conditioned ? &side : nullptr);
      lap(stats.densities_seconds);
      support_bytes = clustering.bytes_per_segment();
      support_stage = pool.bytes_per_segment() + (conditioned ? filtering::slot_order_bytes_per_segment<T> : 0) +
                      clustering.build_peak_bytes_per_segment();
      if (conditioned) {
        filtering::propagate_conditioned_pool(ctx, clustering, side, iterations, radiance, weighted_geometry, parallel_for,
                                              filtering::PoolGeometry::release);
        // The propagation's arrays, and diffuse when factorising.
        propagation_bytes = filtering::conditioned_bytes_per_segment<S> + (options_.factorise ? sizeof(S) : 0) + bridge_bytes(side);
        after_release =
            filtering::conditioned_bytes_after_release<S> + bridge_bytes(side) +
            (stats.lagged_bytes + stats.forced_value_bytes + stats.round_trip_bytes) / n;
      } else {
        filtering::propagate_pool(ctx, clustering, iterations, radiance, weighted_geometry, parallel_for,
                                  filtering::PoolGeometry::release);
        // Propagation: diffuse when factorising, the transfer, the workspace and the backtrack partners.
        propagation_bytes = (options_.factorise ? sizeof(S) : 0) + filtering::Transfer<Scn>::bytes_per_segment() +
                            PairTable<S>::bytes_per_ending_slot + PropagationWorkspace<S>::bytes_per_segment + sizeof(std::uint32_t);
        after_release =
            PropagationWorkspace<S>::bytes_per_segment + sizeof(std::uint32_t) + (stats.lagged_bytes + stats.round_trip_bytes) / n;
      }
    } else {
      DiskJunctions<T> junctions;
      filtering::join(ctx, junctions, parallel_for);
      stats.junctions = junctions.junction_count();
      lap(stats.support_seconds);
      filtering::compute_densities(ctx, junctions, parallel_for, conditioned ? &side : nullptr);
      if (conditioned) filtering::light_side(ctx, junctions, side, parallel_for);
      lap(stats.densities_seconds);
      support_bytes = junctions.bytes_per_segment();
      if (conditioned) {
        filtering::propagate_conditioned_pool(ctx, junctions, side, iterations, radiance, weighted_geometry, parallel_for);
        propagation_bytes = filtering::conditioned_bytes_per_segment<S> + bridge_bytes(side);
      } else {
        filtering::propagate_pool(ctx, junctions, iterations, radiance, weighted_geometry, parallel_for);
        propagation_bytes = PropagationWorkspace<S>::bytes_per_segment + sizeof(std::uint32_t);
      }
    }
    lap(stats.propagation_seconds);
    for (std::size_t i = 0; i < pool.size(); ++i) {
      if (!(pool.flags[i] & filtering::sensor_segment)) continue;
      const S value = radiance[i] * (pool.sensor_weight[i] * weighted_geometry[i]);
      if (is_finite(value)) image.add(pool.pixel[i], value);
      else drops.add(DropReason::non_finite);
    }
    const std::size_t freed = std::min(Pool::geometry_bytes_per_segment, after_release);
    const std::size_t drawing = pool.bytes_per_segment() + stats.record_bytes / n;  // append's records and pool
    const std::size_t propagation_stage =
        pool.bytes_per_segment() - freed + support_bytes + sizeof(T) + sizeof(S) + propagation_bytes +
        (stats.propagation_copy_bytes + stats.lagged_bytes + stats.forced_value_bytes + stats.round_trip_bytes) / n;
    stats.bytes_per_segment = std::max({drawing, support_stage, propagation_stage});
    lap(stats.gather_seconds);
    return stats;
  }

 private:
  /// What the bridges add to the path-conditioned propagation per segment: their share and
  /// density in `side`, and the junctions' copy per ending slot (none without bridges).
  static std::size_t bridge_bytes(const filtering::LightSide<T>& side) noexcept {
    return side.bridge_density.empty() ? 0 : 2 * sizeof(T) + sizeof(detail::ConditionedBridgeEnd<T>);
  }

  template <class Smp>
  static void check_technique(const FilteringTechnique<Smp>& t) {
    if (!(t.per_pixel > 0) || !std::isfinite(t.per_pixel))
      throw std::invalid_argument("segpath::SegmentFiltering: a technique's per_pixel must be > 0, got " +
                                  std::to_string(t.per_pixel));
  }

  FilteringOptions<T> options_;
  std::tuple<FilteringTechnique<Extra>...> extra_;
};

}  // namespace segpath
