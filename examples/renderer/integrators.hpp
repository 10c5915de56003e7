// The renderer's methods: each is the library's method, built from the command line's options,
// run through the library's render protocol (segpath::ProgressiveRender) on a scene that counts
// its rays; the image is the accumulated sum divided by the iteration count whatever the method.
#pragma once

#include "kernel_check.hpp"
#include "render_scene.hpp"

#include <segpath/algorithms/light_tracer.hpp>
#include <segpath/algorithms/path_tracer.hpp>
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/algorithms/vcm.hpp>
#include <segpath/core/drop.hpp>
#include <segpath/core/framebuffer.hpp>
#include <segpath/core/parallel.hpp>
#include <segpath/render/progressive.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <cstdio>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

namespace renderer {

/// Sum over iterations of each iteration's image estimate, in double; image = sum / iterations.
using Accumulator = segpath::Framebuffer<segpath::Rgb<double>>;

/// What the render loop counts: paths traced (camera paths for PT, light paths for LT), rays
/// (intersect + visible calls) and dropped samples by reason.
struct Stats {
  std::uint64_t paths = 0;
  std::uint64_t rays = 0;
  segpath::DropCounters dropped;

  Stats& operator+=(const Stats& o) noexcept {
    paths += o.paths;
    rays += o.rays;
    dropped += o.dropped;
    return *this;
  }
};

/// Options every method is built from (kernel options are used by the kernel methods only).
struct MethodOptions {
  std::uint64_t seed = 1;
  std::size_t max_length = 10;  ///< segments per path, the camera segment included
  std::optional<double> radius;  ///< kernel radius (VCM family) or voxel size (filtering); unset: method default
  std::optional<double> alpha;   ///< progressive reduction, in (0, 1); unset: the method's library default
  std::optional<double> beta;    ///< light paths per camera path (> 0); unset: the method's library default
  /// mvf, bdpf: FilteringOptions::camera_continuation, in (0, 1]; unset: the library's automatic one
  std::optional<double> camera_continuation;
  /// pt, lt, the VCM family: Russian roulette from this path length on (0: never); unset: the method's default
  std::optional<std::size_t> roulette_from;
  segpath::FilteringSupport support = segpath::FilteringSupport::voxel;  ///< filtering: junction support
  bool bridges = false;          ///< bdpf: add bridge segments
  bool next_event = segpath::FilteringOptions<float>{}.next_event;  ///< mvf, bdpf: add next-event segments
  /// bdpf: chain weighting, path-conditioned (unbiased) or the paper's prod 1 / D
  segpath::FilteringWeighting weighting = segpath::FilteringOptions<float>{}.weighting;
  bool print_stats = false;      ///< mvf, phf, bdpf: one line of FilteringStats per iteration on stderr
  std::optional<std::size_t> transfer_cache_mib;  ///< mvf, phf, bdpf: FilteringOptions::transfer_cache_bytes in MiB
  std::uint32_t passes = 1;  ///< mvf, phf, bdpf: FilteringOptions::pixel_passes
};

/// The settings that decide a method's image, as the method runs with them: what the command
/// line set, else the library's or the renderer's default, resolved. A checkpoint records these
/// numbers (image_options), so a render whose defaults have changed since is refused instead of
/// resumed with other settings. Unset: the method does not use the setting.
struct ResolvedSettings {
  std::optional<double> alpha, beta, camera_continuation;
  std::optional<std::size_t> roulette_from;
  /// The automatic initial kernel (merge radius, voxel size) in average pixel footprints, where
  /// the method has a kernel and --radius is unset (its size follows from the scene).
  std::optional<double> kernel_in_footprints;
};

namespace detail {

/// The process's ray count, kept per thread without synchronisation on the hot path: each
/// thread increments a counter of its own (registered at its first ray, retired at its exit);
/// total() sums them. (oneTBB's enumerable_thread_specific cost PT 3.5 % in its lookup.)
class RayCounters {
 public:
  static void count() noexcept {
    thread_local Slot slot;
    slot.rays.store(slot.rays.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  }
  /// Every ray counted so far, by every thread.
  static std::uint64_t total() {
    RayCounters& r = instance();
    const std::lock_guard lock(r.mutex_);
    std::uint64_t sum = r.retired_;
    for (const Slot* slot : r.slots_) sum += slot->rays.load(std::memory_order_relaxed);
    return sum;
  }

 private:
  struct Slot {
    std::atomic<std::uint64_t> rays{0};
    Slot() {
      RayCounters& r = instance();
      const std::lock_guard lock(r.mutex_);
      r.slots_.push_back(this);
    }
    ~Slot() {
      RayCounters& r = instance();
      const std::lock_guard lock(r.mutex_);
      r.retired_ += rays.load(std::memory_order_relaxed);
      r.slots_.erase(std::find(r.slots_.begin(), r.slots_.end(), this));
    }
  };
  /// Never destroyed: worker threads may retire their slots after static destruction.
  static RayCounters& instance() {
    static RayCounters* const counters = new RayCounters;
    return *counters;
  }
  std::mutex mutex_;
  std::vector<const Slot*> slots_;
  std::uint64_t retired_ = 0;
};

}  // namespace detail

/// A RenderScene counting its intersect and visible calls per thread (for the methods that
/// parallelise internally); the total is read after the iteration.
class ThreadCountingScene {
 public:
  using Scalar = T;
  using Spectrum = Color;

  explicit ThreadCountingScene(const RenderScene& scene) : scene_(&scene), counted_(detail::RayCounters::total()) {}

  [[nodiscard]] T area() const noexcept { return scene_->area(); }
  [[nodiscard]] std::optional<segpath::AreaSample<T>> sample_area(const segpath::AreaSampleQuery<T>& q) const noexcept {
    return scene_->sample_area(q);
  }
  [[nodiscard]] std::optional<segpath::Hit<T>> intersect(const segpath::IntersectQuery<T>& q) const noexcept {
    detail::RayCounters::count();
    return scene_->intersect(q);
  }
  [[nodiscard]] bool visible(const segpath::VisibilityQuery<T>& q) const noexcept {
    detail::RayCounters::count();
    return scene_->visible(q);
  }
  [[nodiscard]] const segpath::MaterialSet<Color>& bsdf() const noexcept { return scene_->bsdf(); }
  [[nodiscard]] const Emitter& emitter() const noexcept { return scene_->emitter(); }
  [[nodiscard]] const segpath::PinholeCamera<T>& sensor() const noexcept { return scene_->sensor(); }
  [[nodiscard]] const RenderScene& scene() const noexcept { return *scene_; }

  /// The rays counted since construction or the last call (by every thread of the process:
  /// one render at a time).
  std::uint64_t take_rays() const {
    const std::uint64_t now = detail::RayCounters::total();
    return now - std::exchange(counted_, now);
  }

 private:
  const RenderScene* scene_;
  mutable std::uint64_t counted_;
};

static_assert(segpath::LightSampledScene<ThreadCountingScene>);

namespace detail {

/// The drops counted in `now` beyond those in `before`.
[[nodiscard]] inline segpath::DropCounters drops_since(const segpath::DropCounters& now, const segpath::DropCounters& before) noexcept {
  segpath::DropCounters d;
  for (std::size_t r = 0; r < segpath::drop_reason_count; ++r) d.counts[r] = now.counts[r] - before.counts[r];
  return d;
}

}  // namespace detail

/// A render of one scene with one library method (a segpath::ProgressiveMethod) through the
/// library's render protocol, segpath::ProgressiveRender, on the counting scene: it numbers the
/// iterations, accumulates them in double and computes the kernel schedule once. The renderer's
/// methods below are this class with the method their options build.
template <class Library>
class MethodRun {
 public:
  /// One iteration's image (not yet averaged), as render() leaves it and accumulate() takes it.
  using IterationImage = segpath::Framebuffer<Color>;

  explicit MethodRun(Library method) : method_(std::move(method)) {}

  /// Segment filtering's mode, which decides the filtering options the method reads
  /// (method_specific_options); none for the other methods.
  static constexpr std::optional<segpath::FilteringMode> filtering_mode{};

  /// Renders the next iteration of `scene` (the same scene at every call: the first starts the
  /// render at its sensor's size), adds it to the sum and adds rays, paths and drops to `stats`;
  /// returns what the method's iteration returns (SegmentFiltering: FilteringStats).
  template <segpath::ParallelFor P>
  decltype(auto) iterate(const RenderScene& scene, Stats& stats, const P& parallel) {
    return render_and_accumulate(*this, scene, stats, parallel);
  }

  /// Renders iteration `iteration` into iteration_image() without adding it to the sum (a rank
  /// of a distributed render); adds its rays, paths and drops to `stats`.
  template <segpath::ParallelFor P>
  decltype(auto) render(const RenderScene& scene, std::uint64_t iteration, Stats& stats, const P& parallel) {
    start(scene);
    const segpath::DropCounters before = render_->drops();
    (void)counting_->take_rays();
    const auto finish = [&] {
      stats.rays += counting_->take_rays();
      stats.paths += render_->width() * std::uint64_t(render_->height());
      stats.dropped += detail::drops_since(render_->drops(), before);
    };
    if constexpr (std::is_void_v<decltype(render_->render(iteration, parallel))>) {
      render_->render(iteration, parallel);
      finish();
    } else {
      auto result = render_->render(iteration, parallel);
      finish();
      return result;
    }
  }
  /// The image of the last render().
  [[nodiscard]] const IterationImage& iteration_image() const { return started().iteration_image(); }
  /// Adds `image`, iteration iterations() rendered here or by another rank, to the sum (a
  /// non-finite pixel is dropped and counted in `stats`).
  void accumulate(const RenderScene& scene, const IterationImage& image, Stats& stats) {
    start(scene);
    const segpath::DropCounters before = render_->drops();
    render_->accumulate(image);
    stats.dropped += detail::drops_since(render_->drops(), before);
  }
  /// Continues a render saved after `iterations` iterations with this sum (a checkpoint).
  void resume(const RenderScene& scene, Accumulator sum, std::uint64_t iterations) {
    start(scene);
    render_->resume(std::move(sum), iterations, render_->drops());
  }

  /// The sum of the iterations rendered so far (empty before the first).
  [[nodiscard]] const Accumulator& sum() const { return started().sum(); }
  [[nodiscard]] std::uint64_t iterations() const noexcept { return render_ ? render_->iterations() : 0; }
  /// The library method (after the first iteration: the one that rendered it).
  [[nodiscard]] const Library& method() const { return render_ ? render_->method() : *method_; }

 protected:
  /// iterate() of a method class M derived from MethodRun: M's own render() (which may do more,
  /// e.g. keep FilteringStats), then accumulate().
  template <class M, segpath::ParallelFor P>
  static decltype(auto) render_and_accumulate(M& method, const RenderScene& scene, Stats& stats, const P& parallel) {
    const std::uint64_t iteration = method.iterations();
    if constexpr (std::is_void_v<decltype(method.render(scene, iteration, stats, parallel))>) {
      method.render(scene, iteration, stats, parallel);
      method.accumulate(scene, method.iteration_image(), stats);
    } else {
      auto result = method.render(scene, iteration, stats, parallel);
      method.accumulate(scene, method.iteration_image(), stats);
      return result;
    }
  }

 private:
  void start(const RenderScene& scene) {
    if (!render_) {
      counting_ = std::make_unique<ThreadCountingScene>(scene);
      render_ = std::make_unique<segpath::ProgressiveRender<ThreadCountingScene, Library>>(
          *counting_, std::move(*method_), scene.sensor().width(), scene.sensor().height());
      method_.reset();
    } else if (&counting_->scene() != &scene) {
      throw std::logic_error("renderer::MethodRun: a render continues on the scene it started on");
    }
  }
  [[nodiscard]] const auto& started() const {
    if (!render_) throw std::logic_error("renderer::MethodRun: no iteration rendered yet");
    return *render_;
  }

  std::optional<Library> method_;
  std::unique_ptr<ThreadCountingScene> counting_;  // ProgressiveRender keeps its address
  std::unique_ptr<segpath::ProgressiveRender<ThreadCountingScene, Library>> render_;
};

/// Path tracing with next-event estimation (segpath::PathTracer::render_iteration): one path
/// per pixel per iteration, pixel p of iteration i drawing from Pcg32::for_sample(seed, p, i).
class PtMethod : public MethodRun<segpath::PathTracer<ThreadCountingScene>> {
 public:
  static constexpr std::string_view name = "pt";
  static constexpr RadiusUse radius_use = RadiusUse::ignored;
  static constexpr std::string_view description = "path tracing with next-event estimation (MIS)";

  /// Russian roulette with SmallVCM's rule (core/roulette.hpp) from the third segment on by
  /// default (SmallVCM starts at the first; the third is better at equal time: docs/figures.md).
  static constexpr std::size_t default_roulette_from = 3;

  explicit PtMethod(const MethodOptions& o)
      : MethodRun(segpath::PathTracer<ThreadCountingScene>(
            {o.max_length, segpath::MisHeuristic::power, o.roulette_from.value_or(default_roulette_from), o.seed})) {}

  [[nodiscard]] static ResolvedSettings resolved(const MethodOptions& o) {
    ResolvedSettings r;
    r.roulette_from = o.roulette_from.value_or(default_roulette_from);
    return r;
  }
};

/// Light tracing (segpath::LightTracer::render_iteration): #pixels light paths per iteration,
/// splatted in a fixed chunk order, so the image for a seed is the same for any thread count.
class LtMethod : public MethodRun<segpath::LightTracer<ThreadCountingScene>> {
 public:
  static constexpr std::string_view name = "lt";
  static constexpr RadiusUse radius_use = RadiusUse::ignored;
  static constexpr std::string_view description = "light tracing (splats to the camera)";

  static constexpr std::size_t default_roulette_from = 0;  ///< no Russian roulette by default

  explicit LtMethod(const MethodOptions& o)
      : MethodRun(segpath::LightTracer<ThreadCountingScene>({o.max_length, o.roulette_from.value_or(default_roulette_from), o.seed})) {}

  [[nodiscard]] static ResolvedSettings resolved(const MethodOptions& o) {
    ResolvedSettings r;
    r.roulette_from = o.roulette_from.value_or(default_roulette_from);
    return r;
  }
};

/// BDPT, PPM, BPM and VCM (segpath::VertexConnectionMerging, one implementation with modes):
/// one camera path per pixel and beta x #pixels light paths per iteration; the merge radius
/// starts at --radius (default: the library's segpath::radius_in_footprints(mode) x the average
/// pixel footprint) and shrinks by --alpha.
template <segpath::VcmMode Mode>
class VcmMethod : public MethodRun<segpath::VertexConnectionMerging<ThreadCountingScene>> {
 public:
  static constexpr std::string_view name = segpath::to_string(Mode);
  static constexpr RadiusUse radius_use = Mode == segpath::VcmMode::bdpt ? RadiusUse::ignored : RadiusUse::merge_radius;
  static constexpr std::string_view description =
      Mode == segpath::VcmMode::bdpt  ? "bidirectional path tracing (all connections, MIS)"
      : Mode == segpath::VcmMode::ppm ? "progressive photon mapping (first non-specular camera hit)"
      : Mode == segpath::VcmMode::bpm ? "bidirectional photon mapping (merging at every camera vertex, MIS)"
                                      : "vertex connection and merging (BDPT + BPM under one MIS)";

  explicit VcmMethod(const MethodOptions& o) : MethodRun(segpath::VertexConnectionMerging<ThreadCountingScene>(vcm_options(o))) {}

  /// BDPT merges nothing: no radius, no alpha.
  [[nodiscard]] static ResolvedSettings resolved(const MethodOptions& o) {
    const segpath::VcmOptions v = vcm_options(o);
    ResolvedSettings r;
    r.beta = v.light_path_factor;
    r.roulette_from = v.roulette_from;
    if constexpr (Mode != segpath::VcmMode::bdpt) {
      r.alpha = v.alpha;
      if (!(v.initial_radius > 0)) r.kernel_in_footprints = segpath::radius_in_footprints(Mode);
    }
    return r;
  }

 private:
  static segpath::VcmOptions vcm_options(const MethodOptions& o) {
    segpath::VcmOptions v;  // the library's defaults, but for what the command line set
    v.mode = Mode;
    v.max_length = o.max_length;
    if (o.radius) v.initial_radius = *o.radius;
    if (o.alpha) v.alpha = *o.alpha;
    if (o.beta) v.light_path_factor = *o.beta;
    v.seed = o.seed;
    // Russian roulette from the first scattering by default, SmallVCM's schedule (docs/figures.md).
    v.roulette_from = o.roulette_from.value_or(1);
    return v;
  }
};

/// MVF, PhF and BDPF (segpath::SegmentFiltering): approximate sequential segments pooled per
/// iteration, voxel clusters (or disks of the same area, --support disk) of --radius (default 4x
/// the average pixel footprint) shrinking by --alpha (default 0.67), beta x #pixels light paths
/// (default 1), MMIS weights and propagation (the paper's Algorithm 1); BDPF optionally with
/// bridge segments (--bridges). MVF and BDPF draw next-event segments by default (the library's
/// FilteringOptions::next_event; --no-next-event turns them off; PhF has no camera technique
/// points): on box 1 they cut BDPF's relMSE at equal time by a quarter (docs/figures.md).
template <segpath::FilteringMode Mode>
class FilteringMethod : public MethodRun<segpath::SegmentFiltering<ThreadCountingScene>> {
 public:
  static constexpr std::string_view name = segpath::to_string(Mode);
  static constexpr RadiusUse radius_use = RadiusUse::voxel;
  static constexpr std::string_view description =
      Mode == segpath::FilteringMode::mvf   ? "multi-vertex path filtering (camera segments, propagation)"
      : Mode == segpath::FilteringMode::phf ? "photon filtering (light segments, propagation)"
                                            : "bidirectional path filtering, the paper's method (both sides, MMIS, propagation)";

  explicit FilteringMethod(const MethodOptions& o)
      : MethodRun(segpath::SegmentFiltering<ThreadCountingScene>(filtering_options(o))), print_stats_(o.print_stats) {}

  /// MethodRun::render, keeping (and with --stats printing) the iteration's FilteringStats.
  template <segpath::ParallelFor P>
  void render(const RenderScene& scene, std::uint64_t iteration, Stats& stats, const P& parallel) {
    const segpath::FilteringStats f = MethodRun::render(scene, iteration, stats, parallel);
    if (print_stats_) print(iteration, f);
    last_stats_ = f;
  }
  template <segpath::ParallelFor P>
  void iterate(const RenderScene& scene, Stats& stats, const P& parallel) {
    render_and_accumulate(*this, scene, stats, parallel);
  }

  /// The last iteration's counters (segments, bytes per segment, transfer cache), if any.
  [[nodiscard]] const std::optional<segpath::FilteringStats>& last_stats() const noexcept { return last_stats_; }

  /// Throws std::invalid_argument where --passes leaves a pass without pixels or light paths
  /// in `scene` (segpath::filtering::check_passes), before anything renders.
  static void check_passes(const RenderScene& scene, const MethodOptions& o) {
    segpath::filtering::check_passes(scene, filtering_options(o));
  }
  /// The most passes check_passes accepts for `scene` (segpath::filtering::max_passes).
  static std::uint64_t max_passes(const RenderScene& scene, const MethodOptions& o) {
    return segpath::filtering::max_passes(scene, filtering_options(o));
  }

  static constexpr std::optional<segpath::FilteringMode> filtering_mode = Mode;

  /// MVF draws no light paths: no beta. No Russian roulette option.
  [[nodiscard]] static ResolvedSettings resolved(const MethodOptions& o) {
    const segpath::FilteringOptions<T> f = filtering_options(o);
    ResolvedSettings r;
    r.alpha = double(f.alpha);
    if constexpr (Mode != segpath::FilteringMode::mvf) r.beta = double(f.light_path_ratio);
    if constexpr (Mode != segpath::FilteringMode::phf) r.camera_continuation = segpath::filtering::technique_set(f).camera_continuation;
    if (!(f.initial_cell_size > T(0))) r.kernel_in_footprints = segpath::filtering::cell_in_footprints;
    return r;
  }

 private:
  static segpath::FilteringOptions<T> filtering_options(const MethodOptions& o) {
    segpath::FilteringOptions<T> f;  // the library's defaults, but for what the command line set
    f.mode = Mode;
    f.max_length = o.max_length;
    if (o.beta) f.light_path_ratio = T(*o.beta);
    if (o.camera_continuation) f.camera_continuation = T(*o.camera_continuation);
    if (o.radius) f.initial_cell_size = T(*o.radius);
    if (o.alpha) f.alpha = T(*o.alpha);
    f.seed = o.seed;
    f.support = o.support;
    f.bridges = o.bridges;
    f.next_event = o.next_event;
    f.weighting = o.weighting;
    if (o.transfer_cache_mib) f.transfer_cache_bytes = *o.transfer_cache_mib << 20;
    f.pixel_passes = o.passes;
    return f;
  }
  static void print(std::uint64_t iteration, const segpath::FilteringStats& f) {
    std::fprintf(stderr,
                 "iteration %llu: %llu light paths, %llu segments (camera %llu of which %llu at a repeat visit, light %llu of which %llu at a repeat visit, bridge %llu, next-event %llu), %llu clusters, "
                 "%llu factorised, %llu pair evaluations, cell %.4g, %zu B/segment besides the cache, "
                 "cache %.1f MiB (%zu B/segment); seconds: paths %.3f, support %.3f, densities %.3f, "
                 "propagation %.3f, gather %.3f%s\n",
                 static_cast<unsigned long long>(iteration + 1), static_cast<unsigned long long>(f.light_paths),
                 static_cast<unsigned long long>(f.segments),
                 static_cast<unsigned long long>(f.camera_segments), static_cast<unsigned long long>(f.camera_repeat_visit_segments),
                 static_cast<unsigned long long>(f.light_segments),
                 static_cast<unsigned long long>(f.repeat_visit_segments), static_cast<unsigned long long>(f.bridge_segments), static_cast<unsigned long long>(f.next_event_segments),
                 static_cast<unsigned long long>(f.clusters ? f.clusters : f.junctions),
                 static_cast<unsigned long long>(f.factorised_transfer_clusters),
                 static_cast<unsigned long long>(f.pair_evaluations), f.cell_size, f.bytes_per_segment,
                 double(f.transfer_cache_bytes) / double(1 << 20),
                 f.transfer_cache_bytes / std::max<std::size_t>(f.segments, 1), f.paths_seconds, f.support_seconds,
                 f.densities_seconds, f.propagation_seconds, f.gather_seconds,
                 f.passes > 1 ? ("; " + std::to_string(f.passes) + " passes (memory: the largest)").c_str() : "");
  }
  bool print_stats_ = false;
  std::optional<segpath::FilteringStats> last_stats_;
};

/// The light-transport family a filtering method cannot sample in `scene`, if any (a one-line
/// warning for the user, instead of a silently dark image): MVF's camera paths never end on a
/// Dirac light (point light, sun), so without next-event segments (`next_event` false) it
/// samples none of its light, and with them, which do not pass mirrors or glass, the Dirac
/// light's caustics are missing. (PhF's sky paths chain through mirrors and glass.)
inline std::optional<std::string> unsampled_family(std::string_view method, const RenderScene& scene, bool next_event) {
  const auto& light = scene.emitter().get();
  const bool dirac = std::holds_alternative<segpath::PointLight<Color>>(light) ||
                     std::holds_alternative<segpath::DirectionalLight<Color>>(light);
  if (method == "mvf" && dirac && !next_event)
    return std::string("mvf without next-event segments cannot sample a point light or the sun at all (the image renders "
                       "black); leave them on, or use bdpf or phf");
  bool delta_material = false;
  for (std::uint32_t id = 0; id < scene.bsdf().size(); ++id) {
    const auto* m = scene.bsdf().find(id);
    delta_material |= m && (std::holds_alternative<segpath::Mirror<Color>>(*m) || std::holds_alternative<segpath::Dielectric<Color>>(*m));
  }
  if (!delta_material) return std::nullopt;
  if (method == "mvf" && dirac)
    return std::string("mvf cannot sample light from a point light or the sun through mirrors or glass (those caustics "
                       "render dark); bdpf or phf sample it");
  return std::nullopt;
}

/// An option that only some methods read (--radius aside: kernel_check.hpp), and which read it:
/// `read_by` answers from the settings a method resolves (ResolvedSettings) and its filtering
/// mode (none: not segment filtering).
struct MethodSpecificOption {
  std::string_view name;
  bool (*read_by)(const ResolvedSettings&, std::optional<segpath::FilteringMode>);
};

/// Every option that only some methods read: a new one is one line here.
inline constexpr MethodSpecificOption method_specific_options[] = {
    {"--alpha", [](const ResolvedSettings& r, std::optional<segpath::FilteringMode>) { return r.alpha.has_value(); }},
    {"--beta", [](const ResolvedSettings& r, std::optional<segpath::FilteringMode>) { return r.beta.has_value(); }},
    {"--camera-continuation",
     [](const ResolvedSettings& r, std::optional<segpath::FilteringMode>) { return r.camera_continuation.has_value(); }},
    {"--roulette-from", [](const ResolvedSettings& r, std::optional<segpath::FilteringMode>) { return r.roulette_from.has_value(); }},
    {"--support", [](const ResolvedSettings&, std::optional<segpath::FilteringMode> m) { return m.has_value(); }},
    {"--transfer-cache", [](const ResolvedSettings&, std::optional<segpath::FilteringMode> m) { return m.has_value(); }},
    {"--passes", [](const ResolvedSettings&, std::optional<segpath::FilteringMode> m) { return m.has_value(); }},
    // Next-event segments start at camera technique points, which PhF has none of.
    {"--next-event",
     [](const ResolvedSettings&, std::optional<segpath::FilteringMode> m) { return m && *m != segpath::FilteringMode::phf; }},
    // Bridges and the chain weighting are BDPF's.
    {"--bridges",
     [](const ResolvedSettings&, std::optional<segpath::FilteringMode> m) { return m == segpath::FilteringMode::bdpf; }},
    {"--weighting",
     [](const ResolvedSettings&, std::optional<segpath::FilteringMode> m) { return m == segpath::FilteringMode::bdpf; }},
};

/// Every method the renderer offers: adding one is one line here.
using Method = std::variant<PtMethod, LtMethod, VcmMethod<segpath::VcmMode::bdpt>, VcmMethod<segpath::VcmMode::ppm>,
                            VcmMethod<segpath::VcmMode::bpm>, VcmMethod<segpath::VcmMode::vcm>,
                            FilteringMethod<segpath::FilteringMode::mvf>, FilteringMethod<segpath::FilteringMode::phf>,
                            FilteringMethod<segpath::FilteringMode::bdpf>>;

/// The names of the methods, in variant order.
[[nodiscard]] inline std::vector<std::string> method_names() {
  std::vector<std::string> names;
  [&]<std::size_t... I>(std::index_sequence<I...>) {
    (names.emplace_back(std::variant_alternative_t<I, Method>::name), ...);
  }(std::make_index_sequence<std::variant_size_v<Method>>{});
  return names;
}

/// The method called `name`, or nullopt for an unknown name. Throws std::invalid_argument
/// when the options are invalid for it (e.g. LT with max_length < 2).
[[nodiscard]] inline std::optional<Method> make_method(std::string_view name, const MethodOptions& options) {
  std::optional<Method> method;
  [&]<std::size_t... I>(std::index_sequence<I...>) {
    ((!method && name == std::variant_alternative_t<I, Method>::name
          ? void(method.emplace(std::in_place_index<I>, options))
          : void()),
     ...);
  }(std::make_index_sequence<std::variant_size_v<Method>>{});
  return method;
}

/// The settings the method called `name` runs with for these options (its `resolved`), or
/// nullopt for an unknown name.
[[nodiscard]] inline std::optional<ResolvedSettings> resolved_settings(std::string_view name, const MethodOptions& options) {
  std::optional<ResolvedSettings> settings;
  [&]<std::size_t... I>(std::index_sequence<I...>) {
    ((!settings && name == std::variant_alternative_t<I, Method>::name
          ? void(settings = std::variant_alternative_t<I, Method>::resolved(options))
          : void()),
     ...);
  }(std::make_index_sequence<std::variant_size_v<Method>>{});
  return settings;
}

[[nodiscard]] inline std::string_view method_name(const Method& m) noexcept {
  return std::visit([](const auto& x) { return std::remove_cvref_t<decltype(x)>::name; }, m);
}

}  // namespace renderer
