// Segment BDPT, progressive and bidirectional photon mapping, and vertex connection and
// merging (SPEC 1.9) as modes of one SmallVCM-style implementation: sequential camera and
// light subpaths (N29-N31), Dirac bridges (N34) and uniform-disk junctions (N19) between them,
// weighted by multi-technique MIS (N36) through Georgiev et al. 2012's recursive quantities.
#pragma once

#include "segpath/concepts/scene.hpp"
#include "segpath/integrand/contribution.hpp"
#include "segpath/core/drop.hpp"
#include "segpath/core/framebuffer.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/rng.hpp"
#include "segpath/core/roulette.hpp"
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
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace segpath {

/// Which techniques an iteration uses (SmallVCM's modes):
///  - bdpt: every connection (s, t): camera paths reaching emitters, next-event bridges, bridges
///    between subpath ends, light subpaths bridged to the sensor (t = 1);
///  - ppm: camera paths go through delta scattering to their first non-delta end and gather
///    the light-subpath ends (photons) there with the disk kernel, unweighted;
///  - bpm: gathering at every non-delta camera end, MIS over those merging techniques;
///  - vcm: the union of bdpt's and bpm's techniques under one MIS (UPS).
enum class VcmMode : std::uint8_t { bdpt, ppm, bpm, vcm };

[[nodiscard]] constexpr const char* to_string(VcmMode m) noexcept {
  switch (m) {
    case VcmMode::bdpt: return "bdpt";
    case VcmMode::ppm: return "ppm";
    case VcmMode::bpm: return "bpm";
    case VcmMode::vcm: return "vcm";
  }
  return "unknown";
}

/// The automatic initial merge radius in average pixel footprints (sensors/pixel_footprint.hpp):
/// 2, the best geometric mean of relMSE over SmallVCM's four boxes at 10 s in a sweep over 0.5,
/// 1, 2 and 4 (docs/figures.md).
inline constexpr double vcm_radius_in_footprints = 2.0;

struct VcmOptions {
  VcmMode mode = VcmMode::vcm;
  std::size_t max_length = 10;  ///< segments per path, the sensor segment included (>= 1)
  MisHeuristic heuristic = MisHeuristic::power;
  /// Disk-kernel radius of iteration 0 in scene units; 0 (the default): vcm_radius_in_footprints
  /// average pixel footprints of the scene's sensor (kernel_schedule).
  double initial_radius = 0;
  double alpha = 0.75;           ///< radius schedule r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1), in (0, 1)
  double light_path_factor = 1;  ///< light subpaths per iteration = round(factor * pixels), >= 1
  /// Russian roulette (core/roulette.hpp) after every scattering of a subpath from this many
  /// segments on (0: never). From 1 (SmallVCM's schedule: every scattering) the MIS densities
  /// carry its continuation probabilities, as SmallVCM's do; from a later length the weights
  /// leave it out. Either way they are a partition of unity over the techniques, so the
  /// estimate is unchanged in expectation.
  std::size_t roulette_from = 0;
  std::uint64_t seed = 0;
};

/// Georgiev et al.'s recursive MIS quantities of a subpath end (SmallVCM's dVCM, dVC, dVM),
/// already divided by the heuristic's power of the cosine and distance of the segment that
/// reached the end.
template <Real T>
struct VcmMisState {
  T d_vcm = 0;
  T d_vc = 0;
  T d_vm = 0;
};

/// A camera or light subpath end: the y of a camera subpath's last segment, or the x of a light
/// subpath's first segment. `to_previous` is the unit direction towards the previous end of the
/// same subpath (towards the sensor on camera subpaths, towards the light on light subpaths);
/// `throughput` is the product of the sampler weights of its segments; `length` their number.
template <class S>
struct VcmVertex {
  using Scalar = spectrum_scalar_t<S>;
  SurfacePoint<Scalar> point;
  Vec3<Scalar> to_previous{};
  S throughput{};
  VcmMisState<Scalar> mis{};
  std::uint32_t length = 0;
  /// Camera ends: every scattering before this end was a delta lobe. Light ends: the lobe that
  /// continued the light subpath from this end was a delta (no connection or merging here).
  bool specular = false;
};

/// The constants of one iteration: radius, light-subpath count and the MIS factors of
/// (Georgiev et al. 2012) eta = pi r^2 N_light.
template <Real T>
struct VcmIteration {
  T radius = 0;
  T light_paths = 1;
  T merge_normalization = 0;  ///< K / N_light = 1 / (pi r^2 N_light)
  T vm_factor = 0;            ///< heuristic(eta) when merging is on, else 0
  T vc_factor = 0;            ///< heuristic(1 / eta) when connections are on, else 0
  MisHeuristic heuristic = MisHeuristic::power;
  bool connect = false;
  bool merge = false;
  bool ppm = false;
  /// Every scattering is subject to Russian roulette (VcmOptions::roulette_from == 1): the MIS
  /// densities of scatterings carry its continuation probability.
  bool roulette = false;
  /// Light subpaths can be bridged to the sensor (t = 1): off for sensors that are Dirac in
  /// direction (radiance probes), whose rays no bridge can hit.
  bool camera_connectable = false;
};

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
/// (exact for purely specular or purely non-specular materials). Paths of one segment (the
/// sensor seeing an emitter) are left to the camera subpath alone, as in SmallVCM.
/// Scratch storage lives in the object and is reused across iterations: one render_iteration
/// at a time per object.
template <LightSampledScene Scn>
class VertexConnectionMerging {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  using Vertex = VcmVertex<S>;
  using Iteration = VcmIteration<T>;
  using MisState = VcmMisState<T>;
  /// Work chunks of the light pass and of the camera pass (fixed: never the thread count).
  static constexpr std::size_t chunk_count = 64;
  /// Normal agreement of a merge (DiskKernel's default support).
  static constexpr T merge_min_normal_cosine = T(0.5);

  explicit VertexConnectionMerging(VcmOptions options = {})
      : options_(validated(options)) {}

  [[nodiscard]] const VcmOptions& options() const noexcept { return options_; }

  /// The merge radius of every iteration: none for bdpt; else from initial_radius (or
  /// vcm_radius_in_footprints pixel footprints when it is 0), shrinking by ProgressiveRadius.
  [[nodiscard]] KernelSchedule<T> kernel_schedule(const Scn& scene) const {
    if (options_.mode == VcmMode::bdpt) return {};
    const T initial = options_.initial_radius > 0 ? T(options_.initial_radius)
                                                  : T(vcm_radius_in_footprints) * pixel_footprint(scene, T(5e-3));
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
                                  std::to_string(radius));
    const std::uint32_t n = light_path_count(pixels);
    const std::size_t stride = options_.max_length - 1;
    if (double(n) * double(stride) >= double(std::numeric_limits<std::uint32_t>::max()))
      throw std::invalid_argument("segpath::VertexConnectionMerging: too many light-subpath ends per iteration");
    const Iteration it = iteration_constants(scene, radius, n);
    Scratch& sc = scratch_;
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
        std::vector<Vertex>& ends = sc.chunk_vertices[c];
        std::vector<Vertex>& buffer = sc.path_buffers[c];
        ends.clear();
        buffer.resize(stride);
        const std::size_t begin = c * n / chunks, end = (c + 1) * n / chunks;
        for (std::size_t i = begin; i < end; ++i) {
          Pcg32 rng = Pcg32::for_sample(options_.seed ^ light_salt, i, iteration);
          const std::uint32_t count = trace_light_subpath(scene, it, rng, std::span<Vertex>(buffer.data(), stride));
          sc.light_first[i] = static_cast<std::uint32_t>(ends.size());
          sc.light_counts[i] = count;
          ends.insert(ends.end(), buffer.begin(), buffer.begin() + count);
          if (!it.camera_connectable) continue;
          for (std::uint32_t j = 0; j < count; ++j)
            if (!buffer[j].specular) connect_to_camera(scene, it, buffer[j], rng, sink);
        }
      });
      std::vector<std::size_t> base(chunks + 1, 0);
      for (std::size_t c = 0; c < chunks; ++c) base[c + 1] = base[c] + sc.chunk_vertices[c].size();
      sc.light_vertices.resize(base[chunks]);
      parallel_for(chunks, [&](std::size_t c) {
        std::copy(sc.chunk_vertices[c].begin(), sc.chunk_vertices[c].end(), sc.light_vertices.begin() + std::ptrdiff_t(base[c]));
        for (std::size_t i = c * n / chunks; i < (c + 1) * n / chunks; ++i) sc.light_first[i] += static_cast<std::uint32_t>(base[c]);
      });
    }
    if (it.merge) {
      sc.photons.clear();
      for (std::size_t id = 0; id < sc.light_vertices.size(); ++id)
        if (!sc.light_vertices[id].specular && sc.light_vertices[id].point.kind == PointKind::surface)
          sc.photons.push_back(static_cast<std::uint32_t>(id));
      sc.grid.build(sc.photons, radius, [&](std::uint32_t id) { return sc.light_vertices[id].point.position; });
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
      v.specular = next->delta;
      if (!scatter_light(scene, it, state, v, -next->direction, next->delta)) break;
      if (!arrive(it, state, v.point, next->segment.x, next->direction)) break;
      S throughput = v.throughput * next->weight;
      if (!survives(v.length, *next, throughput, rng) || is_black(throughput)) break;
      out[count] = Vertex{next->segment.x, next->direction, throughput, state, v.length + 1, false};
      ++count;
      segment = next->segment;
      direction = next->direction;
    }
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

  // ---- MIS weights of each technique (N5 over Georgiev et al.'s full-path densities) -------

  /// s = 0: the camera subpath reached an emitter at `v` (`previous` is the end before it).
  [[nodiscard]] T emission_weight(const Scn& scene, const Iteration& it, const SurfacePoint<T>& previous,
                                  const Vertex& v) const noexcept {
    if (v.length <= 1) return T(1);
    const auto& emitter = scene.emitter();
    const T direct = emitter.pdf_towards(EmitterPdfTowardsQuery<T>{previous, v.point});
    const bool finite = v.point.kind != PointKind::direction;
    const EmissionPdf<T> e =
        emitter.pdf_emission(EmissionPdfQuery<T>{v.point, finite ? v.to_previous : previous.position});
    const T w_camera = mis(it, direct) * v.mis.d_vcm + mis(it, e.position * e.direction) * v.mis.d_vc;
    return reciprocal(T(1) + w_camera);
  }

  /// s = 1: the next-event bridge `e` (LightBridgeSampler's sample from camera end `v`).
  [[nodiscard]] T nee_weight(const Scn& scene, const Iteration& it, const Vertex& v,
                             const SegmentSample<S>& e) const noexcept {
    return nee_weight(scene, it, v, e, roulette_f(scene, it, {v.point, v.to_previous, e.direction, Transport::radiance}));
  }
  /// nee_weight with f_r at v for the bridge's direction (used only with roulette in the MIS).
  [[nodiscard]] T nee_weight(const Scn& scene, const Iteration& it, const Vertex& v, const SegmentSample<S>& e,
                             const S& f) const noexcept {
    const Vec3<T>& d = e.direction;
    const BsdfQuery<T> forward{v.point, v.to_previous, d, Transport::radiance};
    const BsdfQuery<T> reverse{v.point, v.to_previous, d, Transport::importance};
    const T forward_pdf = scene.bsdf().pdf(forward);
    const T reverse_pdf = scene.bsdf().pdf(reverse);
    const T forward_density = forward_pdf * continuation(it, f, endpoint_cosine(v.point, d), forward_pdf);
    const T reverse_density = reverse_pdf * continuation(it, f, endpoint_cosine(v.point, v.to_previous), reverse_pdf);
    const T w_light = e.delta ? T(0) : mis(it, solid_angle_to_area(forward_density, v.point, e.segment.y) / e.pdf);
    const SurfacePoint<T>& y = e.segment.y;
    const bool finite = y.kind != PointKind::direction;
    const EmissionPdf<T> ep = scene.emitter().pdf_emission(EmissionPdfQuery<T>{y, finite ? -d : v.point.position});
    const T to_x = finite ? solid_angle_to_area(T(1), y, v.point) : endpoint_cosine(v.point, d);
    const T w_camera = mis(it, ep.position * ep.direction * to_x / e.pdf) *
                       (it.vm_factor + v.mis.d_vcm + v.mis.d_vc * mis(it, reverse_density));
    return reciprocal(w_light + T(1) + w_camera);
  }

  /// s, t >= 2: the Dirac bridge (N34) between camera end `c` and light end `l`.
  [[nodiscard]] T connection_weight(const Scn& scene, const Iteration& it, const Vertex& c, const Vertex& l) const noexcept {
    const Vec3<T> delta = l.point.position - c.point.position;
    const T d2 = glm::dot(delta, delta);
    if (!(d2 > T(0)) || !std::isfinite(d2)) return T(0);
    const Vec3<T> d = delta / std::sqrt(d2);
    return connection_weight(scene, it, c, l, d, d2, roulette_f(scene, it, {c.point, c.to_previous, d, Transport::radiance}),
                             roulette_f(scene, it, {l.point, -d, l.to_previous, Transport::radiance}));
  }

  /// t = 1: the sensor bridge `b` (SensorBridgeSampler's sample towards light end `l`).
  [[nodiscard]] T camera_connection_weight(const Scn& scene, const Iteration& it, const Vertex& l,
                                           const SegmentSample<S>& b) const noexcept {
    return camera_connection_weight(scene, it, l, b,
                                    roulette_f(scene, it, {l.point, -b.direction, l.to_previous, Transport::radiance}));
  }
  /// camera_connection_weight with f_r at l for the bridge's direction.
  [[nodiscard]] T camera_connection_weight(const Scn& scene, const Iteration& it, const Vertex& l, const SegmentSample<S>& b,
                                           const S& f) const noexcept {
    const T reverse_pdf = scene.bsdf().pdf(BsdfQuery<T>{l.point, -b.direction, l.to_previous, Transport::radiance});
    const T reverse = reverse_pdf * continuation(it, f, endpoint_cosine(l.point, l.to_previous), reverse_pdf);
    const T camera_pdf = solid_angle_to_area(
        scene.sensor().pdf(SensorQuery<T>{b.segment.x, b.direction}).direction, b.segment.x, l.point);
    const T w_light = mis(it, camera_pdf / it.light_paths) * (it.vm_factor + l.mis.d_vcm + l.mis.d_vc * mis(it, reverse));
    return reciprocal(T(1) + w_light);
  }

  /// The merge of camera end `c` with light end `l` (disk kernel); 1 in ppm mode.
  [[nodiscard]] T merge_weight(const Scn& scene, const Iteration& it, const Vertex& c, const Vertex& l) const noexcept {
    if (it.ppm) return T(1);
    return merge_weight(scene, it, c, l, roulette_f(scene, it, {c.point, c.to_previous, l.to_previous, Transport::radiance}));
  }
  /// merge_weight with f_r at c between the two subpaths' directions.
  [[nodiscard]] T merge_weight(const Scn& scene, const Iteration& it, const Vertex& c, const Vertex& l, const S& f) const noexcept {
    if (it.ppm) return T(1);
    const T forward_pdf = scene.bsdf().pdf(BsdfQuery<T>{c.point, c.to_previous, l.to_previous, Transport::radiance});
    const T reverse_pdf = scene.bsdf().pdf(BsdfQuery<T>{c.point, c.to_previous, l.to_previous, Transport::importance});
    const T forward = forward_pdf * continuation(it, f, endpoint_cosine(c.point, l.to_previous), forward_pdf);
    const T reverse = reverse_pdf * continuation(it, f, endpoint_cosine(c.point, c.to_previous), reverse_pdf);
    const T w_light = l.mis.d_vcm * it.vc_factor + l.mis.d_vm * mis(it, forward);
    const T w_camera = c.mis.d_vcm * it.vc_factor + c.mis.d_vm * mis(it, reverse);
    return reciprocal(w_light + T(1) + w_camera);
  }

 private:
  static constexpr std::uint64_t light_salt = 0x6c69676874ULL;

  struct Scratch {
    std::vector<Vertex> light_vertices;                  ///< every light subpath's ends, path after path
    std::vector<std::uint32_t> light_first, light_counts;  ///< per light subpath: its first end there, its count
    std::vector<std::vector<Vertex>> chunk_vertices;      ///< the ends each chunk traced
    std::vector<std::vector<Vertex>> path_buffers;        ///< per chunk: one subpath's ends while tracing
    std::vector<std::uint32_t> photons;
    HashGrid<T> grid;
    SplatRecorder<S> splats{chunk_count};
    std::vector<DropCounters> camera_drops;
  };

  static VcmOptions validated(const VcmOptions& o) {
    const auto fail = [](const std::string& what) {
      throw std::invalid_argument("segpath::VertexConnectionMerging: " + what);
    };
    if (o.max_length < 1) fail("max_length must be >= 1, got 0");
    if (!(o.initial_radius >= 0) || !std::isfinite(o.initial_radius) || !std::isfinite(T(o.initial_radius)) ||
        (o.initial_radius > 0 && !(T(o.initial_radius) > T(0))))
      fail("initial_radius must be finite and >= 0 (0: automatic), got " + std::to_string(o.initial_radius));
    if (!(o.alpha > 0 && o.alpha < 1)) fail("alpha must lie in (0, 1), got " + std::to_string(o.alpha));
    if (!(o.light_path_factor > 0) || !std::isfinite(o.light_path_factor))
      fail("light_path_factor must be finite and > 0, got " + std::to_string(o.light_path_factor));
    return o;
  }

  [[nodiscard]] static T mis(const Iteration& it, T x) noexcept {
    return it.heuristic == MisHeuristic::balance ? x : x * x;
  }
  [[nodiscard]] static T reciprocal(T x) noexcept { return x > T(0) && std::isfinite(x) ? T(1) / x : T(0); }

  /// The roulette's continuation probability as a factor of a scattering's solid-angle density
  /// in the MIS (it.roulette): q = min(1, max(f_r) |cos| / pdf) of the scattering that samples
  /// the direction (cosine `cosine`, density `pdf`), the rule the subpaths' roulette applies
  /// (core/roulette.hpp). The reverse direction's q takes f_r of radiance transport, exact for
  /// BSDFs that are symmetric there (no refraction, no shading normals); a weight computed with
  /// another q is still unbiased.
  [[nodiscard]] static T continuation(const Iteration& it, const S& f, T cosine, T pdf) noexcept {
    if (!it.roulette || !(pdf > T(0))) return T(1);
    return continuation_probability(S(f * (cosine / pdf)), false);
  }
  /// f_r for `continuation`, evaluated only when the MIS carries the roulette.
  [[nodiscard]] static S roulette_f(const Scn& scene, const Iteration& it, const BsdfQuery<T>& q) noexcept {
    return it.roulette ? scene.bsdf().eval(q) : S(T(0));
  }

  /// Whether the sensor's rays for a pixel depend on the position in the pixel (a pinhole)
  /// or not (a probe, a Dirac in direction that no bridge can hit).
  [[nodiscard]] static bool sensor_has_direction_density(const Scn& scene) noexcept {
    const auto a = scene.sensor().sample_ray(SensorSampleQuery<T>{0, Vec2<T>(T(0.5)), Vec2<T>(T(0.25))});
    const auto b = scene.sensor().sample_ray(SensorSampleQuery<T>{0, Vec2<T>(T(0.5)), Vec2<T>(T(0.75))});
    return a && b && a->direction != b->direction;
  }

  /// Whether a light end is a Dirac (see the class comment).
  [[nodiscard]] static bool dirac_light_end(const Scn& scene, const SurfacePoint<T>& y, const SurfacePoint<T>& x) noexcept {
    if (y.kind == PointKind::point) return true;
    if (y.kind == PointKind::surface) return false;
    const Frame<T> frame = Frame<T>::from_normal(y.position);
    SurfacePoint<T> nearby = y;
    nearby.position = glm::normalize(y.position + frame.tangent * T(1e-3));
    nearby.normal = nearby.shading_normal = nearby.position;
    return !(scene.emitter().pdf_emission(EmissionPdfQuery<T>{nearby, x.position}).position > T(0));
  }

  /// The camera subpath's quantities at the sensor: only t = 1 (a light subpath bridged to the
  /// sensor) competes there, with density N_light per unit of the pixel's direction density.
  [[nodiscard]] static MisState camera_start(const Iteration& it, T camera_pdf_direction) noexcept {
    MisState s;
    if (it.camera_connectable && camera_pdf_direction > T(0) && std::isfinite(camera_pdf_direction))
      s.d_vcm = mis(it, it.light_paths / camera_pdf_direction);
    return s;
  }

  /// The light subpath's quantities at its first surface end x (segment x -> y, unit
  /// direction d from x towards the light end y).
  [[nodiscard]] static bool light_first(const Scn& scene, const Iteration& it, const SurfacePoint<T>& y,
                                        const SurfacePoint<T>& x, const Vec3<T>& d, MisState& s) noexcept {
    const auto& emitter = scene.emitter();
    const bool finite = y.kind != PointKind::direction;
    const EmissionPdf<T> e = emitter.pdf_emission(EmissionPdfQuery<T>{y, finite ? -d : x.position});
    const T emission = e.position * e.direction;
    if (!(emission > T(0)) || !std::isfinite(emission)) return false;
    const T direct = emitter.pdf_towards(EmitterPdfTowardsQuery<T>{x, y});
    const T cos_y = finite ? endpoint_cosine(y, d) : T(1);
    s.d_vcm = mis(it, direct / emission);
    s.d_vc = dirac_light_end(scene, y, x) ? T(0) : mis(it, cos_y / emission);
    s.d_vm = s.d_vc * it.vc_factor;
    return arrive(it, s, y, x, d);
  }

  /// Divides by the heuristic's power of the density conversion of the segment from -> to.
  [[nodiscard]] static bool arrive(const Iteration& it, MisState& s, const SurfacePoint<T>& from,
                                   const SurfacePoint<T>& to, const Vec3<T>& d) noexcept {
    const T cosine = endpoint_cosine(to, d);
    if (!(cosine > T(0))) return false;
    T d2 = T(1);
    if (from.kind != PointKind::direction) {
      const Vec3<T> delta = to.position - from.position;
      d2 = glm::dot(delta, delta);
      if (!(d2 > T(0)) || !std::isfinite(d2)) return false;
    }
    const T inv_cos = mis(it, T(1) / cosine);
    s.d_vcm *= mis(it, d2) * inv_cos;
    s.d_vc *= inv_cos;
    s.d_vm *= inv_cos;
    return std::isfinite(s.d_vcm) && std::isfinite(s.d_vc) && std::isfinite(s.d_vm);
  }

  /// The recursion through a scattering end with forward and reverse solid-angle densities.
  [[nodiscard]] static bool scatter(const Iteration& it, MisState& s, T forward, T reverse, T cos_out, bool delta) noexcept {
    if (delta) {
      s.d_vcm = T(0);
      s.d_vc *= mis(it, cos_out);
      s.d_vm *= mis(it, cos_out);
      return true;
    }
    if (!(forward > T(0)) || !std::isfinite(forward)) return false;
    const T a = mis(it, cos_out / forward);
    const T d_vc = a * (s.d_vc * mis(it, reverse) + s.d_vcm + it.vm_factor);
    const T d_vm = a * (s.d_vm * mis(it, reverse) + s.d_vcm * it.vc_factor + T(1));
    s.d_vcm = mis(it, T(1) / forward);
    s.d_vc = d_vc;
    s.d_vm = d_vm;
    return std::isfinite(d_vc) && std::isfinite(d_vm);
  }

  /// Camera subpath leaving end v along `out` (towards the light).
  [[nodiscard]] static bool scatter_camera(const Scn& scene, const Iteration& it, MisState& s, const Vertex& v,
                                           const Vec3<T>& out, bool delta) noexcept {
    const T cos_out = endpoint_cosine(v.point, out);
    if (delta) return scatter(it, s, T(0), T(0), cos_out, true);
    const BsdfQuery<T> query{v.point, v.to_previous, out, Transport::radiance};
    const T forward = scene.bsdf().pdf(query);
    const T reverse = scene.bsdf().pdf(BsdfQuery<T>{v.point, v.to_previous, out, Transport::importance});
    const S f = roulette_f(scene, it, query);
    return scatter(it, s, forward * continuation(it, f, cos_out, forward),
                   reverse * continuation(it, f, endpoint_cosine(v.point, v.to_previous), reverse), cos_out, false);
  }

  /// Light subpath leaving end v along `out` (towards the sensor).
  [[nodiscard]] static bool scatter_light(const Scn& scene, const Iteration& it, MisState& s, const Vertex& v,
                                          const Vec3<T>& out, bool delta) noexcept {
    const T cos_out = endpoint_cosine(v.point, out);
    if (delta) return scatter(it, s, T(0), T(0), cos_out, true);
    const BsdfQuery<T> query{v.point, out, v.to_previous, Transport::radiance};
    const T forward = scene.bsdf().pdf(BsdfQuery<T>{v.point, out, v.to_previous, Transport::importance});
    const T reverse = scene.bsdf().pdf(query);
    const S f = roulette_f(scene, it, query);
    return scatter(it, s, forward * continuation(it, f, cos_out, forward),
                   reverse * continuation(it, f, endpoint_cosine(v.point, v.to_previous), reverse), cos_out, false);
  }

  /// connection_weight with the unit direction d from c to l, their squared distance and f_r at
  /// both ends (f_c, f_l: used only with roulette in the MIS).
  [[nodiscard]] T connection_weight(const Scn& scene, const Iteration& it, const Vertex& c, const Vertex& l,
                                    const Vec3<T>& d, T d2, const S& f_c, const S& f_l) const noexcept {
    const auto& bsdf = scene.bsdf();
    T c_forward = bsdf.pdf(BsdfQuery<T>{c.point, c.to_previous, d, Transport::radiance});
    T c_reverse = bsdf.pdf(BsdfQuery<T>{c.point, c.to_previous, d, Transport::importance});
    T l_forward = bsdf.pdf(BsdfQuery<T>{l.point, -d, l.to_previous, Transport::importance});
    T l_reverse = bsdf.pdf(BsdfQuery<T>{l.point, -d, l.to_previous, Transport::radiance});
    c_forward *= continuation(it, f_c, endpoint_cosine(c.point, d), c_forward);
    c_reverse *= continuation(it, f_c, endpoint_cosine(c.point, c.to_previous), c_reverse);
    l_forward *= continuation(it, f_l, endpoint_cosine(l.point, d), l_forward);
    l_reverse *= continuation(it, f_l, endpoint_cosine(l.point, l.to_previous), l_reverse);
    const T c_forward_area = c_forward * endpoint_cosine(l.point, d) / d2;
    const T l_forward_area = l_forward * endpoint_cosine(c.point, d) / d2;
    const T w_light = mis(it, c_forward_area) * (it.vm_factor + l.mis.d_vcm + l.mis.d_vc * mis(it, l_reverse));
    const T w_camera = mis(it, l_forward_area) * (it.vm_factor + c.mis.d_vcm + c.mis.d_vc * mis(it, c_reverse));
    return reciprocal(w_light + T(1) + w_camera);
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
      const auto next = next_.sample(scene, {segment, direction}, rng);
      if (!(next && next->delta)) {
        if (it.ppm) {
          merge(scene, it, v, total, drops);
          break;
        }
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
    sc.grid.for_each_within(c.point.position, [&](std::uint32_t id, const Vec3<T>&) noexcept {
      const Vertex& l = sc.light_vertices[id];
      if (c.length + l.length > max) return;
      if (!(glm::dot(l.point.normal, c.point.normal) >= merge_min_normal_cosine)) return;
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
