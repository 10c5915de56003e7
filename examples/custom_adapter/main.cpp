// segpath-demo: a renderer author's own scene adapter, rendered with segpath.
//
// The user's types here — a room of rectangles and spheres with a brute-force intersector,
// a pinhole camera, a material table and a rectangular lamp — model segpath's concepts
// (static_assert below); the library supplies the Lambertian BRDF and the methods. The room is
// rendered four ways and their image means printed side by side: segment path tracing with the
// sequential estimator (by hand), then PT, VCM and BDPF through the render protocol
// (segpath::ProgressiveRender), spp iterations each. Usage:
//   segpath-demo [--out FILE.png] [--spp N] [--width W] [--height H] [--threads N] [--seed S]
#include <segpath/algorithms/path_tracer.hpp>
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/algorithms/vcm.hpp>
#include <segpath/estimators/sequential.hpp>
#include <segpath/kernels/dirac.hpp>
#include <segpath/materials/lambertian.hpp>
#include <segpath/render/progressive.hpp>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

#include <malloc.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "common/image.hpp"

namespace {

using T = float;
using segpath::Vec2;
using segpath::Vec3;
using Color = segpath::Rgb<T>;

// ---- the user's geometry -------------------------------------------------------------
struct Rectangle {
  Vec3<T> corner, edge_u, edge_v, normal;  // normal faces into the room
  std::uint32_t material;
};
struct Ball {
  Vec3<T> center;
  T radius;
  std::uint32_t material;
};

enum Material : std::uint32_t { white, red, green, light, material_count };

/// A camera the renderer already had: a pinhole whose pixel value is the mean radiance
/// over the pixel (W cos / p = 1 for the rays it samples).
class Pinhole {
 public:
  Pinhole(Vec3<T> position, Vec3<T> forward, Vec3<T> up, T vertical_fov_degrees, std::uint32_t width,
          std::uint32_t height)
      : position_(position), width_(width), height_(height) {
    forward_ = glm::normalize(forward);
    right_ = glm::normalize(glm::cross(forward_, up));
    up_ = glm::cross(right_, forward_);
    tan_y_ = std::tan(vertical_fov_degrees * segpath::pi<T> / T(360));
    tan_x_ = tan_y_ * T(width) / T(height);
    pixel_area_ = (T(2) * tan_x_ / T(width)) * (T(2) * tan_y_ / T(height));
  }
  [[nodiscard]] std::uint32_t pixel_count() const noexcept { return width_ * height_; }

  [[nodiscard]] std::optional<segpath::SensorSample<T>> sample_ray(const segpath::SensorSampleQuery<T>& q) const noexcept {
    const T px = T(q.pixel % width_) + q.u_direction.x, py = T(q.pixel / width_) + q.u_direction.y;
    const Vec3<T> d = glm::normalize(forward_ + (T(2) * px / T(width_) - T(1)) * tan_x_ * right_ +
                                     (T(1) - T(2) * py / T(height_)) * tan_y_ * up_);
    const T p = direction_pdf(d);
    return segpath::SensorSample<T>{segpath::SurfacePoint<T>::at_point(position_, forward_), d, p, T(1), p};
  }
  [[nodiscard]] std::optional<segpath::SensorResponse<T>> importance(const segpath::SensorQuery<T>& q) const noexcept {
    const auto pixel = pixel_of(q.direction);
    if (!pixel || q.origin.position != position_) return std::nullopt;
    return segpath::SensorResponse<T>{*pixel, direction_pdf(q.direction)};
  }
  [[nodiscard]] segpath::SensorPdf<T> pdf(const segpath::SensorQuery<T>& q) const noexcept {
    if (!pixel_of(q.direction) || q.origin.position != position_) return {};
    return {T(1), direction_pdf(q.direction)};
  }

 private:
  /// Uniform over the pixel's area on the image plane at distance 1: 1 / (A cos^3).
  [[nodiscard]] T direction_pdf(const Vec3<T>& d) const noexcept {
    const T c = glm::dot(d, forward_);
    return c > T(0) ? T(1) / (pixel_area_ * c * c * c) : T(0);
  }
  [[nodiscard]] std::optional<std::uint32_t> pixel_of(const Vec3<T>& d) const noexcept {
    const T c = glm::dot(d, forward_);
    if (!(c > T(0))) return std::nullopt;
    const T sx = glm::dot(d, right_) / (c * tan_x_), sy = glm::dot(d, up_) / (c * tan_y_);
    const T px = (sx + T(1)) * T(0.5) * T(width_), py = (T(1) - sy) * T(0.5) * T(height_);
    if (!(px >= T(0) && px < T(width_) && py >= T(0) && py < T(height_))) return std::nullopt;
    return static_cast<std::uint32_t>(py) * width_ + static_cast<std::uint32_t>(px);
  }

  Vec3<T> position_, forward_, right_, up_;
  std::uint32_t width_, height_;
  T tan_x_ = 0, tan_y_ = 0, pixel_area_ = 0;
};

/// The user's scene adapter: everything segpath needs, in the user's own terms.
class Room {
 public:
  using Scalar = T;
  using Spectrum = Color;
  static constexpr T ray_epsilon = T(1e-4);
  static constexpr std::uint32_t lamp_index = 5;  ///< the lamp's rectangle

  Room(std::uint32_t width, std::uint32_t height)
      : camera_({0, T(-3.4), 0}, {0, 1, 0}, {0, 0, 1}, T(38), width, height) {
    auto wall = [&](Vec3<T> c, Vec3<T> u, Vec3<T> v, std::uint32_t m) {
      rectangles_.push_back({c, u, v, glm::normalize(glm::cross(u, v)), m});
    };
    wall({-1, -1, -1}, {2, 0, 0}, {0, 2, 0}, white);  // floor, normal +z
    wall({-1, -1, 1}, {0, 2, 0}, {2, 0, 0}, white);   // ceiling, normal -z
    wall({-1, 1, -1}, {2, 0, 0}, {0, 0, 2}, white);   // back wall, normal -y
    wall({-1, -1, -1}, {0, 2, 0}, {0, 0, 2}, red);    // left wall, normal +x
    wall({1, -1, -1}, {0, 0, 2}, {0, 2, 0}, green);   // right wall, normal -x
    wall({T(-0.5), T(-0.5), T(0.98)}, {0, T(1), 0}, {T(1), 0, 0}, light);  // ceiling lamp (lamp_index), facing down
    balls_.push_back({{T(-0.4), T(0.3), T(-0.6)}, T(0.4), white});
    balls_.push_back({{T(0.45), T(-0.1), T(-0.7)}, T(0.3), white});
    materials_[white] = {Color(T(0.75))};
    materials_[red] = {Color(T(0.75), T(0.15), T(0.12))};
    materials_[green] = {Color(T(0.15), T(0.6), T(0.15))};
    materials_[light] = {Color(T(0.0))};
    // Area CDF over all primitives, for uniform area sampling.
    for (const auto& r : rectangles_) cdf_.push_back(total_area_ += glm::length(glm::cross(r.edge_u, r.edge_v)));
    for (const auto& b : balls_) cdf_.push_back(total_area_ += T(4) * segpath::pi<T> * b.radius * b.radius);
  }

  // Manifold
  [[nodiscard]] T area() const noexcept { return total_area_; }
  [[nodiscard]] std::optional<segpath::AreaSample<T>> sample_area(const segpath::AreaSampleQuery<T>& q) const noexcept {
    const T target = q.u.x * total_area_;
    std::size_t i = 0;
    while (i + 1 < cdf_.size() && cdf_[i] <= target) ++i;
    const T lo = i == 0 ? T(0) : cdf_[i - 1];
    const T reused = std::clamp((target - lo) / (cdf_[i] - lo), T(0), T(1) - T(1e-7));  // re-used uniform
    segpath::SurfacePoint<T> p;
    if (i < rectangles_.size()) {
      const auto& r = rectangles_[i];
      p = segpath::SurfacePoint<T>::on_surface(r.corner + r.edge_u * reused + r.edge_v * q.u.y, r.normal,
                                               std::uint32_t(i), r.material);
    } else {
      const auto& b = balls_[i - rectangles_.size()];
      const Vec3<T> n = segpath::square_to_uniform_sphere(Vec2<T>(reused, q.u.y));
      p = segpath::SurfacePoint<T>::on_surface(b.center + n * b.radius, n, std::uint32_t(i), b.material);
    }
    return segpath::AreaSample<T>{p, T(1) / total_area_};
  }
  [[nodiscard]] std::optional<segpath::Hit<T>> intersect(const segpath::IntersectQuery<T>& q) const noexcept {
    std::optional<segpath::Hit<T>> hit;
    T t_best = q.t_max;
    for (std::size_t i = 0; i < rectangles_.size(); ++i) {
      const auto& r = rectangles_[i];
      const T denom = glm::dot(q.ray.direction, r.normal);
      if (std::abs(denom) < T(1e-8)) continue;
      const T t = glm::dot(r.corner - q.ray.origin, r.normal) / denom;
      if (!(t > ray_epsilon && t < t_best)) continue;
      const Vec3<T> rel = q.ray.at(t) - r.corner;
      const T a = glm::dot(rel, r.edge_u) / glm::dot(r.edge_u, r.edge_u);
      const T b = glm::dot(rel, r.edge_v) / glm::dot(r.edge_v, r.edge_v);
      if (a < 0 || a > 1 || b < 0 || b > 1) continue;
      t_best = t;
      hit = segpath::Hit<T>{segpath::SurfacePoint<T>::on_surface(q.ray.at(t), r.normal, std::uint32_t(i), r.material), t};
    }
    for (std::size_t i = 0; i < balls_.size(); ++i) {
      const auto& s = balls_[i];
      const Vec3<T> oc = q.ray.origin - s.center;
      const T b = glm::dot(oc, q.ray.direction), c = glm::dot(oc, oc) - s.radius * s.radius;
      const T disc = b * b - c;
      if (disc < 0) continue;
      const T root = std::sqrt(disc);
      for (T t : {-b - root, -b + root}) {
        if (!(t > ray_epsilon && t < t_best)) continue;
        t_best = t;
        const Vec3<T> n = glm::normalize(q.ray.at(t) - s.center);
        hit = segpath::Hit<T>{segpath::SurfacePoint<T>::on_surface(s.center + n * s.radius, n,
                                                                   std::uint32_t(rectangles_.size() + i), s.material), t};
        break;
      }
    }
    return hit;
  }
  [[nodiscard]] bool visible(const segpath::VisibilityQuery<T>& q) const noexcept {
    const Vec3<T> d = q.to.position - q.from.position;
    const T dist = glm::length(d);
    return !intersect(segpath::IntersectQuery<T>{segpath::Ray<T>{q.from.position, d / dist}, dist - ray_epsilon});
  }

  // Radiometry: the library's Lambertian per material, the lamp as the only emitter.
  struct Materials {
    const Room* room;
    [[nodiscard]] Color eval(const segpath::BsdfQuery<T>& q) const noexcept { return of(q.point).eval(q); }
    [[nodiscard]] std::optional<segpath::BsdfSample<Color>> sample(const segpath::BsdfSampleQuery<T>& q) const noexcept { return of(q.point).sample(q); }
    [[nodiscard]] T pdf(const segpath::BsdfQuery<T>& q) const noexcept { return of(q.point).pdf(q); }
    // Optional hook: every material here is Lambertian, so the filtering methods may factorise
    // their clusters (docs/guide.md, "Optional hooks").
    [[nodiscard]] std::optional<Color> lambertian_albedo(const segpath::SurfacePoint<T>& p) const noexcept {
      return of(p).albedo;
    }
    [[nodiscard]] const segpath::Lambertian<Color>& of(const segpath::SurfacePoint<T>& p) const noexcept {
      return room->materials_[p.material_id < material_count ? p.material_id : white];
    }
  };
  // The lamp: one rectangle emitting a Lambertian radiance downwards. The four sampling
  // functions make it a SampledEmitter, which PT's next-event estimation, VCM's light subpaths
  // and BDPF's light paths need (the sequential estimator needs radiance() only).
  struct Lamp {
    const Rectangle* rect;
    static constexpr Color emitted{T(5), T(4.6), T(4)};
    [[nodiscard]] T area() const noexcept { return glm::length(glm::cross(rect->edge_u, rect->edge_v)); }
    [[nodiscard]] segpath::SurfacePoint<T> point(const Vec2<T>& u) const noexcept {
      return segpath::SurfacePoint<T>::on_surface(rect->corner + rect->edge_u * u.x + rect->edge_v * u.y, rect->normal,
                                                  lamp_index, light);
    }
    [[nodiscard]] Color radiance(const segpath::EmissionQuery<T>& q) const noexcept {
      const bool lit = q.point.material_id == light && glm::dot(q.to_sensor, q.point.normal) > T(0);
      return lit ? emitted : Color(T(0));
    }
    // A point uniform on the lamp, a cosine-weighted direction below it.
    [[nodiscard]] std::optional<segpath::EmissionSample<Color>> sample_emission(const segpath::EmissionSampleQuery<T>& q) const noexcept {
      const Vec3<T> local = segpath::square_to_cosine_hemisphere(q.u_direction);
      const Vec3<T> d = segpath::Frame<T>::from_normal(rect->normal).to_world(local);
      return segpath::EmissionSample<Color>{point(q.u_position), d, emitted, T(1) / area(),
                                            segpath::square_to_cosine_hemisphere_pdf(local), false};
    }
    [[nodiscard]] segpath::EmissionPdf<T> pdf_emission(const segpath::EmissionPdfQuery<T>& q) const noexcept {
      if (q.point.material_id != light) return {};
      const T cosine = glm::dot(q.direction, rect->normal);
      return {T(1) / area(), cosine > T(0) ? cosine / segpath::pi<T> : T(0)};
    }
    // A point uniform on the lamp for a receiver (next-event estimation).
    [[nodiscard]] std::optional<segpath::EmitterTowardsSample<Color>> sample_towards(const segpath::EmitterTowardsQuery<T>& q) const noexcept {
      const segpath::SurfacePoint<T> y = point(q.u);
      const bool lit = glm::dot(q.receiver.position - y.position, rect->normal) > T(0);
      return segpath::EmitterTowardsSample<Color>{y, lit ? emitted : Color(T(0)), T(1) / area(), false};
    }
    [[nodiscard]] T pdf_towards(const segpath::EmitterPdfTowardsQuery<T>& q) const noexcept {
      return q.point.material_id == light ? T(1) / area() : T(0);
    }
  };
  [[nodiscard]] Materials bsdf() const noexcept { return Materials{this}; }
  [[nodiscard]] Lamp emitter() const noexcept { return {&rectangles_[lamp_index]}; }
  [[nodiscard]] const Pinhole& sensor() const noexcept { return camera_; }

 private:
  std::vector<Rectangle> rectangles_;
  std::vector<Ball> balls_;
  std::array<segpath::Lambertian<Color>, material_count> materials_{};
  std::vector<T> cdf_;
  T total_area_ = 0;
  Pinhole camera_;
};

static_assert(segpath::Manifold<Room>, "the user's geometry is a segpath Manifold");
static_assert(segpath::Sensor<Pinhole, T>, "the user's camera is a segpath Sensor");
static_assert(segpath::Scene<Room>, "and the whole adapter a segpath Scene");
static_assert(segpath::LightSampledScene<Room>, "with a sampled emitter: PT, VCM and BDPF run on it");

struct Options {
  std::string out = "segpath-demo.png";
  std::uint32_t spp = 16, width = 256, height = 256, threads = 0;
  std::uint64_t seed = 1;
};

[[noreturn]] void usage_error(const std::string& message) {
  std::fprintf(stderr, "segpath-demo: %s\nusage: segpath-demo [--out FILE.png] [--spp N] [--width W] [--height H] [--threads N] [--seed S]\n",
               message.c_str());
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (i + 1 >= argc) usage_error("missing value after " + arg);
    const std::string value = argv[++i];
    auto number = [&](std::uint64_t max) -> std::uint64_t {
      char* end = nullptr;
      const unsigned long long v = std::strtoull(value.c_str(), &end, 10);
      if (value.empty() || value[0] == '-' || *end != '\0' || v == 0 || v > max)
        usage_error(arg + " needs an integer in [1, " + std::to_string(max) + "], got '" + value + "'");
      return v;
    };
    if (arg == "--out") o.out = value;
    else if (arg == "--spp") o.spp = std::uint32_t(number(1u << 20));
    else if (arg == "--width") o.width = std::uint32_t(number(8192));
    else if (arg == "--height") o.height = std::uint32_t(number(8192));
    else if (arg == "--threads") o.threads = std::uint32_t(number(256));
    else if (arg == "--seed") o.seed = number(~0ull);
    else usage_error("unknown option " + arg);
  }
  return o;
}

/// Accumulates one pixel's samples; counts dropped ones.
struct PixelSink {
  Color sum{};
  std::uint64_t dropped = 0;
  void add(std::uint32_t, const Color& v) noexcept { sum += v; }
  void drop(segpath::DropReason) noexcept { ++dropped; }
};

/// The user's own ParallelFor (segpath::ParallelFor): body(i) for i in [0, n) on `threads`
/// std::threads taking indices from a shared counter.
struct ThreadFor {
  unsigned threads = 1;
  template <class Body>
  void operator()(std::size_t n, Body&& body) const {
    std::atomic<std::size_t> next{0};
    auto work = [&] {
      for (std::size_t i; (i = next.fetch_add(1)) < n;) body(i);
    };
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
  }
};

/// Writes an image as PNG (tone-mapped to sRGB) and PFM (linear) next to each other.
bool write_images(const examples::Image& image, const std::string& png) {
  std::vector<unsigned char> ldr(image.pixels.size() * 3);
  for (std::size_t i = 0; i < image.pixels.size(); ++i)
    for (int c = 0; c < 3; ++c)
      ldr[3 * i + std::size_t(c)] = static_cast<unsigned char>(examples::to_srgb(image.pixels[i][c]) * 255.0f + 0.5f);
  const std::filesystem::path out(png);
  if (out.has_parent_path()) std::filesystem::create_directories(out.parent_path());
  if (!stbi_write_png(png.c_str(), image.width, image.height, 3, ldr.data(), image.width * 3)) return false;
  std::filesystem::path pfm = out;
  examples::write_pfm(image, pfm.replace_extension(".pfm").string());
  return true;
}

/// `png` with `-suffix` before its extension.
std::string suffixed(const std::string& png, const std::string& suffix) {
  std::filesystem::path p(png);
  const std::string ext = p.extension().string();
  return p.replace_extension().string() + "-" + suffix + ext;
}

struct Result {
  std::string name;
  double seconds = 0, mean = 0;
  std::uint64_t dropped = 0;
};

/// `spp` iterations of a library method through the render protocol (segpath::ProgressiveRender:
/// it numbers the iterations, accumulates them in double and picks the kernel size from the
/// pixel footprint), written to `png`.
template <class Method>
Result render_progressive(const std::string& name, const Room& room, Method method, const Options& o, unsigned threads,
                          const std::string& png) {
  const auto start = std::chrono::steady_clock::now();
  segpath::ProgressiveRender render(room, std::move(method), o.width, o.height);
  for (std::uint32_t i = 0; i < o.spp; ++i) render.iterate(ThreadFor{threads});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  examples::Image image(int(o.width), int(o.height));
  for (std::uint32_t p = 0; p < render.width() * render.height(); ++p) image.pixels[p] = Color(render.pixel(p));
  if (!write_images(image, png)) throw std::runtime_error("cannot write " + png);
  return {name, seconds, image.mean(), render.drops().total()};
}

}  // namespace

int main(int argc, char** argv) {
  // BDPF allocates its pool (hundreds of MB at full HD) every iteration: keep freed blocks in
  // the heap, or glibc returns them to the kernel, which zeroes every page again on the next
  // iteration (docs/guide.md, "Performance").
  mallopt(M_MMAP_THRESHOLD, 1 << 30);
  mallopt(M_TRIM_THRESHOLD, -1);
  // One heap for every thread: what the worker threads free (their path records) is then
  // reused by the pool and propagation arrays allocated next (docs/guide.md, "Performance").
  // A MALLOC_ARENA_MAX of the user's is left alone.
  if (std::getenv("MALLOC_ARENA_MAX") == nullptr) mallopt(M_ARENA_MAX, 1);
  const Options options = parse(argc, argv);
  const Room room(options.width, options.height);
  const unsigned threads = options.threads ? options.threads : std::max(1u, std::thread::hardware_concurrency());
  std::vector<Result> results;

  // 1. Segment path tracing with the sequential estimator: spp samples per pixel, by hand.
  {
    const segpath::SequentialEstimator<Room, segpath::DiracKernel<T>> estimator(segpath::DiracKernel<T>{}, {1, 8});
    examples::Image image(int(options.width), int(options.height));
    std::vector<std::uint64_t> dropped(threads, 0);
    const auto start = std::chrono::steady_clock::now();
    auto render_rows = [&](unsigned thread) {
      // Rows are interleaved over threads; every (pixel, sample) has its own random stream, so
      // the image does not depend on the thread count.
      for (std::uint32_t y = thread; y < options.height; y += threads)
        for (std::uint32_t x = 0; x < options.width; ++x) {
          const std::uint32_t pixel = y * options.width + x;
          PixelSink sink;
          for (std::uint32_t s = 0; s < options.spp; ++s) {
            segpath::Pcg32 rng = segpath::Pcg32::for_sample(options.seed, pixel, s);
            estimator.estimate(room, segpath::EstimateQuery{pixel, s}, rng, sink);
          }
          image.at(int(x), int(y)) = sink.sum / T(options.spp);
          dropped[thread] += sink.dropped;
        }
    };
    std::vector<std::thread> pool;
    for (unsigned t = 0; t < threads; ++t) pool.emplace_back(render_rows, t);
    for (auto& t : pool) t.join();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!write_images(image, options.out)) {
      std::fprintf(stderr, "segpath-demo: cannot write %s\n", options.out.c_str());
      return 1;
    }
    std::uint64_t total_dropped = 0;
    for (auto d : dropped) total_dropped += d;
    results.push_back({"sequential", seconds, image.mean(), total_dropped});
  }

  // 2. The library's methods on the same adapter, through one protocol.
  try {
    results.push_back(render_progressive("pt", room, segpath::PathTracer<Room>({8, segpath::MisHeuristic::power, 3, options.seed}),
                                         options, threads, suffixed(options.out, "pt")));
    segpath::VcmOptions vcm;  // the defaults: merge radius from the pixel footprint
    vcm.max_length = 8;
    vcm.seed = options.seed;
    results.push_back(render_progressive("vcm", room, segpath::VertexConnectionMerging<Room>(vcm), options, threads,
                                         suffixed(options.out, "vcm")));
    segpath::FilteringOptions<T> bdpf;  // BDPF, the paper's method, with its defaults
    bdpf.max_length = 8;
    bdpf.seed = options.seed;
    results.push_back(render_progressive("bdpf", room, segpath::SegmentFiltering<Room>(bdpf), options, threads,
                                         suffixed(options.out, "bdpf")));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "segpath-demo: %s\n", e.what());
    return 1;
  }

  std::printf("segpath-demo: %ux%u, %u spp, %u threads -> %s (and -pt, -vcm, -bdpf)\n", options.width, options.height,
              options.spp, threads, options.out.c_str());
  for (const Result& r : results)
    std::printf("  %-10s  mean %.4f  %7.2f s  %llu dropped\n", r.name.c_str(), r.mean, r.seconds,
                static_cast<unsigned long long>(r.dropped));
  return 0;
}
