// segpath-demo: a renderer author's own scene adapter, rendered with segpath.
//
// The user's types here — a room of rectangles and spheres with a brute-force intersector,
// a pinhole camera and a material table — model segpath's concepts (static_assert below);
// the library supplies the Lambertian BRDF, the Dirac kernel and the sequential estimator
// (segment path tracing). Usage:
//   segpath-demo [--out FILE.png] [--spp N] [--width W] [--height H] [--threads N] [--seed S]
#include <segpath/estimators/sequential.hpp>
#include <segpath/kernels/dirac.hpp>
#include <segpath/materials/lambertian.hpp>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
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
    wall({T(-0.5), T(-0.5), T(0.98)}, {0, T(1), 0}, {T(1), 0, 0}, light);  // ceiling lamp, facing down
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
    [[nodiscard]] const segpath::Lambertian<Color>& of(const segpath::SurfacePoint<T>& p) const noexcept {
      return room->materials_[p.material_id < material_count ? p.material_id : white];
    }
  };
  struct Lamp {
    [[nodiscard]] Color radiance(const segpath::EmissionQuery<T>& q) const noexcept {
      const bool lit = q.point.material_id == light && glm::dot(q.to_sensor, q.point.normal) > T(0);
      return lit ? Color(T(5), T(4.6), T(4)) : Color(T(0));
    }
  };
  [[nodiscard]] Materials bsdf() const noexcept { return Materials{this}; }
  [[nodiscard]] Lamp emitter() const noexcept { return {}; }
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

struct Options {
  std::string out = "segpath-demo.png";
  std::uint32_t spp = 64, width = 256, height = 256, threads = 0;
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

}  // namespace

int main(int argc, char** argv) {
  const Options options = parse(argc, argv);
  const Room room(options.width, options.height);
  const segpath::SequentialEstimator<Room, segpath::DiracKernel<T>> estimator(segpath::DiracKernel<T>{}, {1, 8});
  examples::Image image(int(options.width), int(options.height));
  const unsigned threads = options.threads ? options.threads : std::max(1u, std::thread::hardware_concurrency());
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

  std::vector<unsigned char> ldr(image.pixels.size() * 3);
  for (std::size_t i = 0; i < image.pixels.size(); ++i)
    for (int c = 0; c < 3; ++c)
      ldr[3 * i + std::size_t(c)] = static_cast<unsigned char>(examples::to_srgb(image.pixels[i][c]) * 255.0f + 0.5f);
  const std::filesystem::path out(options.out);
  if (out.has_parent_path()) std::filesystem::create_directories(out.parent_path());
  if (!stbi_write_png(options.out.c_str(), int(options.width), int(options.height), 3, ldr.data(), int(options.width) * 3)) {
    std::fprintf(stderr, "segpath-demo: cannot write %s\n", options.out.c_str());
    return 1;
  }
  std::filesystem::path pfm = out;
  examples::write_pfm(image, pfm.replace_extension(".pfm").string());
  std::uint64_t total_dropped = 0;
  for (auto d : dropped) total_dropped += d;
  const double samples = double(options.spp) * options.width * options.height;
  std::printf("segpath-demo: segment path tracing, %ux%u, %u spp, %u threads, %.2f s, %.2f M samples/s, mean %.4f, %llu dropped -> %s\n",
              options.width, options.height, options.spp, threads, seconds, samples / seconds * 1e-6, image.mean(),
              static_cast<unsigned long long>(total_dropped), options.out.c_str());
  return 0;
}
