// Path tracing with next-event estimation and light tracing: unbiased against closed forms.
//  - PT inside the sphere: every probe against the truncated closed form;
//  - PT and LT through a real pinhole over the lit planes: every pixel against the pixel
//    average of the closed-form radiance, computed by quadrature over the pixel.
#include <segpath/algorithms/light_tracer.hpp>
#include <segpath/algorithms/path_tracer.hpp>
#include <segpath/sensors/pinhole_camera.hpp>
#include <segpath/testing/integrate.hpp>
#include <segpath/testing/lit_plane.hpp>
#include <segpath/testing/sphere_interior.hpp>
#include <segpath/testing/statistics.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

template <class S>
struct RecordingSink {
  S value{};
  std::uint64_t drops = 0;
  void add(std::uint32_t, const S& v) noexcept { value += v; }
  void drop(DropReason) noexcept { ++drops; }
};

/// Splats into per-pixel running sums (one light path = one sample of every pixel).
template <class S>
struct SplatSink {
  std::vector<double>* pixels;
  std::uint64_t drops = 0;
  void add(std::uint32_t p, const S& v) noexcept { (*pixels)[p] += double(v); }
  void drop(DropReason) noexcept { ++drops; }
};

/// An analytic scene seen through a pinhole instead of its probes.
template <class Base>
class Photographed : public Base {
 public:
  using T = typename Base::Scalar;
  template <class... Args>
  Photographed(const PinholeCameraParameters<T>& camera, Args&&... args) : Base(std::forward<Args>(args)...), camera_(camera) {}
  [[nodiscard]] const PinholeCamera<T>& sensor() const noexcept { return camera_; }

 private:
  PinholeCamera<T> camera_;
};

/// A 4 x 4 pinhole 0.6 above the plane looking straight down.
template <class T>
PinholeCameraParameters<T> downward_camera() {
  PinholeCameraParameters<T> c;
  c.position = {T(0.1), T(-0.05), T(0.6)};
  c.forward = {0, 0, -1};
  c.right = {1, 0, 0};
  c.up = {0, 1, 0};
  c.width = 4;
  c.height = 4;
  c.fov_x_degrees = 70;
  c.fov_y_degrees = 70;
  return c;
}

/// The expected value of a pixel: the closed-form radiance at the plane point each ray
/// through the pixel hits, averaged over the pixel (box filter).
template <class Scn>
double pixel_expectation(const Scn& scene, std::uint32_t pixel) {
  using T = typename Scn::Scalar;
  const auto& camera = scene.sensor();
  return testing::integrate_2d(
      [&](glm::dvec2 u) {
        const auto ray = camera.sample_ray(SensorSampleQuery<T>{pixel, Vec2<T>(0.5), Vec2<T>(T(u.x), T(u.y))});
        const double t = -double(ray->origin.position.z) / double(ray->direction.z);
        const Vec3<T> hit = ray->origin.position + ray->direction * T(t);
        return double(scene.radiance_at(hit));
      },
      glm::dvec2(0), glm::dvec2(1), 8, 8);
}

}  // namespace

TEMPLATE_TEST_CASE("path tracing with NEE is unbiased inside the sphere", "[algorithms][stat]", float, double) {
  using T = TestType;
  testing::SphereInteriorParameters<T> p;
  p.radius = T(1.3);
  p.emission_gradient = {T(0.4), 0, T(-0.5)};
  p.albedo_mean = T(0.5);
  p.albedo_gradient = {0, T(0.2), T(0.15)};
  const testing::SphereInterior<T> scene(p, {{0, 0, 1}, {1, -1, 0}, {-0.2, 0.3, -0.9}});
  const std::size_t max_length = 6;
  const PathTracer<testing::SphereInterior<T>> pt({max_length, MisHeuristic::power, 0});
  const double alpha = testing::sidak_alpha(0.01, 2 * 3 * 2);
  for (std::uint32_t pixel = 0; pixel < 3; ++pixel) {
    double expected = 0;
    for (unsigned k = 0; k < max_length; ++k) expected += scene.bounce_radiance_at(scene.probe_target(pixel), k);
    testing::RunningStats stats;
    std::uint64_t drops = 0;
    for (std::uint64_t i = 0; i < 20000; ++i) {
      Pcg32 rng = Pcg32::for_sample(17, pixel, i);
      RecordingSink<T> sink;
      pt.estimate(scene, {pixel, i}, rng, sink);
      stats.add(double(sink.value));
      drops += sink.drops;
    }
    INFO("probe " << pixel << ": " << stats.mean() << " +- " << stats.standard_error() << " vs " << expected);
    CHECK(drops == 0);
    CHECK_FALSE(testing::student_t_test(stats, expected).rejects(alpha));
    CHECK(testing::student_t_test(stats, 1.02 * expected).rejects(alpha));  // the test has power
  }
}

// Russian roulette (core/roulette.hpp) inside a uniform sphere (emission 1, albedo rho = 0.2):
// cosine sampling and uniform area sampling have the same density there, so the MIS weights
// are 1/2 and bounce k adds (rho beta_k + beta_{k+1}) / 2, beta_k the throughput of the path's
// first k segments. With the scattering-weight rule the roulette keeps beta where it starts,
// beta_k = rho^(min(k, r) - 1) for roulette from length r, which bounds every sample; the mean
// must stay the closed form. The throughput rule (q = max beta) lifts a surviving path to
// beta ~ 1 and breaks the bound for r >= 2.
TEMPLATE_TEST_CASE("path tracing with Russian roulette stays unbiased and never lifts a path's throughput", "[algorithms][stat]",
                   float, double) {
  using T = TestType;
  testing::SphereInteriorParameters<T> p;
  p.emission_mean = 1;
  p.albedo_mean = T(0.2);
  const testing::SphereInterior<T> scene(p, {{0, 0, 1}, {T(0.6), T(-0.8), 0}});
  const std::size_t max_length = 8;
  const double rho = 0.2;
  const double alpha = testing::sidak_alpha(0.01, 2 * 3 * 2 * 2);
  for (const std::size_t roulette_from : {std::size_t(1), std::size_t(2), std::size_t(3)}) {
    auto beta = [&](std::size_t k) { return std::pow(rho, double(std::min(k, roulette_from)) - 1); };
    double bound = 1;
    for (std::size_t k = 1; k < max_length; ++k) bound += (rho * beta(k) + beta(k + 1)) / 2;
    const PathTracer<testing::SphereInterior<T>> pt({max_length, MisHeuristic::power, roulette_from});
    for (std::uint32_t pixel = 0; pixel < 2; ++pixel) {
      double expected = 0;
      for (unsigned k = 0; k < max_length; ++k) expected += scene.bounce_radiance_at(scene.probe_target(pixel), k);
      testing::RunningStats stats;
      double largest = 0;
      for (std::uint64_t i = 0; i < 20000; ++i) {
        Pcg32 rng = Pcg32::for_sample(29, pixel, i);
        RecordingSink<T> sink;
        pt.estimate(scene, {pixel, i}, rng, sink);
        stats.add(double(sink.value));
        largest = std::max(largest, double(sink.value));
      }
      INFO("roulette from " << roulette_from << ", probe " << pixel << ": " << stats.mean() << " +- " << stats.standard_error()
                            << " vs " << expected << ", largest sample " << largest << " (bound " << bound << ")");
      CHECK(largest <= bound * (1 + 1e-4));
      CHECK(stats.standard_error() > 0);  // the roulette ran
      CHECK_FALSE(testing::student_t_test(stats, expected).rejects(alpha));
      CHECK(testing::student_t_test(stats, 1.02 * expected).rejects(alpha));  // the test has power
    }
  }
}

TEMPLATE_TEST_CASE("path tracing and light tracing agree with the lit planes pixel by pixel", "[algorithms][stat]",
                   float, double) {
  using T = TestType;
  const auto camera = downward_camera<T>();
  const Photographed<testing::PointLitPlane<T>> point_lit(camera, testing::PointLitPlaneParameters<T>{2, 1, T(1.5), T(0.6)},
                                                          std::vector<Vec2<T>>{{0, 0}});
  const Photographed<testing::DiskLitPlane<T>> disk_lit(camera, testing::DiskLitPlaneParameters<T>{2, 1, T(0.5), 2, T(0.6)},
                                                        std::vector<Vec2<T>>{{0, 0}});
  static_assert(LightSampledScene<Photographed<testing::PointLitPlane<T>>>);
  const double alpha = testing::sidak_alpha(0.01, 2 * 2 * 2 * 16);
  auto check_scene = [&](const auto& scene, const char* name) {
    using Scn = std::remove_cvref_t<decltype(scene)>;
    const PathTracer<Scn> pt({4, MisHeuristic::balance, 0});
    const LightTracer<Scn> lt({4, 0});
    const std::uint32_t pixels = scene.sensor().pixel_count();
    // Path tracing, pixel by pixel.
    for (std::uint32_t pixel = 0; pixel < pixels; ++pixel) {
      testing::RunningStats stats;
      for (std::uint64_t i = 0; i < 4000; ++i) {
        Pcg32 rng = Pcg32::for_sample(3, pixel, i);
        RecordingSink<T> sink;
        pt.estimate(scene, {pixel, i}, rng, sink);
        stats.add(double(sink.value));
      }
      const double expected = pixel_expectation(scene, pixel);
      INFO(name << " PT pixel " << pixel << ": " << stats.mean() << " +- " << stats.standard_error() << " vs " << expected);
      CHECK(expected > 0);
      CHECK_FALSE(testing::student_t_test(stats, expected).rejects(alpha));
    }
    // Light tracing: every light path is one sample of every pixel.
    std::vector<testing::RunningStats> stats(pixels);
    std::vector<double> splat(pixels);
    std::uint64_t drops = 0;
    for (std::uint64_t i = 0; i < 60000; ++i) {
      std::fill(splat.begin(), splat.end(), 0.0);
      Pcg32 rng = Pcg32::for_sample(4, 0, i);
      SplatSink<T> sink{&splat};
      lt.estimate(scene, {0, i}, rng, sink);
      drops += sink.drops;
      for (std::uint32_t p = 0; p < pixels; ++p) stats[p].add(splat[p]);
    }
    CHECK(drops == 0);
    for (std::uint32_t p = 0; p < pixels; ++p) {
      const double expected = pixel_expectation(scene, p);
      INFO(name << " LT pixel " << p << ": " << stats[p].mean() << " +- " << stats[p].standard_error() << " vs " << expected);
      CHECK_FALSE(testing::student_t_test(stats[p], expected).rejects(alpha));
    }
  };
  check_scene(point_lit, "point-lit plane");
  check_scene(disk_lit, "disk-lit plane");
}

// A fast check for the sanitizer build (which runs no [stat] test): path tracing with NEE inside
// the sphere, 1500 samples per probe, within 5 standard errors (fixed seeds: deterministic). It
// catches an NEE weight in the wrong measure, not small biases.
TEST_CASE("path tracing with NEE: a fast sphere check for the sanitizer run", "[algorithms]") {
  using T = double;
  testing::SphereInteriorParameters<T> p;
  p.radius = T(1.3);
  p.emission_gradient = {T(0.4), 0, T(-0.5)};
  p.albedo_mean = T(0.5);
  const testing::SphereInterior<T> scene(p, {{0, 0, 1}, {1, -1, 0}});
  const std::size_t max_length = 4;
  const PathTracer<testing::SphereInterior<T>> pt({max_length, MisHeuristic::power, 0});
  for (std::uint32_t pixel = 0; pixel < 2; ++pixel) {
    double expected = 0;
    for (unsigned k = 0; k < max_length; ++k) expected += scene.bounce_radiance_at(scene.probe_target(pixel), k);
    testing::RunningStats stats;
    for (std::uint64_t i = 0; i < 1500; ++i) {
      Pcg32 rng = Pcg32::for_sample(23, pixel, i);
      RecordingSink<T> sink;
      pt.estimate(scene, {pixel, i}, rng, sink);
      stats.add(double(sink.value));
    }
    INFO("probe " << pixel << ": " << stats.mean() << " +- " << stats.standard_error() << " vs " << expected);
    CHECK(std::abs(stats.mean() - expected) <= 5 * stats.standard_error());
    CHECK(stats.standard_error() < 0.03 * expected);
  }
}

TEST_CASE("path and light tracers reject bad options", "[algorithms]") {
  using Scn = testing::SphereInterior<double>;
  CHECK_THROWS_AS(PathTracer<Scn>({0, MisHeuristic::power, 0}), std::invalid_argument);
}
