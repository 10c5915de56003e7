// The renderer's methods as iteration-based integrators: each renders one iteration (PT: one
// path per pixel; LT: one light path per pixel's worth of splats) into an accumulation
// image, so the image is the accumulated sum divided by the iteration count whatever the method.
#pragma once

#include "render_scene.hpp"

#include <segpath/algorithms/light_tracer.hpp>
#include <segpath/algorithms/path_tracer.hpp>
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/algorithms/vcm.hpp>
#include <segpath/core/drop.hpp>
#include <segpath/core/framebuffer.hpp>
#include <segpath/core/parallel.hpp>
#include <segpath/core/rng.hpp>

#include <tbb/enumerable_thread_specific.h>

#include <cmath>
#include <cstdio>
#include <cstddef>
#include <cstdint>
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
  segpath::FilteringSupport support = segpath::FilteringSupport::voxel;  ///< filtering: junction support
  bool bridges = false;          ///< bdpf: add bridge segments
  bool next_event = segpath::FilteringOptions<float>{}.next_event;  ///< mvf, bdpf: add next-event segments
  /// bdpf: chain weighting, path-conditioned (unbiased) or the paper's prod 1 / D
  segpath::FilteringWeighting weighting = segpath::FilteringOptions<float>{}.weighting;
  bool print_stats = false;      ///< mvf, phf, bdpf: one line of FilteringStats per iteration on stderr
  std::optional<std::size_t> transfer_cache_mib;  ///< mvf, phf, bdpf: FilteringOptions::transfer_cache_bytes in MiB
};

/// The emitter of a RenderScene by reference: PathTracer copies scene.emitter() once per
/// path, so a copyable view keeps the emitter's tables from being copied.
class EmitterView {
 public:
  explicit EmitterView(const Emitter& e) noexcept : e_(&e) {}
  [[nodiscard]] Color radiance(const segpath::EmissionQuery<T>& q) const noexcept { return e_->radiance(q); }
  [[nodiscard]] std::optional<segpath::EmissionSample<Color>> sample_emission(
      const segpath::EmissionSampleQuery<T>& q) const noexcept {
    return e_->sample_emission(q);
  }
  [[nodiscard]] segpath::EmissionPdf<T> pdf_emission(const segpath::EmissionPdfQuery<T>& q) const noexcept {
    return e_->pdf_emission(q);
  }
  [[nodiscard]] std::optional<segpath::EmitterTowardsSample<Color>> sample_towards(
      const segpath::EmitterTowardsQuery<T>& q) const noexcept {
    return e_->sample_towards(q);
  }
  [[nodiscard]] T pdf_towards(const segpath::EmitterPdfTowardsQuery<T>& q) const noexcept {
    return e_->pdf_towards(q);
  }

 private:
  const Emitter* e_;
};

/// A RenderScene that counts its intersect and visible calls into a counter owned by one
/// task (no atomics; the counts are summed after the parallel loop).
class CountingScene {
 public:
  using Scalar = T;
  using Spectrum = Color;

  CountingScene(const RenderScene& scene, std::uint64_t& rays) noexcept : scene_(&scene), rays_(&rays) {}

  [[nodiscard]] T area() const noexcept { return scene_->area(); }
  [[nodiscard]] std::optional<segpath::AreaSample<T>> sample_area(const segpath::AreaSampleQuery<T>& q) const noexcept {
    return scene_->sample_area(q);
  }
  [[nodiscard]] std::optional<segpath::Hit<T>> intersect(const segpath::IntersectQuery<T>& q) const noexcept {
    ++*rays_;
    return scene_->intersect(q);
  }
  [[nodiscard]] bool visible(const segpath::VisibilityQuery<T>& q) const noexcept {
    ++*rays_;
    return scene_->visible(q);
  }
  [[nodiscard]] const segpath::MaterialSet<Color>& bsdf() const noexcept { return scene_->bsdf(); }
  [[nodiscard]] EmitterView emitter() const noexcept { return EmitterView(scene_->emitter()); }
  [[nodiscard]] const segpath::PinholeCamera<T>& sensor() const noexcept { return scene_->sensor(); }

 private:
  const RenderScene* scene_;
  std::uint64_t* rays_;
};

static_assert(segpath::LightSampledScene<CountingScene>);

namespace detail {

/// The sink of one PT sample: at most one add, or a drop.
struct PixelSink {
  Color value{T(0)};
  bool added = false;
  segpath::DropCounters* drops;
  void add(std::uint32_t, const Color& v) noexcept {
    value += v;
    added = true;
  }
  void drop(segpath::DropReason r) noexcept { drops->add(r); }
};

[[nodiscard]] inline segpath::Rgb<double> to_double(const Color& c) noexcept {
  return {double(c.r), double(c.g), double(c.b)};
}

}  // namespace detail

/// Path tracing with next-event estimation (segpath::PathTracer): one path per pixel per
/// iteration, pixel p of iteration i drawing from Pcg32::for_sample(seed, p, i). Each row is
/// one task, so each pixel's sum is accumulated by one task in iteration order.
class PtMethod {
 public:
  static constexpr std::string_view name = "pt";
  static constexpr std::string_view description = "path tracing with next-event estimation (MIS)";

  // Russian roulette with SmallVCM's rule (core/roulette.hpp) from the third segment on (SmallVCM
  // starts at the first; the third is better at equal time here: docs/figures.md).
  explicit PtMethod(const MethodOptions& o)
      : seed_(o.seed), tracer_(segpath::PathTracerOptions{o.max_length, segpath::MisHeuristic::power, 3}) {}

  template <segpath::ParallelFor P>
  void render_iteration(const RenderScene& scene, std::uint64_t iteration, Accumulator& accumulate, Stats& stats,
                        const P& parallel) {
    const std::uint32_t width = accumulate.width(), height = accumulate.height();
    rows_.assign(height, Stats{});
    parallel(std::size_t(height), [&](std::size_t row) {
      Stats& s = rows_[row];
      const CountingScene counting(scene, s.rays);
      for (std::uint32_t x = 0; x < width; ++x) {
        const std::uint32_t pixel = std::uint32_t(row) * width + x;
        segpath::Pcg32 rng = segpath::Pcg32::for_sample(seed_, pixel, iteration);
        detail::PixelSink sink{Color(T(0)), false, &s.dropped};
        tracer_.estimate(counting, segpath::EstimateQuery{pixel, iteration}, rng, sink);
        ++s.paths;
        if (sink.added) {
          if (segpath::is_finite(sink.value)) accumulate.add(pixel, detail::to_double(sink.value));
          else s.dropped.add(segpath::DropReason::non_finite);
        }
      }
    });
    for (const Stats& s : rows_) stats += s;
  }

 private:
  std::uint64_t seed_;
  segpath::PathTracer<CountingScene> tracer_;
  std::vector<Stats> rows_;
};

/// Light tracing (segpath::LightTracer): N = #pixels light paths per iteration, so one
/// iteration's image is (sum of their splats) / N (N16). The paths are split into
/// `chunk_count` chunks, a number independent of the thread count; each chunk records its
/// splats (segpath::SplatRecorder) and the chunks are applied in order, so the image for a
/// seed is bit-identical for any thread count. Path k of iteration i draws from
/// Pcg32::for_sample(seed ^ stream_salt, k, i), streams disjoint from PT's for the same seed.
class LtMethod {
 public:
  static constexpr std::string_view name = "lt";
  static constexpr std::string_view description = "light tracing (splats to the camera)";
  static constexpr std::size_t chunk_count = 64;
  static constexpr std::uint64_t stream_salt = 0x4c54'0000'0000'0000ULL;

  explicit LtMethod(const MethodOptions& o)
      : seed_(o.seed ^ stream_salt), tracer_(segpath::LightTracerOptions{o.max_length}), recorder_(chunk_count) {}

  template <segpath::ParallelFor P>
  void render_iteration(const RenderScene& scene, std::uint64_t iteration, Accumulator& accumulate, Stats& stats,
                        const P& parallel) {
    const std::uint64_t n = accumulate.pixel_count();
    if (!image_ || image_->pixel_count() != n) image_.emplace(accumulate.width(), accumulate.height());
    image_->clear();
    chunks_.assign(chunk_count, Stats{});
    parallel(chunk_count, [&](std::size_t chunk) {
      Stats& s = chunks_[chunk];
      const CountingScene counting(scene, s.rays);
      auto sink = recorder_.sink(chunk);
      const std::uint64_t begin = n * chunk / chunk_count, end = n * (chunk + 1) / chunk_count;
      for (std::uint64_t k = begin; k < end; ++k) {
        segpath::Pcg32 rng = segpath::Pcg32::for_sample(seed_, k, iteration);
        tracer_.estimate(counting, segpath::EstimateQuery{0, iteration * n + k}, rng, sink);
      }
      s.paths += end - begin;
    });
    for (const Stats& s : chunks_) stats += s;
    recorder_.apply(*image_, stats.dropped);
    const double inv_n = 1.0 / double(n);
    for (std::uint32_t p = 0; p < image_->pixel_count(); ++p) accumulate.add(p, detail::to_double((*image_)[p]) * inv_n);
  }

 private:
  std::uint64_t seed_;
  segpath::LightTracer<CountingScene> tracer_;
  segpath::SplatRecorder<Color> recorder_;
  std::optional<segpath::Framebuffer<Color>> image_;
  std::vector<Stats> chunks_;
};

/// A RenderScene counting its intersect and visible calls per thread (for the methods that
/// parallelise internally); the total is read after the iteration.
class ThreadCountingScene {
 public:
  using Scalar = T;
  using Spectrum = Color;

  explicit ThreadCountingScene(const RenderScene& scene) noexcept : scene_(&scene) {}

  [[nodiscard]] T area() const noexcept { return scene_->area(); }
  [[nodiscard]] std::optional<segpath::AreaSample<T>> sample_area(const segpath::AreaSampleQuery<T>& q) const noexcept {
    return scene_->sample_area(q);
  }
  [[nodiscard]] std::optional<segpath::Hit<T>> intersect(const segpath::IntersectQuery<T>& q) const noexcept {
    ++rays_.local();
    return scene_->intersect(q);
  }
  [[nodiscard]] bool visible(const segpath::VisibilityQuery<T>& q) const noexcept {
    ++rays_.local();
    return scene_->visible(q);
  }
  [[nodiscard]] const segpath::MaterialSet<Color>& bsdf() const noexcept { return scene_->bsdf(); }
  [[nodiscard]] const Emitter& emitter() const noexcept { return scene_->emitter(); }
  [[nodiscard]] const segpath::PinholeCamera<T>& sensor() const noexcept { return scene_->sensor(); }

  /// The rays counted since the last call, and reset.
  std::uint64_t take_rays() const {
    std::uint64_t total = 0;
    for (auto& r : rays_) total += std::exchange(r, 0);
    return total;
  }

 private:
  const RenderScene* scene_;
  mutable tbb::enumerable_thread_specific<std::uint64_t> rays_{0};
};

static_assert(segpath::LightSampledScene<ThreadCountingScene>);

/// The average pixel footprint on the first surface hit (distance times the side of a pixel's
/// solid angle), from the pixel centres of every 7th pixel: the unit of the paper's kernel
/// size ("initial support ~ 4x the average pixel footprint").
[[nodiscard]] inline double pixel_footprint(const RenderScene& scene) {
  const auto& camera = scene.sensor();
  double sum = 0;
  std::uint64_t count = 0;
  for (std::uint32_t p = 0; p < camera.pixel_count(); p += 7) {
    const auto ray = camera.sample_ray(segpath::SensorSampleQuery<T>{p, segpath::Vec2<T>(T(0.5)), segpath::Vec2<T>(T(0.5))});
    if (!ray || !(ray->pdf_direction > T(0))) continue;
    const auto hit = scene.intersect(segpath::IntersectQuery<T>{segpath::Ray<T>{ray->origin.position, ray->direction}});
    if (!hit) continue;
    sum += double(hit->distance) / std::sqrt(double(ray->pdf_direction));
    ++count;
  }
  return count ? sum / double(count) : 1e-2;
}

namespace detail {

/// Adds a float iteration image to the double accumulator.
inline void accumulate_image(const segpath::Framebuffer<Color>& image, Accumulator& accumulate) {
  for (std::uint32_t p = 0; p < image.pixel_count(); ++p) accumulate.add(p, to_double(image[p]));
}

}  // namespace detail

/// The VCM family's default initial merge radius in pixel footprints: 2, the best geometric mean
/// of relMSE over the four boxes at 10 s of a sweep over 0.5, 1, 2 and 4 (docs/figures.md).
inline constexpr double vcm_radius_in_footprints = 2.0;

/// BDPT, PPM, BPM and VCM (segpath::VertexConnectionMerging, one implementation with modes):
/// one camera path per pixel and beta x #pixels light paths per iteration; the merge radius
/// starts at --radius (default: vcm_radius_in_footprints x the average pixel footprint) and
/// shrinks by --alpha.
template <segpath::VcmMode Mode>
class VcmMethod {
 public:
  static constexpr std::string_view name = segpath::to_string(Mode);
  static constexpr std::string_view description =
      Mode == segpath::VcmMode::bdpt  ? "bidirectional path tracing (all connections, MIS)"
      : Mode == segpath::VcmMode::ppm ? "progressive photon mapping (first non-specular camera hit)"
      : Mode == segpath::VcmMode::bpm ? "bidirectional photon mapping (merging at every camera vertex, MIS)"
                                      : "vertex connection and merging (BDPT + BPM under one MIS)";

  explicit VcmMethod(const MethodOptions& o) : options_(o) {
    // Validate now (a clear error before rendering); the radius is fixed at the first iteration.
    (void)segpath::VertexConnectionMerging<ThreadCountingScene>(vcm_options(o.radius.value_or(1.0)));
  }

  template <segpath::ParallelFor P>
  void render_iteration(const RenderScene& scene, std::uint64_t iteration, Accumulator& accumulate, Stats& stats,
                        const P& parallel) {
    if (!vcm_) vcm_.emplace(vcm_options(options_.radius ? *options_.radius : vcm_radius_in_footprints * pixel_footprint(scene)));
    if (!image_ || image_->pixel_count() != accumulate.pixel_count()) image_.emplace(accumulate.width(), accumulate.height());
    image_->clear();
    const ThreadCountingScene counting(scene);
    vcm_->render_iteration(counting, iteration, *image_, stats.dropped, parallel);
    stats.rays += counting.take_rays();
    stats.paths += accumulate.pixel_count();
    detail::accumulate_image(*image_, accumulate);
  }

 private:
  segpath::VcmOptions vcm_options(double radius) const {
    segpath::VcmOptions v;  // the library's defaults, but for what the command line set
    v.mode = Mode;
    v.max_length = options_.max_length;
    v.initial_radius = radius;
    if (options_.alpha) v.alpha = *options_.alpha;
    if (options_.beta) v.light_path_factor = *options_.beta;
    v.seed = options_.seed;
    // Russian roulette from the first scattering, SmallVCM's schedule (docs/figures.md).
    v.roulette_from = 1;
    return v;
  }
  MethodOptions options_;
  std::optional<segpath::VertexConnectionMerging<ThreadCountingScene>> vcm_;
  std::optional<segpath::Framebuffer<Color>> image_;
};

/// MVF, PhF and BDPF (segpath::SegmentFiltering): approximate sequential segments pooled per
/// iteration, voxel clusters (or disks of the same area, --support disk) of --radius (default 4x
/// the average pixel footprint) shrinking by --alpha (default 0.67), beta x #pixels light paths
/// (default 1), MMIS weights and propagation (the paper's Algorithm 1); BDPF optionally with
/// bridge segments (--bridges). MVF and BDPF draw next-event segments by default (the library's
/// FilteringOptions::next_event; --no-next-event turns them off; PhF has no camera technique
/// points): on box 1 they cut BDPF's relMSE at equal time by a quarter (docs/figures.md).
template <segpath::FilteringMode Mode>
class FilteringMethod {
 public:
  static constexpr std::string_view name = segpath::to_string(Mode);
  static constexpr std::string_view description =
      Mode == segpath::FilteringMode::mvf   ? "multi-vertex path filtering (camera segments, propagation)"
      : Mode == segpath::FilteringMode::phf ? "photon filtering (light segments, propagation)"
                                            : "bidirectional path filtering, the paper's method (both sides, MMIS, propagation)";

  explicit FilteringMethod(const MethodOptions& o) : filter_(filtering_options(o)), print_stats_(o.print_stats) {}

  template <segpath::ParallelFor P>
  void render_iteration(const RenderScene& scene, std::uint64_t iteration, Accumulator& accumulate, Stats& stats,
                        const P& parallel) {
    const ThreadCountingScene counting(scene);
    if (!initial_cell_) initial_cell_ = filter_.initial_cell_size(counting);
    if (!image_ || image_->pixel_count() != accumulate.pixel_count()) image_.emplace(accumulate.width(), accumulate.height());
    image_->clear();
    const segpath::FilteringStats f = filter_.render_iteration_at_cell(
        counting, iteration, filter_.cell_size(*initial_cell_, iteration), *image_, stats.dropped, parallel);
    if (print_stats_) print(iteration, f);
    last_stats_ = f;
    stats.rays += counting.take_rays();
    stats.paths += accumulate.pixel_count();
    detail::accumulate_image(*image_, accumulate);
  }

  /// The last iteration's counters (segments, bytes per segment, transfer cache), if any.
  [[nodiscard]] const std::optional<segpath::FilteringStats>& last_stats() const noexcept { return last_stats_; }

 private:
  static segpath::FilteringOptions<T> filtering_options(const MethodOptions& o) {
    segpath::FilteringOptions<T> f;  // the library's defaults, but for what the command line set
    f.mode = Mode;
    f.max_length = o.max_length;
    if (o.beta) f.light_path_ratio = T(*o.beta);
    if (o.radius) f.initial_cell_size = T(*o.radius);
    if (o.alpha) f.alpha = T(*o.alpha);
    f.seed = o.seed;
    f.support = o.support;
    f.bridges = o.bridges;
    f.next_event = o.next_event;
    f.weighting = o.weighting;
    if (o.transfer_cache_mib) f.transfer_cache_bytes = *o.transfer_cache_mib << 20;
    return f;
  }
  static void print(std::uint64_t iteration, const segpath::FilteringStats& f) {
    std::fprintf(stderr,
                 "iteration %llu: %llu segments (camera %llu, light %llu, bridge %llu, next-event %llu), %llu clusters, "
                 "%llu factorised, %llu pair evaluations, cell %.4g, %zu B/segment, cache %.1f MiB; seconds: paths %.3f, support %.3f, "
                 "densities %.3f, propagation %.3f, gather %.3f\n",
                 static_cast<unsigned long long>(iteration + 1), static_cast<unsigned long long>(f.segments),
                 static_cast<unsigned long long>(f.camera_segments), static_cast<unsigned long long>(f.light_segments),
                 static_cast<unsigned long long>(f.bridge_segments), static_cast<unsigned long long>(f.next_event_segments),
                 static_cast<unsigned long long>(f.clusters ? f.clusters : f.junctions),
                 static_cast<unsigned long long>(f.factorised_transfer_clusters),
                 static_cast<unsigned long long>(f.pair_evaluations), f.cell_size, f.bytes_per_segment,
                 double(f.transfer_cache_bytes) / double(1 << 20), f.paths_seconds, f.support_seconds, f.densities_seconds,
                 f.propagation_seconds, f.gather_seconds);
  }
  segpath::SegmentFiltering<ThreadCountingScene> filter_;
  bool print_stats_ = false;
  std::optional<T> initial_cell_;
  std::optional<segpath::Framebuffer<Color>> image_;
  std::optional<segpath::FilteringStats> last_stats_;
};

/// The light-transport family a filtering method cannot sample in `scene`, if any (a one-line
/// warning for the user, instead of a silently dark image): MVF's camera paths never end on a
/// Dirac light (point light, sun) and its next-event segments do not pass mirrors or glass, so
/// the Dirac light's caustics are missing. (PhF's sky paths chain through mirrors and glass.)
inline std::optional<std::string> unsampled_family(std::string_view method, const RenderScene& scene) {
  bool delta_material = false;
  for (std::uint32_t id = 0; id < scene.bsdf().size(); ++id) {
    const auto* m = scene.bsdf().find(id);
    delta_material |= m && (std::holds_alternative<segpath::Mirror<Color>>(*m) || std::holds_alternative<segpath::Dielectric<Color>>(*m));
  }
  if (!delta_material) return std::nullopt;
  const auto& light = scene.emitter().get();
  const bool dirac = std::holds_alternative<segpath::PointLight<Color>>(light) ||
                     std::holds_alternative<segpath::DirectionalLight<Color>>(light);
  if (method == "mvf" && dirac)
    return std::string("mvf cannot sample light from a point light or the sun through mirrors or glass (those caustics "
                       "render dark); bdpf or phf sample it");
  return std::nullopt;
}

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

[[nodiscard]] inline std::string_view method_name(const Method& m) noexcept {
  return std::visit([](const auto& x) { return std::remove_cvref_t<decltype(x)>::name; }, m);
}

}  // namespace renderer
