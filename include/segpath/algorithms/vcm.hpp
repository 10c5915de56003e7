// Segment BDPT, progressive and bidirectional photon mapping, and vertex connection and
// merging (SPEC 1.9) as modes of one SmallVCM-style implementation: sequential camera and
// light subpaths (N29-N31), Dirac bridges (N34) and uniform-disk junctions (N19) between them,
// weighted by multi-technique MIS (N36) through Georgiev et al. 2012's recursive quantities.
#pragma once

#include "segpath/algorithms/vcm/options.hpp"
#include "segpath/algorithms/vcm/weights.hpp"
#include "segpath/concepts/bsdf.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/block_list.hpp"
#include "segpath/core/drop.hpp"
#include "segpath/core/format.hpp"
#include "segpath/core/framebuffer.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/rng.hpp"
#include "segpath/core/roulette.hpp"
#include "segpath/core/scratch_vector.hpp"
#include "segpath/integrand/contribution.hpp"
#include "segpath/kernels/dirac.hpp"
#include "segpath/kernels/hash_grid.hpp"
#include "segpath/kernels/progressive_radius.hpp"
#include "segpath/samplers/bridge.hpp"
#include "segpath/samplers/light_next.hpp"
#include "segpath/samplers/light_start.hpp"
#include "segpath/samplers/next_segment.hpp"
#include "segpath/samplers/sensor_start.hpp"
#include "segpath/sensors/pixel_footprint.hpp"
#include "segpath/weights/mis.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace segpath {

/// The bidirectional methods of SPEC 1.9 on any LightSampledScene, one iteration at a time.
///
/// Protocol of render_iteration (iteration i = 0, 1, ...):
///  1. N = light_path_count(pixels) light subpaths are traced with the light-start sampler (N30)
///     and Dirac-kernel light-side successors; their surface ends are stored, and in bdpt/vcm
///     each non-delta end is bridged to the sensor (t = 1) and splatted (1/N each);
///  2. bpm/ppm/vcm: the stored ends enter a HashGrid for radius r_i (ProgressiveRadius);
///  3. one camera subpath per pixel (sensor-start sampler N29, Dirac-kernel successors N31):
///     at every end the emitted radiance (s = 0), and at every non-delta end a next-event bridge
///     (s = 1), bridges to the ends of light subpath (pixel mod N) and merges with the stored
///     ends within r_i whose normal agrees (cosine >= 1/2, as DiskKernel's default support);
///  4. splats are applied in chunk order, so an image is bit-identical for any ParallelFor.
/// `image` receives ONE iteration's estimate; average over iterations.
///
/// Assumptions: the sensor is a Dirac in position (a pinhole or a probe: no path reaches it by
/// scattering); a `direction` light end is taken as a Dirac (a sun) when the emitter gives no
/// emission density to a direction 1e-3 away from it, which is exact for one distant emitter
/// per LightSet; a material whose sampled lobe was a delta is treated as specular at that end
/// (exact for purely specular or purely non-specular materials; ppm with a BSDF that has
/// `is_delta` is exact for mixed ones too: it gathers wherever the material has a non-delta lobe
/// and follows a sampled delta lobe on). Paths of one segment (the
/// sensor seeing an emitter) are left to the camera subpath alone, as in SmallVCM.
/// Scratch storage lives in the object and is reused across iterations: one render_iteration
/// at a time per object.
template <LightSampledScene Scn>
class VertexConnectionMerging : public VcmWeights<Scn> {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  using Vertex = VcmVertex<S>;
  using Photon = VcmPhoton<S>;
  using Iteration = VcmIteration<T>;
  using MisState = VcmMisState<T>;
  // The MIS weight of each technique (vcm/weights.hpp).
  using VcmWeights<Scn>::emission_weight;
  using VcmWeights<Scn>::nee_weight;
  using VcmWeights<Scn>::connection_weight;
  using VcmWeights<Scn>::camera_connection_weight;
  using VcmWeights<Scn>::merge_weight;
  /// Work chunks of the light pass and of the camera pass (fixed: never the thread count).
  static constexpr std::size_t chunk_count = 64;
  /// Normal agreement of a merge (DiskKernel's default support).
  static constexpr T merge_min_normal_cosine = T(0.5);

  explicit VertexConnectionMerging(VcmOptions options = {})
      : options_(validated(options)) {}

  [[nodiscard]] const VcmOptions& options() const noexcept { return options_; }

  /// Bytes of the scratch that grow with the light paths, at their sizes after the last
  /// iteration: each light subpath's ends (kept twice: per chunk and in path order), its first
  /// end and count, the photons and their grid (HashGrid::item_bytes), and the splats to the
  /// camera that the iteration recorded before it applied them. Proportional to the light paths
  /// of an iteration, so a renderer can scale a small render's to a larger one's. Not counted:
  /// unused capacity and what does not grow with the paths (fixed_scratch_bytes).
  [[nodiscard]] std::size_t light_path_bytes() const noexcept {
    const Scratch& sc = scratch_;
    std::size_t bytes = sc.light_vertices.size() * sizeof(Vertex);
    bytes += (sc.light_first.size() + sc.light_counts.size() + sc.photons.size()) * sizeof(std::uint32_t);
    for (const auto& ends : sc.chunk_vertices) bytes += ends.size() * sizeof(Vertex);
    return bytes + sc.grid.item_bytes() + sc.splats.applied_bytes();
  }
  /// Bytes of the scratch that do not grow with the light paths, at most: per chunk, one path
  /// buffer of max_length - 1 ends and the unfilled rest of its last block of ends and of splats.
  [[nodiscard]] std::size_t fixed_scratch_bytes() const noexcept {
    return chunk_count * ((options_.max_length - 1 + ChunkEnds::block_size) * sizeof(Vertex) +
                          SplatList<S>::block_size * sizeof(typename SplatList<S>::value_type));
  }

  /// The merge radius of every iteration: none for bdpt; else from initial_radius (or
  /// radius_in_footprints(mode) pixel footprints when it is 0), shrinking by ProgressiveRadius.
  [[nodiscard]] KernelSchedule<T> kernel_schedule(const Scn& scene) const {
    if (options_.mode == VcmMode::bdpt) return {};
    const T initial = options_.initial_radius > 0 ? T(options_.initial_radius)
                                                  : T(radius_in_footprints(options_.mode)) * pixel_footprint(scene, T(5e-3));
    return KernelSchedule<T>(initial, T(options_.alpha));
  }

  /// N_light = max(1, round(light_path_factor * pixels)).
  [[nodiscard]] std::uint32_t light_path_count(std::uint32_t pixels) const noexcept {
    const double n = std::round(options_.light_path_factor * double(pixels));
    return n < 1 ? 1u : n > 4e9 ? 4000000000u : static_cast<std::uint32_t>(n);
  }

  /// The iteration constants for a radius and a light-subpath count.
  [[nodiscard]] Iteration iteration_constants(const Scn& scene, T radius, std::uint32_t light_paths) const noexcept {
    Iteration it;
    it.radius = radius;
    it.light_paths = T(light_paths);
    it.heuristic = options_.heuristic;
    it.connect = options_.mode == VcmMode::bdpt || options_.mode == VcmMode::vcm;
    it.merge = options_.mode != VcmMode::bdpt;
    it.ppm = options_.mode == VcmMode::ppm;
    it.roulette = options_.roulette_from == 1;
    const T eta = pi<T> * radius * radius * it.light_paths;
    it.merge_normalization = T(1) / eta;
    it.vm_factor = it.merge ? mis(it, eta) : T(0);
    it.vc_factor = it.connect ? mis(it, T(1) / eta) : T(0);
    it.camera_connectable = it.connect && sensor_has_direction_density(scene);
    return it;
  }

  /// The largest MIS factor heuristic(eta) or heuristic(1 / eta) an iteration accepts: it
  /// multiplies every partial sum of the MIS recursion, which must keep room in T for the
  /// density ratios of a whole path (14 orders of magnitude; float: 3.4e24).
  static constexpr T max_mis_factor = std::numeric_limits<T>::max() * T(1e-14);

  /// Throws std::invalid_argument where VCM's merge radius and light-path count give an MIS
  /// factor above max_mis_factor. Beyond it the partial sums overflow and whole techniques'
  /// weights fall to 0 (in float at 32 x 32, radius 1e-10 on box 1 rendered 2 % dark, 1e-19 26 %),
  /// so the radius is refused instead, with the range that works. BPM and PPM merge only: their
  /// weights do not depend on eta = pi r^2 N, but the merge's normalisation 1 / eta does, and is
  /// refused beyond the same factor (r^2 underflowed to 0 or overflowed: a black image).
  void check_mis_range(const Iteration& it) const {
    if (!it.merge) return;
    const bool weights = it.connect;  // VCM: heuristic(eta) and heuristic(1 / eta)
    if (weights ? it.vm_factor <= max_mis_factor && it.vc_factor <= max_mis_factor
                : it.merge_normalization >= T(1) / max_mis_factor && it.merge_normalization <= max_mis_factor)
      return;
    // heuristic(eta) <= M and heuristic(1 / eta) <= M: eta in [1 / m, m], m = M or sqrt(M).
    const double m = weights && options_.heuristic == MisHeuristic::power ? std::sqrt(double(max_mis_factor)) : double(max_mis_factor);
    const double per_radius2 = std::numbers::pi * double(it.light_paths);
    const auto number = [](double x) { return format_number(x, 3); };
    throw std::invalid_argument("segpath::VertexConnectionMerging: merge radius " + number(double(it.radius)) + " with " +
                                std::to_string(std::uint64_t(it.light_paths)) + " light paths puts " +
                                (weights ? "VCM's MIS weights" : "the merge's normalisation 1 / (pi r^2 N)") +
                                " out of the scalar type's range; use a radius from " + number(std::sqrt(1 / (m * per_radius2))) +
                                " to " + number(std::sqrt(m / per_radius2)));
  }

  /// Adds one iteration's estimate to `image` (image.pixel_count() == sensor pixel count).
  template <ParallelFor P = SerialFor>
  void render_iteration(const Scn& scene, std::uint64_t iteration, Framebuffer<S>& image, DropCounters& drops,
                        const P& parallel_for = {}) const {
    render_iteration_at(scene, iteration, kernel_schedule(scene).at(iteration), image, drops, parallel_for);
  }

  /// render_iteration with an explicit merge radius (e.g. a schedule computed once, or a fixed
  /// radius to measure kernel bias); bdpt ignores it.
  template <ParallelFor P = SerialFor>
  void render_iteration_at(const Scn& scene, std::uint64_t iteration, T radius, Framebuffer<S>& image,
                           DropCounters& drops, const P& parallel_for = {}) const {
    const std::uint32_t pixels = scene.sensor().pixel_count();
    if (image.pixel_count() != pixels)
      throw std::invalid_argument("segpath::VertexConnectionMerging: the image has " +
                                  std::to_string(image.pixel_count()) + " pixels, the sensor " +
                                  std::to_string(pixels));
    if (options_.mode == VcmMode::bdpt) radius = T(1);  // no merging: the radius enters no weight
    if (!(radius > T(0)) || !std::isfinite(radius))
      throw std::invalid_argument("segpath::VertexConnectionMerging: radius must be finite and > 0, got " +
                                  format_number(double(radius)));
    const std::uint32_t n = light_path_count(pixels);
    const std::size_t stride = options_.max_length - 1;
    if (double(n) * double(stride) >= double(std::numeric_limits<std::uint32_t>::max()))
      throw std::invalid_argument("segpath::VertexConnectionMerging: too many light-subpath ends per iteration");
    const Iteration it = iteration_constants(scene, radius, n);
    check_mis_range(it);
    Scratch& sc = scratch_;
    sc.splats.clear();  // what an iteration that threw left
    sc.light_first.assign(n, 0);
    sc.light_counts.assign(n, 0);
    sc.light_vertices.clear();

    if ((it.connect || it.merge) && stride > 0) {
      // Each chunk traces into one path's buffer and appends the ends it got to its own list;
      // the lists are then laid end to end, so memory follows the ends traced (roulette makes
      // most paths far shorter than max_length) and stays in path order.
      const std::size_t chunks = std::min<std::size_t>(chunk_count, n);
      sc.chunk_vertices.resize(chunks);
      sc.path_buffers.resize(chunks);
      parallel_for(chunks, [&](std::size_t c) {
        auto sink = sc.splats.sink(c);
        ChunkEnds& ends = sc.chunk_vertices[c];
        std::vector<Vertex>& buffer = sc.path_buffers[c];
        ends.clear();
        buffer.resize(stride);
        const std::size_t begin = c * n / chunks, end = (c + 1) * n / chunks;
        for (std::size_t i = begin; i < end; ++i) {
          Pcg32 rng = Pcg32::for_sample(options_.seed ^ light_salt, i, iteration);
          const std::uint32_t count = trace_light_subpath(scene, it, rng, std::span<Vertex>(buffer.data(), stride));
          sc.light_first[i] = static_cast<std::uint32_t>(ends.size());
          sc.light_counts[i] = count;
          for (std::uint32_t j = 0; j < count; ++j) ends.push_back(buffer[j]);
          if (!it.camera_connectable) continue;
          for (std::uint32_t j = 0; j < count; ++j)
            if (!buffer[j].specular) connect_to_camera(scene, it, buffer[j], rng, sink);
        }
      });
      std::vector<std::size_t> base(chunks + 1, 0);
      for (std::size_t c = 0; c < chunks; ++c) base[c + 1] = base[c] + sc.chunk_vertices[c].size();
      resize_for_overwrite(sc.light_vertices, base[chunks]);
      parallel_for(chunks, [&](std::size_t c) {
        sc.chunk_vertices[c].copy_to(sc.light_vertices.begin() + std::ptrdiff_t(base[c]));
        for (std::size_t i = c * n / chunks; i < (c + 1) * n / chunks; ++i) sc.light_first[i] += static_cast<std::uint32_t>(base[c]);
      });
    }
    if (it.merge) {
      sc.photons.clear();
      reserve_without_copy(sc.photons, sc.light_vertices.size());
      for (std::size_t id = 0; id < sc.light_vertices.size(); ++id)
        if (!sc.light_vertices[id].specular && sc.light_vertices[id].point.kind == PointKind::surface)
          sc.photons.push_back(static_cast<std::uint32_t>(id));
      sc.grid.build(
          sc.photons.size(), radius, [&](std::size_t i) { return std::optional(sc.light_vertices[sc.photons[i]].point.position); },
          [&](std::size_t i) { return Photon::of(sc.light_vertices[sc.photons[i]]); }, parallel_for);
    }
    const std::size_t chunks = std::min<std::size_t>(chunk_count, pixels);
    sc.camera_drops.assign(chunks, DropCounters{});
    parallel_for(chunks, [&](std::size_t c) {
      const std::size_t begin = c * pixels / chunks, end = (c + 1) * pixels / chunks;
      for (std::size_t p = begin; p < end; ++p) {
        Pcg32 rng = Pcg32::for_sample(options_.seed, p, iteration);
        image[std::uint32_t(p)] += camera_path(scene, it, std::uint32_t(p), n, rng, sc.camera_drops[c]);
      }
    });
    sc.splats.apply(image, drops);
    for (const DropCounters& d : sc.camera_drops) drops += d;
  }

  // ---- subpaths ----------------------------------------------------------------------------

  /// Traces one light subpath into `out` (at most out.size() ends, each with length <=
  /// max_length - 1) and returns the number of ends written. Ends are the x of its segments,
  /// in order from the light.
  template <UniformSource<T> R>
  std::uint32_t trace_light_subpath(const Scn& scene, const Iteration& it, R& rng, std::span<Vertex> out) const noexcept {
    if (out.empty()) return 0;
    auto start = light_start_.sample(scene, {}, rng);
    if (!start) return 0;
    MisState state;
    if (!light_first(scene, it, start->segment.y, start->segment.x, start->direction, state)) return 0;
    Segment<T> segment = start->segment;
    Vec3<T> direction = start->direction;
    out[0] = Vertex{segment.x, direction, start->weight, state, 1, false};
    std::uint32_t count = 1;
    while (count < out.size() && out[count - 1].length + 1 < options_.max_length) {
      Vertex& v = out[count - 1];
      if (v.point.kind != PointKind::surface) break;
      const auto next = light_next_.sample(scene, {segment, direction}, rng);
      if (!next) break;
      // ppm stores a photon wherever its camera ends gather (ppm_gathers), whichever lobe the
      // light subpath goes on through.
      v.specular = it.ppm ? !ppm_gathers(scene, v.point, next) : next->delta;
      if (!it.ppm) {  // ppm's merges are unweighted: no MIS state to carry
        if (!scatter_light(scene, it, state, v, -next->direction, next->delta)) break;
        if (!arrive(it, state, v.point, next->segment.x, next->direction)) break;
      }
      S throughput = v.throughput * next->weight;
      if (!survives(v.length, *next, throughput, rng) || is_black(throughput)) break;
      out[count] = Vertex{next->segment.x, next->direction, throughput, state, v.length + 1, false};
      ++count;
      segment = next->segment;
      direction = next->direction;
    }
    // Only the last end can have light arriving from behind a one-sided surface (the sun's and
    // the sky's rays on the outside of a closed box; every earlier end scattered). It lights
    // nothing there (HasScattersFrom): connections through it evaluate its BSDF, 0; merges take
    // it only at camera ends within 60 degrees of its normal, where the light is behind as well
    // on a flat surface (on a curved one, light leaking through it). It is not kept.
    if (const Vertex& last = out[count - 1];
        last.point.kind == PointKind::surface && !scatters_from<S>(scene.bsdf(), last.point, last.to_previous))
      --count;
    return count;
  }

  /// The camera-subpath ends along explicit points (tests and diagnostics): points[0] is the
  /// sensor end of the first segment, out[i - 1] receives the end at points[i] with its MIS
  /// quantities exactly as a traced subpath through these points would carry them
  /// (throughput 1). Returns the number of ends written.
  std::size_t camera_vertices(const Scn& scene, const Iteration& it, std::span<const SurfacePoint<T>> points,
                              std::span<Vertex> out) const noexcept {
    if (points.size() < 2) return 0;
    MisState state = camera_start(it, scene.sensor().pdf(SensorQuery<T>{points[0], Segment<T>{points[0], points[1]}.direction()}).direction);
    std::size_t count = 0;
    for (std::size_t i = 1; i < points.size() && count < out.size(); ++i) {
      const Vec3<T> d = Segment<T>{points[i - 1], points[i]}.direction();
      if (i >= 2 && !scatter_camera(scene, it, state, out[count - 1], d, false)) break;
      if (!arrive(it, state, points[i - 1], points[i], d)) break;
      out[count] = Vertex{points[i], -d, S(T(1)), state, std::uint32_t(i), i == 1};
      ++count;
    }
    return count;
  }

  /// The light-subpath ends that the last render_iteration stored (in light-path order), which
  /// its connections and merges read; for tests and diagnostics.
  [[nodiscard]] std::span<const Vertex> light_ends() const noexcept { return scratch_.light_vertices; }

  /// The light-subpath ends along explicit points: points[0] is the light end y, out[i - 1]
  /// the end at points[i] (throughput 1). Returns the number of ends written.
  std::size_t light_vertices(const Scn& scene, const Iteration& it, std::span<const SurfacePoint<T>> points,
                             std::span<Vertex> out) const noexcept {
    if (points.size() < 2 || out.empty()) return 0;
    MisState state;
    const Vec3<T> d0 = Segment<T>{points[1], points[0]}.direction();
    if (!light_first(scene, it, points[0], points[1], d0, state)) return 0;
    out[0] = Vertex{points[1], d0, S(T(1)), state, 1, false};
    std::size_t count = 1;
    for (std::size_t i = 2; i < points.size() && count < out.size(); ++i) {
      const Vec3<T> d = Segment<T>{points[i], points[i - 1]}.direction();
      if (!scatter_light(scene, it, state, out[count - 1], -d, false)) break;
      if (!arrive(it, state, points[i - 1], points[i], d)) break;
      out[count] = Vertex{points[i], d, S(T(1)), state, std::uint32_t(i), false};
      ++count;
    }
    return count;
  }

 private:
  using VcmWeights<Scn>::mis;
  using VcmWeights<Scn>::reciprocal;
  using VcmWeights<Scn>::continuation;
  using VcmWeights<Scn>::roulette_f;
  using VcmWeights<Scn>::camera_start;
  using VcmWeights<Scn>::light_first;
  using VcmWeights<Scn>::arrive;
  using VcmWeights<Scn>::scatter;
  using VcmWeights<Scn>::scatter_camera;
  using VcmWeights<Scn>::scatter_light;
  static constexpr std::uint64_t light_salt = 0x6c69676874ULL;

  /// One chunk's light-subpath ends, in blocks of ~23 KB (float) that never move and are kept
  /// from iteration to iteration (core/block_list.hpp): no doubling, no outgrown buffers.
  using ChunkEnds = BlockList<Vertex, 256>;
  struct Scratch {
    std::vector<Vertex> light_vertices;                  ///< every light subpath's ends, path after path
    std::vector<std::uint32_t> light_first, light_counts;  ///< per light subpath: its first end there, its count
    std::vector<ChunkEnds> chunk_vertices;               ///< the ends each chunk traced
    std::vector<std::vector<Vertex>> path_buffers;        ///< per chunk: one subpath's ends while tracing
    std::vector<std::uint32_t> photons;
    HashGrid<T, Photon> grid;  ///< the photons' merging state, in cell order
    SplatRecorder<S> splats{chunk_count};
    std::vector<DropCounters> camera_drops;
  };

  static VcmOptions validated(const VcmOptions& o) {
    const auto fail = [](const std::string& what) {
      throw std::invalid_argument("segpath::VertexConnectionMerging: " + what);
    };
    // Enumerations cast from a number out of their range.
    if (o.mode > VcmMode::vcm || o.heuristic > MisHeuristic::power)
      fail("mode or heuristic out of its enumeration's range (" + std::to_string(int(o.mode)) + ", " +
           std::to_string(int(o.heuristic)) + ")");
    if (o.max_length < 1) fail("max_length must be >= 1, got 0");
    if (!(o.initial_radius >= 0) || !std::isfinite(o.initial_radius) || !std::isfinite(T(o.initial_radius)) ||
        (o.initial_radius > 0 && !(T(o.initial_radius) > T(0))))
      fail("initial_radius must be finite and >= 0 (0: automatic), got " + format_number(double(o.initial_radius)));
    if (!(o.alpha > 0 && o.alpha < 1)) fail("alpha must lie in (0, 1), got " + format_number(double(o.alpha)));
    if (!(o.light_path_factor > 0) || !std::isfinite(o.light_path_factor))
      fail("light_path_factor must be finite and > 0, got " + format_number(double(o.light_path_factor)));
    return o;
  }

  /// Whether the sensor's rays for a pixel depend on the position in the pixel (a pinhole)
  /// or not (a probe, a Dirac in direction that no bridge can hit).
  [[nodiscard]] static bool sensor_has_direction_density(const Scn& scene) noexcept {
    const auto a = scene.sensor().sample_ray(SensorSampleQuery<T>{0, Vec2<T>(T(0.5)), Vec2<T>(T(0.25))});
    const auto b = scene.sensor().sample_ray(SensorSampleQuery<T>{0, Vec2<T>(T(0.5)), Vec2<T>(T(0.75))});
    return a && b && a->direction != b->direction;
  }

  /// Whether the BSDF says the point is Lambertian (HasLambertianAlbedo), so it has no delta
  /// lobe: ppm gathers there without sampling (and tracing) a next segment it would not follow.
  [[nodiscard]] static bool has_no_delta_lobe(const Scn& scene, const SurfacePoint<T>& p) noexcept {
    if constexpr (HasLambertianAlbedo<std::remove_cvref_t<decltype(scene.bsdf())>, S>)
      return scene.bsdf().lambertian_albedo(p).has_value();
    else return false;
  }
  /// Whether ppm gathers at camera end p, whose next segment was sampled as `next`: where the
  /// BSDF has a non-delta lobe (HasIsDelta; exact for mixed materials too, which ppm then also
  /// follows through their delta lobes), else where the sampled lobe was not a delta.
  template <class Next>
  [[nodiscard]] static bool ppm_gathers(const Scn& scene, const SurfacePoint<T>& p, const Next& next) noexcept {
    if constexpr (HasIsDelta<std::remove_cvref_t<decltype(scene.bsdf())>, S>) return !scene.bsdf().is_delta(p);
    else return !(next && next->delta);
  }

  static void accumulate(S& total, const S& value, DropCounters& drops) noexcept {
    if (is_finite(value)) total += value;
    else drops.add(DropReason::non_finite);
  }

  /// t = 1 for light end l: the sensor bridge (N34), splatted with 1/N_light.
  template <UniformSource<T> R, class Sink>
  void connect_to_camera(const Scn& scene, const Iteration& it, const Vertex& l, R& rng, Sink& sink) const {
    if (l.length + 1 > options_.max_length) return;
    const Segment<T> at{l.point, l.point};
    const auto b = camera_.sample(scene, {at}, rng);
    if (!b) return;
    const S f = scene.bsdf().eval(BsdfQuery<T>{l.point, -b->direction, l.to_previous, Transport::radiance});
    if (is_black(f)) return;
    const auto response = scene.sensor().importance(SensorQuery<T>{b->segment.x, b->direction});
    if (!response) return;
    const T w = camera_connection_weight(scene, it, l, *b, f);
    if (w == T(0)) return;
    sink.add(response->pixel, l.throughput * f * b->weight * (w / it.light_paths));
  }

  /// One camera subpath of `pixel` and every technique at its ends.
  template <UniformSource<T> R>
  S camera_path(const Scn& scene, const Iteration& it, std::uint32_t pixel, std::uint32_t light_paths, R& rng,
                DropCounters& drops) const noexcept {
    S total(T(0));
    const auto first = first_.sample(scene, {pixel}, rng);
    if (!first) return total;
    const Scratch& sc = scratch_;
    const std::size_t max = options_.max_length;
    const Vertex* partner = sc.light_vertices.data() + sc.light_first[pixel % light_paths];
    const std::uint32_t partner_count = sc.light_counts[pixel % light_paths];
    MisState state =
        camera_start(it, scene.sensor().pdf(SensorQuery<T>{first->segment.x, first->direction}).direction);
    Segment<T> segment = first->segment;
    Vec3<T> direction = first->direction;
    S throughput = first->weight;
    bool specular = true;
    const auto& emitter = scene.emitter();
    for (std::uint32_t length = 1;; ++length) {
      const bool escaped = segment.y.kind == PointKind::direction;
      if (!escaped && !arrive(it, state, segment.x, segment.y, direction)) break;
      const Vertex v{segment.y, -direction, throughput, state, length, specular};
      if (length == 1 || it.connect || specular) {
        const S emitted = emitter.radiance(EmissionQuery<T>{segment.y, -direction});
        if (!is_black(emitted)) accumulate(total, throughput * emitted * emission_weight(scene, it, segment.x, v), drops);
      }
      if (escaped || length >= max || segment.y.kind != PointKind::surface) break;
      if (it.ppm && has_no_delta_lobe(scene, v.point)) {  // gathered; no lobe to go on through
        merge(scene, it, v, total, drops);
        break;
      }
      const auto next = next_.sample(scene, {segment, direction}, rng);
      if (it.ppm) {
        if (ppm_gathers(scene, v.point, next)) merge(scene, it, v, total, drops);
        if (!(next && next->delta)) break;
      } else if (!(next && next->delta)) {
        if (it.connect) {
          if (length + 1 <= max) {
            const Segment<T> at{v.point, v.point};
            if (const auto e = bridge_.sample(scene, {at}, rng); e && e->pdf > T(0)) {
              const S f = scene.bsdf().eval(BsdfQuery<T>{v.point, v.to_previous, e->direction, Transport::radiance});
              if (!is_black(f)) accumulate(total, throughput * f * e->weight * nee_weight(scene, it, v, *e, f), drops);
            }
          }
          for (std::uint32_t j = 0; j < partner_count; ++j) {
            const Vertex& l = partner[j];
            if (length + l.length + 1 > max) break;
            if (!l.specular) accumulate(total, connect(scene, it, v, l), drops);
          }
        }
        if (it.merge) merge(scene, it, v, total, drops);
      }
      if (!next) break;
      if (!scatter_camera(scene, it, state, v, next->direction, next->delta)) break;
      throughput = throughput * next->weight;
      if (!survives(length, *next, throughput, rng) || is_black(throughput)) break;
      specular = specular && next->delta;
      segment = next->segment;
      direction = next->direction;
    }
    return total;
  }

  /// Russian roulette after the scattering that drew `next` onto a subpath of `length`
  /// segments: false ends the subpath; a survivor's throughput is divided by the probability.
  template <UniformSource<T> R>
  [[nodiscard]] bool survives(std::uint32_t length, const SegmentSample<S>& next, S& throughput, R& rng) const noexcept {
    if (options_.roulette_from == 0 || length < options_.roulette_from) return true;
    const T q = continuation_probability(next.weight, next.delta);
    if (!(q < T(1))) return true;
    if (!(rng.template uniform<T>() < q)) return false;
    throughput = throughput / q;
    return true;
  }

  /// The Dirac bridge between camera end c and light end l: f G f with visibility, weighted.
  [[nodiscard]] S connect(const Scn& scene, const Iteration& it, const Vertex& c, const Vertex& l) const noexcept {
    const S zero(T(0));
    const Vec3<T> delta = l.point.position - c.point.position;
    const T d2 = glm::dot(delta, delta);
    if (!(d2 > T(0)) || !std::isfinite(d2)) return zero;
    const Vec3<T> d = delta / std::sqrt(d2);
    const S f_c = scene.bsdf().eval(BsdfQuery<T>{c.point, c.to_previous, d, Transport::radiance});
    if (is_black(f_c)) return zero;
    const S f_l = scene.bsdf().eval(BsdfQuery<T>{l.point, -d, l.to_previous, Transport::radiance});
    if (is_black(f_l)) return zero;
    const T g = endpoint_cosine(c.point, d) * endpoint_cosine(l.point, d) / d2;
    if (!(g > T(0))) return zero;
    if (!scene.visible(VisibilityQuery<T>{c.point, l.point})) return zero;
    return c.throughput * f_c * (l.throughput * f_l) * (g * connection_weight(scene, it, c, l, d, d2, f_c, f_l));
  }

  /// Merges camera end c with the stored light ends in its disk (N19), weighted.
  void merge(const Scn& scene, const Iteration& it, const Vertex& c, S& total, DropCounters& drops) const noexcept {
    const Scratch& sc = scratch_;
    S sum(T(0));
    const std::size_t max = options_.max_length;
    sc.grid.for_each_within(c.point.position, [&](const Photon& l, const Vec3<T>&) noexcept {
      if (c.length + l.length > max) return;
      if (!(glm::dot(l.normal, c.point.normal) >= merge_min_normal_cosine)) return;
      const S f = scene.bsdf().eval(BsdfQuery<T>{c.point, c.to_previous, l.to_previous, Transport::radiance});
      if (is_black(f)) return;
      sum += f * l.throughput * merge_weight(scene, it, c, l, f);
    });
    if (!is_black(sum)) accumulate(total, c.throughput * sum * it.merge_normalization, drops);
  }

  VcmOptions options_;
  SensorStartSampler<Scn> first_;
  NextSegmentSampler<Scn, DiracKernel<T>> next_{DiracKernel<T>{}};
  LightBridgeSampler<Scn, DiracKernel<T>> bridge_{DiracKernel<T>{}};
  LightStartSampler<Scn> light_start_;
  LightNextSegmentSampler<Scn, DiracKernel<T>> light_next_{DiracKernel<T>{}};
  SensorBridgeSampler<Scn, DiracKernel<T>> camera_{DiracKernel<T>{}};
  mutable Scratch scratch_;
};

}  // namespace segpath
