// S-D-S against a closed form (testing/submerged_plane.hpp): a Lambertian square under a flat
// dielectric interface, lit by a point light and seen from above through the interface. No
// vertex connection reaches the light; VCM's merging, PhF and BDPF (the Dirac light's chains
// through the interface) converge to the closed form as the kernel shrinks:
//  - at each of two kernel sizes the estimate agrees with the kernel's own expectation (the
//    disk average for VCM's merging, the tent average of a jittered voxel for filtering);
//  - the bias is resolved at the larger size and falls by the ratio of the two averages' biases;
//  - the closed form with the interface's Jacobian or the eta^2 radiance scaling left out is
//    rejected;
//  - MVF, which has no technique for the family, renders it black.
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/algorithms/vcm.hpp>
#include <segpath/testing/statistics.hpp>
#include <segpath/testing/submerged_plane.hpp>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

using Scn = testing::PointLitSubmergedPlane<double>;

const testing::SubmergedPlaneParameters<double> parameters{2, 0.5, 1, 1.5, 1, 0.5};
const std::vector<testing::SubmergedProbe<double>> probes{
    {Vec2<double>(0, 0), 0}, {Vec2<double>(0.6, 0), 0.5}, {Vec2<double>(-0.3, 0.5), -0.4}};
constexpr std::size_t max_length = 4;  // probe, interface, square, interface, light

/// One iteration into `image` (3 x 1, cleared), counting drops.
using Iteration = std::function<void(std::uint64_t, Framebuffer<double>&, DropCounters&)>;

std::vector<testing::RunningStats> run(const Iteration& iteration, std::uint64_t iterations) {
  std::vector<testing::RunningStats> stats(probes.size());
  DropCounters drops;
  for (std::uint64_t i = 0; i < iterations; ++i) {
    Framebuffer<double> image(static_cast<std::uint32_t>(probes.size()), 1);
    iteration(i, image, drops);
    for (std::uint32_t p = 0; p < probes.size(); ++p) stats[p].add(image[p]);
  }
  CHECK(drops.total() == 0);
  return stats;
}

/// The closed form with the flat interface's Jacobian left out: the inverse-square law along
/// the bent ray, E = I T cos theta_t / l^2 (l = a / cos theta + d / cos theta_t).
double radiance_without_jacobian(const Scn& scene, const Vec3<double>& x) {
  const double n = parameters.eta;
  const double s = scene.incidence_sine(std::hypot(x.x, x.y));
  const double c = std::sqrt(1 - s * s), c_t = std::sqrt(1 - s * s / (n * n));
  const double l = parameters.light_height / c + parameters.depth / c_t;
  return parameters.albedo / pi<double> * parameters.intensity * scene.transmittance(c) * c_t / (l * l);
}

/// The checks of the header comment for one method, given its runs at kernel sizes
/// `sizes[0] > sizes[1]` and the kernel's expectation of L at a target.
void check_convergence(const std::string& method, const Scn& scene, const double (&sizes)[2],
                       const std::vector<testing::RunningStats> (&stats)[2],
                       const std::function<double(const Vec3<double>&, double)>& kernel_average) {
  const double alpha = testing::sidak_alpha(0.01, 4 * probes.size() + 2);
  double bias[2], error[2], exact_bias[2];
  for (int k = 0; k < 2; ++k) {
    for (std::uint32_t p = 0; p < probes.size(); ++p) {
      const Vec3<double> x = scene.probe_target(p);
      const double factor = scene.probe_factor(p);
      const double expected = factor * kernel_average(x, sizes[k]);
      const testing::RunningStats& s = stats[k][p];
      INFO(method << ", kernel " << sizes[k] << ", probe " << p << ": " << s.mean() << " +- " << s.standard_error()
                  << ", kernel average " << expected << ", closed form " << scene.probe_radiance(p));
      CHECK_FALSE(testing::student_t_test(s, expected).rejects(alpha));
      if (k == 1) {
        // Wrong closed forms, carried to the kernel's expectation by the right one's ratio.
        const double smoothing = kernel_average(x, sizes[k]) / scene.radiance_at(x);
        CHECK(testing::student_t_test(s, expected * parameters.eta * parameters.eta).rejects(alpha));
        CHECK(testing::student_t_test(s, factor * smoothing * radiance_without_jacobian(scene, x)).rejects(alpha));
      }
    }
    // The bias at the foot of the light, where E curves most.
    const double truth = scene.probe_radiance(0);
    bias[k] = stats[k][0].mean() - truth;
    error[k] = stats[k][0].standard_error();
    exact_bias[k] = scene.probe_factor(0) * kernel_average(scene.probe_target(0), sizes[k]) - truth;
  }
  INFO(method << ": bias " << bias[0] << " +- " << error[0] << " at " << sizes[0] << ", " << bias[1] << " +- " << error[1]
              << " at " << sizes[1] << "; kernel averages' " << exact_bias[0] << ", " << exact_bias[1]);
  CHECK(std::abs(bias[0]) > 5 * error[0]);  // resolved at the larger kernel
  // It falls by the kernel averages' ratio (about 4: O(h^2) for a smooth E).
  const double ratio = bias[0] / bias[1];
  const double ratio_error = std::abs(ratio) * std::hypot(error[0] / bias[0], error[1] / bias[1]);
  CHECK(std::abs(ratio - exact_bias[0] / exact_bias[1]) < 3.5 * ratio_error);
  CHECK(std::abs(bias[1]) < std::abs(bias[0]) / 2);
}

VcmOptions vcm_options(VcmMode mode, double radius, std::uint64_t seed) {
  VcmOptions o;
  o.mode = mode;
  o.max_length = max_length;
  o.initial_radius = radius;
  o.light_path_factor = 1000;
  o.seed = seed;
  return o;
}

FilteringOptions<double> filtering_options(FilteringMode mode, std::uint64_t seed) {
  FilteringOptions<double> o;
  o.mode = mode;
  o.max_length = max_length;
  o.light_path_ratio = 1000;
  o.seed = seed;
  return o;
}

}  // namespace

TEST_CASE("S-D-S: PPM and VCM converge to the submerged plane's closed form", "[algorithms][stat]") {
  const Scn scene(parameters, probes);
  const double radii[2] = {0.6, 0.3};
  for (const VcmMode mode : {VcmMode::ppm, VcmMode::vcm}) {
    std::vector<testing::RunningStats> stats[2];
    for (int k = 0; k < 2; ++k) {
      const VertexConnectionMerging<Scn> method(vcm_options(mode, radii[k], 5 + k));
      stats[k] = run([&](std::uint64_t i, Framebuffer<double>& image,
                         DropCounters& drops) { method.render_iteration_at(scene, i, radii[k], image, drops, SerialFor{}); },
                     k == 0 ? 400 : 1600);
    }
    check_convergence(to_string(mode), scene, radii, stats,
                      [&](const Vec3<double>& x, double r) { return scene.disk_average_radiance(x, r); });
  }
}

TEST_CASE("S-D-S: PhF and BDPF converge to the submerged plane's closed form", "[algorithms][stat]") {
  const Scn scene(parameters, probes);
  const double cells[2] = {0.6, 0.3};
  for (const FilteringMode mode : {FilteringMode::phf, FilteringMode::bdpf}) {
    std::vector<testing::RunningStats> stats[2];
    for (int k = 0; k < 2; ++k) {
      const SegmentFiltering<Scn> method(filtering_options(mode, 9 + k));
      stats[k] = run([&](std::uint64_t i, Framebuffer<double>& image,
                         DropCounters& drops) { method.render_iteration_at(scene, i, cells[k], image, drops, SerialFor{}); },
                     k == 0 ? 400 : 1600);
    }
    check_convergence(to_string(mode), scene, cells, stats,
                      [&](const Vec3<double>& x, double h) { return scene.voxel_average_radiance(x, h); });
  }
}

TEST_CASE("S-D-S: MVF has no technique for a point light seen through glass", "[algorithms]") {
  const Scn scene(parameters, probes);
  const SegmentFiltering<Scn> method(filtering_options(FilteringMode::mvf, 3));
  for (std::uint64_t i = 0; i < 20; ++i) {
    Framebuffer<double> image(static_cast<std::uint32_t>(probes.size()), 1);
    DropCounters drops;
    method.render_iteration_at(scene, i, 0.3, image, drops, SerialFor{});
    for (std::uint32_t p = 0; p < probes.size(); ++p) CHECK(image[p] == 0);
  }
}
