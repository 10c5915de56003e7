// The render protocol (render/progressive.hpp): the image is the mean of the method's own
// iterations, numbered from 0, accumulated in double; a kernel method's automatic schedule is
// the pixel footprint's multiple and shrinks per iteration; the image does not depend on the
// ParallelFor; iterations rendered apart and added in index order, or resumed, give the same sum; a non-finite pixel is dropped and counted; PT and LT through the protocol agree
// with the furnace's closed form.
#include <segpath/algorithms/light_tracer.hpp>
#include <segpath/algorithms/path_tracer.hpp>
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/algorithms/vcm.hpp>
#include <segpath/render/progressive.hpp>
#include <segpath/sensors/pixel_footprint.hpp>
#include <segpath/testing/sphere_interior.hpp>
#include <segpath/testing/statistics.hpp>
#include <segpath/testing/two_threads.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

using Sphere = testing::PhotographedSphereInterior<float>;

/// The furnace seen through a 6 x 6 pinhole, with an albedo gradient so that pixels differ.
Sphere make_sphere() {
  testing::SphereInteriorParameters<float> p;
  p.albedo_gradient = {0.1f, 0.2f, 0.1f};
  return Sphere(6, p);
}

/// The mean of `iterations` iterations of the method's own render_iteration, summed in double.
template <class Method>
std::vector<double> own_loop(const Method& method, const Sphere& scene, std::uint64_t iterations) {
  std::vector<double> sum(scene.sensor().pixel_count(), 0.0);
  for (std::uint64_t i = 0; i < iterations; ++i) {
    Framebuffer<float> image(6, 6);
    DropCounters drops;
    method.render_iteration(scene, i, image, drops);
    for (std::uint32_t p = 0; p < image.pixel_count(); ++p) sum[p] += double(image[p]);
  }
  for (double& v : sum) v /= double(iterations);
  return sum;
}

template <class Method>
void check_same_as_own_loop(const Method& method, const Sphere& scene) {
  ProgressiveRender render(scene, method, 6, 6);
  for (int i = 0; i < 3; ++i) render.iterate();
  CHECK(render.iterations() == 3);
  const std::vector<double> expected = own_loop(method, scene, 3);
  const Framebuffer<double> image = render.image();
  double total = 0;
  for (std::uint32_t p = 0; p < image.pixel_count(); ++p) {
    CHECK(image[p] == expected[p]);
    total += image[p];
  }
  CHECK(total > 0);
}

/// A user's own method: pixel 0 non-finite in iteration 1, every pixel its iteration index.
struct Faulty {
  void render_iteration(const Sphere&, std::uint64_t iteration, Framebuffer<float>& image, DropCounters&,
                        const SerialFor&) const {
    for (std::uint32_t p = 0; p < image.pixel_count(); ++p) image.add(p, float(iteration));
    if (iteration == 1) image[0] = std::numeric_limits<float>::quiet_NaN();
  }
};

}  // namespace

TEST_CASE("the render protocol averages the method's own iterations, numbered from 0, in double", "[render]") {
  const Sphere scene = make_sphere();
  check_same_as_own_loop(PathTracer<Sphere>({5, MisHeuristic::power, 2, 7}), scene);
  check_same_as_own_loop(LightTracer<Sphere>({5, 2, 7}), scene);
  VcmOptions v;
  v.max_length = 5;
  v.seed = 7;
  v.roulette_from = 1;
  for (const VcmMode mode : {VcmMode::bdpt, VcmMode::ppm, VcmMode::bpm, VcmMode::vcm}) {
    v.mode = mode;
    check_same_as_own_loop(VertexConnectionMerging<Sphere>(v), scene);
  }
  FilteringOptions<float> f;
  f.max_length = 5;
  f.seed = 7;
  for (const FilteringMode mode : {FilteringMode::mvf, FilteringMode::phf, FilteringMode::bdpf}) {
    f.mode = mode;
    check_same_as_own_loop(SegmentFiltering<Sphere>(f), scene);
  }
}

TEST_CASE("kernel methods get an automatic kernel from the pixel footprint, shrinking per iteration", "[render]") {
  const Sphere scene = make_sphere();
  const float footprint = pixel_footprint(scene);
  // The sphere of radius 1 seen from its centre (distance 1) through 6 x 6 pixels of a 90-degree
  // pinhole: a pixel's side is 1/3 on the axis, (1/3) cos^1.5 at the corner pixels' cosine 0.647.
  CHECK(footprint > 0.17f);
  CHECK(footprint < 1.0f / 3);
  VcmOptions v;
  const ProgressiveRender vcm(scene, VertexConnectionMerging<Sphere>(v), 6, 6);
  CHECK(vcm.kernel_schedule().initial() == Approx(radius_in_footprints(VcmMode::vcm) * footprint));
  for (const VcmMode mode : {VcmMode::ppm, VcmMode::bpm}) {
    VcmOptions m;
    m.mode = mode;
    CHECK(ProgressiveRender(scene, VertexConnectionMerging<Sphere>(m), 6, 6).kernel_schedule().initial() ==
          Approx(radius_in_footprints(mode) * footprint));
  }
  CHECK(vcm.kernel_schedule().at(1) == Approx(vcm.kernel_schedule().at(0) * std::sqrt((1 + v.alpha) / 2)));
  v.initial_radius = 0.125;
  CHECK(ProgressiveRender(scene, VertexConnectionMerging<Sphere>(v), 6, 6).kernel_schedule().initial() == 0.125f);
  v.mode = VcmMode::bdpt;
  CHECK_FALSE(ProgressiveRender(scene, VertexConnectionMerging<Sphere>(v), 6, 6).kernel_schedule().has_kernel());
  const ProgressiveRender bdpf(scene, SegmentFiltering<Sphere>(FilteringOptions<float>{}), 6, 6);
  CHECK(bdpf.kernel_schedule().initial() == Approx(filtering::cell_in_footprints * footprint));
  CHECK_FALSE(ProgressiveRender(scene, PathTracer<Sphere>(), 6, 6).kernel_schedule().has_kernel());
}

TEST_CASE("a render with a fixed kernel renders every iteration at that size", "[render]") {
  const Sphere scene = make_sphere();
  FilteringOptions<float> f;
  f.max_length = 4;
  const SegmentFiltering<Sphere> bdpf(f);
  ProgressiveRender render(scene, bdpf, 6, 6, KernelSchedule<float>::fixed(0.3f));
  CHECK(render.kernel_schedule().at(5) == 0.3f);
  render.iterate();
  render.iterate();
  std::vector<double> expected(36, 0.0);
  for (std::uint64_t i = 0; i < 2; ++i) {
    Framebuffer<float> image(6, 6);
    DropCounters drops;
    bdpf.render_iteration_at(scene, i, 0.3f, image, drops);
    for (std::uint32_t p = 0; p < 36; ++p) expected[p] += double(image[p]);
  }
  for (std::uint32_t p = 0; p < 36; ++p) CHECK(render.sum()[p] == expected[p]);
  CHECK_THROWS_AS(KernelSchedule<float>::fixed(0.0f), std::invalid_argument);
  CHECK_THROWS_AS(ProgressiveRender(scene, bdpf, 6, 6, KernelSchedule<float>{}), std::invalid_argument);
}

TEST_CASE("the render protocol's image does not depend on the ParallelFor", "[render]") {
  const Sphere scene = make_sphere();
  ProgressiveRender serial(scene, SegmentFiltering<Sphere>(FilteringOptions<float>{}), 6, 6);
  ProgressiveRender threaded(scene, SegmentFiltering<Sphere>(FilteringOptions<float>{}), 6, 6);
  ProgressiveRender lt_serial(scene, LightTracer<Sphere>(), 6, 6), lt_threaded(scene, LightTracer<Sphere>(), 6, 6);
  for (int i = 0; i < 2; ++i) {
    const FilteringStats stats = serial.iterate();
    CHECK(stats.segments > 0);
    threaded.iterate(testing::TwoThreadFor{});
    lt_serial.iterate();
    lt_threaded.iterate(testing::TwoThreadFor{});
  }
  for (std::uint32_t p = 0; p < 36; ++p) {
    CHECK(serial.pixel(p) == threaded.pixel(p));
    CHECK(lt_serial.pixel(p) == lt_threaded.pixel(p));
  }
}

TEST_CASE("the render protocol drops and counts a non-finite pixel, and checks the image size", "[render]") {
  const Sphere scene = make_sphere();
  static_assert(ProgressiveMethod<Faulty, Sphere> && !KernelMethod<Faulty, Sphere>);
  ProgressiveRender render(scene, Faulty{}, 6, 6);
  CHECK(render.pixel(3) == 0.0);
  for (int i = 0; i < 3; ++i) render.iterate();
  CHECK(render.drops()[DropReason::non_finite] == 1);
  CHECK(render.pixel(0) == Approx((0.0 + 2.0) / 3));
  CHECK(render.pixel(5) == Approx((0.0 + 1.0 + 2.0) / 3));
  CHECK_THROWS_AS(ProgressiveRender(scene, Faulty{}, 6, 5), std::invalid_argument);
  // As many pixels in other rows: the image came back reshaped without a word.
  CHECK_THROWS_WITH(ProgressiveRender(scene, Faulty{}, 36, 1), Catch::Contains("the sensor is 6 pixels wide"));
  CHECK_THROWS_WITH(ProgressiveRender(scene, Faulty{}, 4, 9), Catch::Contains("the sensor is 6 pixels wide"));
  // Pixel indices are 32-bit: refused before anything is allocated (pixel_count() was cut to 0).
  CHECK_THROWS_WITH(Framebuffer<float>(65536, 65536), Catch::Contains("65536 x 65536 pixels are more than 32-bit"));
  CHECK_THROWS_AS(Framebuffer<float>(0, 4), std::invalid_argument);
}

TEST_CASE("iterations rendered apart and added in index order, or a resumed render, equal iterate() bit for bit",
          "[render]") {
  const Sphere scene = make_sphere();
  VcmOptions v;  // a kernel method: each iteration must be rendered at its own scheduled radius
  v.max_length = 5;
  v.seed = 3;
  const VertexConnectionMerging<Sphere> vcm(v);
  ProgressiveRender whole(scene, vcm, 6, 6);
  for (int i = 0; i < 5; ++i) whole.iterate();

  // Two "ranks" render iterations 0..4 in another order; the root adds them in index order.
  ProgressiveRender root(scene, vcm, 6, 6), other(scene, vcm, 6, 6);
  std::vector<Framebuffer<float>> images(5, Framebuffer<float>(6, 6));
  for (std::uint64_t i : {4u, 1u, 3u}) {
    other.render(i);
    images[i] = other.iteration_image();
  }
  for (std::uint64_t i : {2u, 0u}) {
    root.render(i);
    images[i] = root.iteration_image();
  }
  for (const auto& image : images) root.accumulate(image);
  CHECK(root.iterations() == 5);

  // A render stopped after 2 iterations, saved and resumed by another object.
  ProgressiveRender first(scene, vcm, 6, 6);
  first.iterate();
  first.iterate();
  ProgressiveRender resumed(scene, vcm, 6, 6);
  resumed.resume(first.sum(), first.iterations(), first.drops());
  for (int i = 0; i < 3; ++i) resumed.iterate();
  CHECK(resumed.iterations() == 5);

  double total = 0;
  for (std::uint32_t p = 0; p < 36; ++p) {
    CHECK(root.sum()[p] == whole.sum()[p]);
    CHECK(resumed.sum()[p] == whole.sum()[p]);
    total += whole.sum()[p];
  }
  CHECK(total > 0);
  CHECK_THROWS_AS(root.accumulate(Framebuffer<float>(6, 5)), std::invalid_argument);
  CHECK_THROWS_AS(resumed.resume(Framebuffer<double>(5, 6), 1, {}), std::invalid_argument);
}

// PT and LT through the protocol (LT's image is its splats over N light paths) against the
// closed form of the constant furnace: each pixel's mean over the iterations within 5 standard
// errors of L truncated at max_length segments (LT: without the emission seen directly, which
// light tracing leaves to the camera side).
TEST_CASE("PT and LT through the render protocol agree with the furnace's closed form", "[render][stat]") {
  testing::SphereInteriorParameters<float> p;
  const Sphere scene(4, p);  // constant emission and albedo: every pixel sees L exactly
  const std::size_t max_length = 5;
  double expected = 0;
  for (unsigned k = 0; k < max_length; ++k) expected += scene.bounce_radiance_at({0, 0, -1}, k);
  for (const bool light : {false, true}) {
    std::vector<testing::RunningStats> pixels(16);
    const auto run = [&](auto method) {
      ProgressiveRender render(scene, method, 4, 4);
      for (int i = 0; i < 2000; ++i) {
        const Framebuffer<double> before = render.sum();
        render.iterate();
        for (std::uint32_t q = 0; q < 16; ++q) pixels[q].add(render.sum()[q] - before[q]);
      }
      CHECK(render.drops().total() == 0);
      for (std::uint32_t q = 0; q < 16; ++q) CHECK(render.pixel(q) == Approx(pixels[q].mean()));
    };
    if (light) run(LightTracer<Sphere>({max_length, 0, 3}));
    else run(PathTracer<Sphere>({max_length, MisHeuristic::power, 2, 3}));  // roulette: a zero-variance furnace otherwise
    const double target = light ? expected - scene.bounce_radiance_at({0, 0, -1}, 0) : expected;
    for (std::uint32_t q = 0; q < 16; ++q) {
      INFO((light ? "lt" : "pt") << " pixel " << q << ": " << pixels[q].mean() << " +- " << pixels[q].standard_error()
                                 << ", expected " << target);
      CHECK(std::abs(pixels[q].mean() - target) < 5 * pixels[q].standard_error());
      // Power: LT's image without its 1 / N (N = 16 here) would be 16x the closed form.
      CHECK(std::abs(16 * pixels[q].mean() - target) > 5 * 16 * pixels[q].standard_error());
    }
  }
}
