// VCM / BDPT / BPM MIS weights against the brute-force heuristic over explicit full-path
// densities (every technique's density built from the samplers' pdf functions), options
// validation, and the hash grid against a linear scan.
#include <segpath/algorithms/vcm.hpp>
#include <segpath/sensors/pinhole_camera.hpp>
#include <segpath/testing/sphere_interior.hpp>

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

/// The sphere interior seen through a pinhole at its centre (so t = 1 techniques exist).
template <class Base>
class PinholeView : public Base {
 public:
  using T = typename Base::Scalar;
  template <class... Args>
  PinholeView(const PinholeCameraParameters<T>& camera, Args&&... args)
      : Base(std::forward<Args>(args)...), camera_(camera) {}
  [[nodiscard]] const PinholeCamera<T>& sensor() const noexcept { return camera_; }

 private:
  PinholeCamera<T> camera_;
};

using Sphere = PinholeView<testing::SphereInterior<double>>;

Sphere make_sphere() {
  testing::SphereInteriorParameters<double> p;
  p.radius = 1.3;
  p.emission_gradient = {0.4, 0, -0.5};
  p.albedo_mean = 0.5;
  p.albedo_gradient = {0, 0.2, 0.15};
  PinholeCameraParameters<double> c;
  c.position = {0.1, -0.2, 0.05};
  c.forward = {0, 0, 1};
  c.right = {1, 0, 0};
  c.up = {0, 1, 0};
  c.width = 3;
  c.height = 2;
  c.fov_x_degrees = 60;
  c.fov_y_degrees = 50;
  return Sphere(c, p, std::vector<Vec3<double>>{{0, 0, 1}});
}

enum class Kind { emission, nee, connect, camera, merge };

struct Technique {
  Kind kind;
  std::size_t index;  ///< camera ends for connect/merge
  double density;     ///< n_i p_i of the whole path
};

/// Every technique's full-path density for the path v[0] (pinhole) .. v[k] (light end). With
/// `roulette` every scattering's density also carries the roulette's continuation probability,
/// the albedo on the sphere's Lambertian surface (core/roulette.hpp: f cos / p = rho).
struct BruteForce {
  BruteForce(const Sphere& s, std::uint32_t p, double n, double r, bool rr)
      : scene(s), pixel(p), light_paths(n), radius(r), roulette(rr) {}
  const Sphere& scene;
  std::uint32_t pixel;
  double light_paths;
  double radius;
  bool roulette;
  SensorStartSampler<Sphere> sensor_start;
  NextSegmentSampler<Sphere, DiracKernel<double>> next{DiracKernel<double>{}};
  LightStartSampler<Sphere> light_start;
  LightNextSegmentSampler<Sphere, DiracKernel<double>> light_next{DiracKernel<double>{}};
  LightBridgeSampler<Sphere, DiracKernel<double>> light_bridge{DiracKernel<double>{}};
  SensorBridgeSampler<Sphere, DiracKernel<double>> sensor_bridge{DiracKernel<double>{}};

  /// Camera-side density of segment i (v[i-1], v[i]).
  double camera(const std::vector<SurfacePoint<double>>& v, std::size_t i) const {
    const Segment<double> s{v[i - 1], v[i]};
    if (i == 1) return sensor_start.pdf(scene, {pixel}, s);
    const Segment<double> prev{v[i - 2], v[i - 1]};
    return next.pdf(scene, {prev}, s) * continuation(v[i - 1]);
  }
  /// Light-side density of segment i (v[i-1], v[i]).
  double light(const std::vector<SurfacePoint<double>>& v, std::size_t i) const {
    const Segment<double> s{v[i - 1], v[i]};
    if (i + 1 == v.size()) return light_start.pdf(scene, {}, s);
    const Segment<double> after{v[i], v[i + 1]};
    return light_next.pdf(scene, {after}, s) * continuation(v[i]);
  }
  double continuation(const SurfacePoint<double>& scattering) const {
    return roulette ? scene.albedo_at(scattering.position) : 1.0;
  }

  std::vector<Technique> techniques(const std::vector<SurfacePoint<double>>& v, VcmMode mode) const {
    const std::size_t k = v.size() - 1;
    const bool vc = mode == VcmMode::bdpt || mode == VcmMode::vcm;
    const bool vm = mode == VcmMode::bpm || mode == VcmMode::vcm;
    auto camera_prefix = [&](std::size_t n) {
      double p = 1;
      for (std::size_t i = 1; i <= n; ++i) p *= camera(v, i);
      return p;
    };
    auto light_suffix = [&](std::size_t from) {  // segments from..k sampled from the light
      double p = 1;
      for (std::size_t i = from; i <= k; ++i) p *= light(v, i);
      return p;
    };
    std::vector<Technique> out;
    if (vc) {
      out.push_back({Kind::emission, k, camera_prefix(k)});
      const Segment<double> prev{v[k - 2], v[k - 1]};
      out.push_back({Kind::nee, k - 1, camera_prefix(k - 1) * light_bridge.pdf(scene, {prev}, Segment<double>{v[k - 1], v[k]})});
      for (std::size_t c = 1; c + 2 <= k; ++c) out.push_back({Kind::connect, c, camera_prefix(c) * light_suffix(c + 2)});
      const Segment<double> second{v[1], v[2]};
      out.push_back({Kind::camera, 0,
                     light_paths * sensor_bridge.pdf(scene, {second}, Segment<double>{v[0], v[1]}) * light_suffix(2)});
    }
    if (vm)
      for (std::size_t i = 1; i + 1 <= k; ++i)
        out.push_back({Kind::merge, i, light_paths * pi<double> * radius * radius * camera_prefix(i) * light_suffix(i + 1)});
    return out;
  }
};

}  // namespace

TEST_CASE("VCM, BDPT and BPM weights equal the brute-force heuristic over full-path densities", "[algorithms][vcm]") {
  const Sphere scene = make_sphere();
  const double radius = 0.05;
  const std::uint32_t light_paths = 7;
  Pcg32 rng(2024, 5);
  std::size_t checked = 0;
  for (const bool roulette : {false, true})
  for (const VcmMode mode : {VcmMode::bdpt, VcmMode::vcm, VcmMode::bpm}) {
    for (const MisHeuristic h : {MisHeuristic::balance, MisHeuristic::power}) {
      VcmOptions o;
      o.mode = mode;
      o.heuristic = h;
      o.max_length = 12;
      o.roulette_from = roulette ? 1 : 0;
      const VertexConnectionMerging<Sphere> vcm(o);
      const auto it = vcm.iteration_constants(scene, radius, light_paths);
      REQUIRE(it.camera_connectable == (mode != VcmMode::bpm));
      for (int trial = 0; trial < 60; ++trial) {
        const std::size_t k = 2 + std::size_t(trial % 6);
        // v[1] through a random pixel; the other ends uniform on the sphere.
        const std::uint32_t pixel = rng.next_u32() % scene.sensor().pixel_count();
        const auto ray = scene.sensor().sample_ray({pixel, rng.uniform2<double>(), rng.uniform2<double>()});
        REQUIRE(ray);
        const auto hit = scene.intersect({Ray<double>{ray->origin.position, ray->direction}});
        REQUIRE(hit);
        std::vector<SurfacePoint<double>> v{ray->origin, hit->point};
        while (v.size() <= k) v.push_back(scene.sample_area({rng.uniform2<double>()})->point);
        const BruteForce bf(scene, pixel, double(light_paths), radius, roulette);
        const auto techniques = bf.techniques(v, mode);
        double denominator = 0;
        for (const auto& t : techniques) denominator += mis_term(t.density, h);
        REQUIRE(denominator > 0);

        std::vector<VcmVertex<double>> cam(k + 1), light(k + 1);
        double weight_sum = 0;
        for (const auto& t : techniques) {
          double w = -1;
          const std::span<const SurfacePoint<double>> points(v);
          switch (t.kind) {
            case Kind::emission: {
              REQUIRE(vcm.camera_vertices(scene, it, points.first(k + 1), cam) == k);
              w = vcm.emission_weight(scene, it, v[k - 1], cam[k - 1]);
              break;
            }
            case Kind::nee: {
              REQUIRE(vcm.camera_vertices(scene, it, points.first(k), cam) == k - 1);
              const Segment<double> prev{v[k - 2], v[k - 1]};
              const Segment<double> s{v[k - 1], v[k]};
              SegmentSample<double> e{s, s.direction(), 0, bf.light_bridge.pdf(scene, {prev}, s), 0, false};
              w = vcm.nee_weight(scene, it, cam[k - 2], e);
              break;
            }
            case Kind::connect:
            case Kind::merge: {
              const std::size_t c = t.index;
              REQUIRE(vcm.camera_vertices(scene, it, points.first(c + 1), cam) == c);
              // Light ends from v[k] down to v[c + 1] (connect) or v[c] (merge).
              const std::size_t last = t.kind == Kind::connect ? c + 1 : c;
              std::vector<SurfacePoint<double>> reversed(v.rbegin(), v.rbegin() + std::ptrdiff_t(k - last + 1));
              REQUIRE(vcm.light_vertices(scene, it, reversed, light) == k - last);
              w = t.kind == Kind::connect ? vcm.connection_weight(scene, it, cam[c - 1], light[k - last - 1])
                                          : vcm.merge_weight(scene, it, cam[c - 1], light[k - last - 1]);
              break;
            }
            case Kind::camera: {
              std::vector<SurfacePoint<double>> reversed(v.rbegin(), v.rend() - 1);
              REQUIRE(vcm.light_vertices(scene, it, reversed, light) == k - 1);
              const Segment<double> s{v[0], v[1]};
              SegmentSample<double> b{s, s.direction(), 0, 1, 0, false};
              w = vcm.camera_connection_weight(scene, it, light[k - 2], b);
              break;
            }
          }
          const double expected = mis_term(t.density, h) / denominator;
          INFO(to_string(mode) << (h == MisHeuristic::power ? " power" : " balance") << (roulette ? ", roulette" : "") << " k=" << k << " technique "
                               << int(t.kind) << "/" << t.index << ": " << w << " vs " << expected);
          CHECK(std::abs(w - expected) <= 1e-6 * expected + 1e-12);
          weight_sum += w;
          ++checked;
        }
        CHECK(weight_sum == Approx(1).epsilon(1e-9));
      }
    }
  }
  CHECK(checked > 2000);
}

TEST_CASE("VCM rejects bad options with clear messages", "[algorithms][vcm]") {
  using V = VertexConnectionMerging<Sphere>;
  const auto message_of = [](VcmOptions o) -> std::string {
    try {
      V v(o);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  VcmOptions o;
  o.initial_radius = -1;
  CHECK(message_of(o).find("initial_radius") != std::string::npos);
  o = {};
  for (const double alpha : {0.0, 1.0, -0.5, 1.5}) {
    o.alpha = alpha;
    CHECK(message_of(o).find("alpha") != std::string::npos);
  }
  o = {};
  o.light_path_factor = 0;
  CHECK(message_of(o).find("light_path_factor") != std::string::npos);
  o = {};
  o.max_length = 0;
  CHECK(message_of(o).find("max_length") != std::string::npos);
  // A mode cast from a number out of range failed only at render time, naming the radius.
  o = {};
  o.mode = VcmMode(9);
  CHECK(message_of(o).find("mode or heuristic out of its enumeration's range (9, ") != std::string::npos);
  o = {};
  o.heuristic = MisHeuristic(5);
  CHECK(message_of(o).find("out of its enumeration's range") != std::string::npos);
  CHECK(message_of(VcmOptions{}).empty());

  const Sphere scene = make_sphere();
  const V v{VcmOptions{}};
  Framebuffer<double> wrong(2, 2);
  DropCounters drops;
  CHECK_THROWS_AS(v.render_iteration(scene, 0, wrong, drops, SerialFor{}), std::invalid_argument);
  Framebuffer<double> image(3, 2);
  CHECK_THROWS_AS(v.render_iteration_at(scene, 0, 0.0, image, drops, SerialFor{}), std::invalid_argument);
}

TEST_CASE("VCM refuses a merge radius whose MIS factors leave the scalar type's range", "[algorithms][vcm]") {
  // In float, eta = pi r^2 N and its power heuristic enter every MIS partial sum: on box 1 at
  // 32 x 32 (1,024 light paths) radius 1e-10 rendered 2 % dark and 1e-19 26 % dark (whole
  // techniques' weights overflowed to 0) without a word. BPM and PPM do not weigh by eta.
  using FloatSphere = PinholeView<testing::SphereInterior<float>>;
  testing::SphereInteriorParameters<float> p;
  PinholeCameraParameters<float> c;
  c.forward = {0, 0, 1};
  c.right = {1, 0, 0};
  c.up = {0, 1, 0};
  c.width = 32;
  c.height = 32;
  const FloatSphere scene(c, p, std::vector<Vec3<float>>{{0, 0, 1}});
  Framebuffer<float> image(32, 32);
  DropCounters drops;
  const auto message_at = [&](VcmMode mode, float radius) -> std::string {
    VcmOptions o;
    o.mode = mode;
    try {
      VertexConnectionMerging<FloatSphere>(o).render_iteration_at(scene, 0, radius, image, drops, SerialFor{});
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  using V = VertexConnectionMerging<FloatSphere>;
  CHECK(V::max_mis_factor == Approx(std::numeric_limits<float>::max() * 1e-14f));
  // The range for 1,024 light paths and the power heuristic: eta^2 and eta^-2 at most 3.4e24.
  const std::string small = message_at(VcmMode::vcm, 1e-10f);
  CHECK(small.find("merge radius 1e-10 with 1024 light paths") != std::string::npos);
  CHECK(small.find("use a radius from 1.3e-08 to 2.39e+04") != std::string::npos);
  CHECK_FALSE(message_at(VcmMode::vcm, 1e5f).empty());
  CHECK(message_at(VcmMode::vcm, 1e-6f).empty());
  CHECK(message_at(VcmMode::vcm, 1e4f).empty());
  CHECK(message_at(VcmMode::bpm, 1e-10f).empty());
  CHECK(message_at(VcmMode::ppm, 1e-10f).empty());
  CHECK(message_at(VcmMode::bdpt, 1e-10f).empty());  // no merging: the radius is ignored
  // BPM and PPM: the merge's normalisation 1 / (pi r^2 N) within the same factor. r^2 of 1e-20
  // is denormal in float and of 1e20 infinite; both rendered a black image with no drop.
  for (const VcmMode mode : {VcmMode::bpm, VcmMode::ppm}) {
    const std::string tiny = message_at(mode, 1e-20f), huge = message_at(mode, 1e20f);
    CHECK(tiny.find("merge radius 1e-20 with 1024 light paths puts the merge's normalisation") != std::string::npos);
    CHECK(tiny.find("use a radius from 9.56e-15 to 3.25e+10") != std::string::npos);
    CHECK(huge.find("merge radius 1e+20") != std::string::npos);
    CHECK(message_at(mode, 1e-14f).empty());
    CHECK(message_at(mode, 1e10f).empty());
  }
}

TEST_CASE("the kernel radius follows ProgressiveRadius from iteration 0", "[algorithms][vcm]") {
  VcmOptions o;
  o.initial_radius = 0.2;
  o.alpha = 0.5;
  const VertexConnectionMerging<Sphere> v(o);
  const Sphere scene = make_sphere();
  const KernelSchedule<double> k = v.kernel_schedule(scene);
  CHECK(k.at(0) == Approx(0.2));
  CHECK(k.at(1) == Approx(0.2 * std::sqrt(0.75)));
  CHECK(k.at(2) == Approx(0.2 * std::sqrt(0.75 * 2.5 / 3)));
  o.mode = VcmMode::bdpt;
  CHECK_FALSE(VertexConnectionMerging<Sphere>(o).kernel_schedule(scene).has_kernel());
}

// A renderer estimates a large render's memory from a small one's (segpath-render's pilot), so
// what an iteration reports must follow its light paths, not a constant or a capacity.
TEST_CASE("VCM's light-path bytes follow the light paths of an iteration", "[algorithms][vcm]") {
  const Sphere scene = make_sphere();
  const auto bytes_after_one_iteration = [&](VcmMode mode, double light_path_factor) {
    VcmOptions o;
    o.mode = mode;
    o.initial_radius = 0.1;
    o.light_path_factor = light_path_factor;
    o.roulette_from = 1;  // light subpaths of many lengths
    const VertexConnectionMerging<Sphere> v(o);
    Framebuffer<double> image(3, 2);
    DropCounters drops;
    v.render_iteration(scene, 0, image, drops, SerialFor{});
    return double(v.light_path_bytes());
  };
  for (const VcmMode mode : {VcmMode::bdpt, VcmMode::ppm, VcmMode::vcm}) {
    INFO("mode " << to_string(mode));
    const double small = bytes_after_one_iteration(mode, 2000), large = bytes_after_one_iteration(mode, 7000);
    CHECK(large / small == Approx(3.5).epsilon(0.05));
  }
  // Merging keeps the photons and their grid besides the ends BDPT keeps.
  CHECK(bytes_after_one_iteration(VcmMode::vcm, 2000) > 1.2 * bytes_after_one_iteration(VcmMode::bdpt, 2000));
}
