// segpath-custom-technique: a researcher's own segment sampler joins BDPF's technique set.
//
// CosineSurfaceSampler (cosine_surface_sampler.hpp, written outside the library) draws segments
// from uniformly chosen surface points; SegmentFiltering<Scene, CosineSurfaceSampler> adds its
// draws to the pool and its density to every MMIS denominator. The scene is the test kit's
// sphere-interior furnace seen through a pinhole, whose image mean has a closed form: the program
// prints BDPF's mean with and without the extra technique next to it, at two voxel sizes. Usage:
//   segpath-custom-technique [ITERATIONS]
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/render/progressive.hpp>
#include <segpath/testing/sphere_interior.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "custom_technique/cosine_surface_sampler.hpp"

namespace {

using Scene = segpath::testing::PhotographedSphereInterior<double>;
using Cosine = example::CosineSurfaceSampler<Scene>;

/// The mean over pixels and iterations, and its standard error (iterations are independent), of
/// `iterations` iterations through the render protocol at a fixed voxel size.
template <class Method>
std::pair<double, double> image_mean(const Method& method, const Scene& scene, std::uint64_t iterations, double cell) {
  segpath::ProgressiveRender render(scene, method, scene.sensor().width(), scene.sensor().height(),
                                    segpath::KernelSchedule<double>::fixed(cell));
  double sum = 0, sum2 = 0, before = 0;  // before: the pixel sum after the previous iteration
  for (std::uint64_t i = 0; i < iterations; ++i) {
    render.iterate();
    double total = 0;
    for (const double v : render.sum().pixels()) total += v;
    const double mean = (total - before) / double(render.sum().pixel_count());
    before = total;
    sum += mean, sum2 += mean * mean;
  }
  const double n = double(iterations), mean = sum / n;
  return {mean, std::sqrt(std::max(0.0, sum2 / n - mean * mean) / (n - 1))};
}

}  // namespace

int main(int argc, char** argv) {
  const std::uint64_t iterations = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 20;
  if (iterations < 2) {
    std::fprintf(stderr, "segpath-custom-technique: ITERATIONS must be an integer >= 2\n");
    return 2;
  }
  const Scene scene(16);
  // The default furnace is uniform: every pixel's expectation is L truncated to paths of up to
  // max_length segments (max_length - 1 reflections).
  segpath::FilteringOptions<double> options;
  options.max_length = 6;
  double expected = 0;
  for (unsigned k = 0; k < options.max_length; ++k) expected += scene.bounce_radiance_at({0, 0, -1}, k);

  // Kernel estimation is biased O(voxel size) on the curved sphere: halving the voxel halves it.
  const segpath::SegmentFiltering<Scene> bdpf(options);
  const segpath::SegmentFiltering<Scene, Cosine> extended(options, segpath::FilteringTechnique<Cosine>{Cosine{}, 1.0});
  std::printf("closed form %.5f\n", expected);
  for (const double cell : {0.3, 0.15}) {
    const auto [plain, plain_error] = image_mean(bdpf, scene, iterations, cell);
    const auto [with_cosine, cosine_error] = image_mean(extended, scene, iterations, cell);
    std::printf("voxel %.2f: BDPF %.5f +- %.5f, BDPF + cosine technique %.5f +- %.5f\n", cell, plain, plain_error, with_cosine,
                cosine_error);
  }
  return 0;
}
