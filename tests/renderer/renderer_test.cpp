// Tests of the renderer example: its methods on the four Cornell boxes (image means against
// the sanity figure, light tracing against path tracing on the path families both sample),
// thread-count independence, image files and error metrics.
#include "support/catch.hpp"

#include "cornell.hpp"
#include "image_io.hpp"
#include "integrators.hpp"
#include "options.hpp"
#include "tbb_parallel.hpp"

#include <segpath/integrand/contribution.hpp>
#include <segpath/samplers/sensor_start.hpp>
#include <segpath/testing/statistics.hpp>

#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace {

/// The sink of one PT sample: its value, or a counted drop.
struct PixelSink {
  renderer::Color value;
  segpath::DropCounters* drops;
  void add(std::uint32_t, const renderer::Color& v) noexcept { value += v; }
  void drop(segpath::DropReason r) noexcept { drops->add(r); }
};

using renderer::Color;
using renderer::RenderScene;
using segpath::testing::RunningStats;

/// Renders `iterations` iterations of `method` with `parallel`; their sum.
template <class M, class P>
renderer::Accumulator render(M& method, const RenderScene& scene, std::uint64_t iterations, renderer::Stats& stats,
                             const P& parallel) {
  for (std::uint64_t i = 0; i < iterations; ++i) method.iterate(scene, stats, parallel);
  return method.sum();
}

double accumulator_mean(const renderer::Accumulator& acc, std::uint64_t iterations) {
  double sum = 0;
  for (const auto& p : acc.pixels()) sum += p.r + p.g + p.b;
  return sum / (3.0 * double(acc.pixel_count()) * double(iterations));
}

/// Whether a PT sample's path belongs to the families light tracing samples too
/// (cornell-boxes.md, "Which method sees which light"): its first camera hit is a surface
/// with a non-delta BSDF that emits nothing towards the camera. The sensor-start sampler is
/// replayed on a copy of the sample's stream, so this is the first segment PT itself uses.
bool light_tracer_family(const RenderScene& scene, std::uint32_t pixel, segpath::Pcg32 rng) {
  const segpath::SensorStartSampler<RenderScene> first;
  const auto s = first.sample(scene, {pixel}, rng);
  if (!s || s->segment.y.kind != segpath::PointKind::surface) return false;
  if (scene.bsdf().is_delta(s->segment.y)) return false;
  return segpath::is_black(segpath::emission_factor(scene, s->segment, s->direction));
}

double channel_mean(const Color& c) { return (double(c.r) + double(c.g) + double(c.b)) / 3.0; }

/// Two RunningStats of `count` zeros, built by doubling (count may be ~10^6 per tile).
RunningStats zeros(std::uint64_t count) {
  RunningStats result, block;
  block.add(0.0);
  for (; count != 0; count >>= 1) {
    if (count & 1u) result.merge(block);
    const RunningStats copy = block;
    block.merge(copy);
  }
  return result;
}

struct TileGrid {
  std::uint32_t width, height, tile;
  [[nodiscard]] std::uint32_t columns() const { return (width + tile - 1) / tile; }
  [[nodiscard]] std::uint32_t count() const { return columns() * ((height + tile - 1) / tile); }
  [[nodiscard]] std::uint32_t of(std::uint32_t pixel) const {
    return (pixel / width) / tile * columns() + (pixel % width) / tile;
  }
  [[nodiscard]] double pixels_in(std::uint32_t t) const {
    const std::uint32_t tx = t % columns(), ty = t / columns();
    return double(std::min(tile, width - tx * tile)) * double(std::min(tile, height - ty * tile));
  }
};

}  // namespace

TEST_CASE("the method list names every method and makes each by name", "[renderer]") {
  const auto names = renderer::method_names();
  REQUIRE(names == std::vector<std::string>{"pt", "lt", "bdpt", "ppm", "bpm", "vcm", "mvf", "phf", "bdpf"});
  for (const auto& name : names) {
    const auto m = renderer::make_method(name, {});
    REQUIRE(m);
    CHECK(renderer::method_name(*m) == name);
  }
  CHECK_FALSE(renderer::make_method("vcm-typo", {}));
  renderer::MethodOptions short_paths;
  short_paths.max_length = 1;
  CHECK_THROWS_AS(renderer::make_method("lt", short_paths), std::invalid_argument);
  CHECK_THROWS_AS(renderer::make_method("bdpf", short_paths), std::invalid_argument);  // k >= 1 iterations
  renderer::MethodOptions bad_beta;
  bad_beta.beta = -1.0;
  CHECK_THROWS_AS(renderer::make_method("vcm", bad_beta), std::invalid_argument);
  CHECK_THROWS_AS(renderer::make_method("bdpf", bad_beta), std::invalid_argument);
}

TEST_CASE("--radius is checked against the scene's diagonal as the method reads it", "[renderer]") {
  using renderer::check_kernel;
  using renderer::RadiusUse;
  const double diagonal = 4;
  // A merge radius r is a kernel 2 r wide: refused from the diagonal on, warned from a tenth.
  CHECK(check_kernel("vcm", RadiusUse::merge_radius, 2.0, diagonal).error);
  CHECK_FALSE(check_kernel("vcm", RadiusUse::merge_radius, 1.999, diagonal).error);
  CHECK(check_kernel("vcm", RadiusUse::merge_radius, 1.999, diagonal).warning);
  CHECK(check_kernel("ppm", RadiusUse::merge_radius, 0.2, diagonal).warning);
  CHECK_FALSE(check_kernel("ppm", RadiusUse::merge_radius, 0.1999, diagonal).warning);
  CHECK_FALSE(check_kernel("ppm", RadiusUse::merge_radius, 0.1999, diagonal).error);
  // A voxel v is v wide.
  CHECK(check_kernel("bdpf", RadiusUse::voxel, 4.0, diagonal).error);
  CHECK_FALSE(check_kernel("bdpf", RadiusUse::voxel, 3.999, diagonal).error);
  CHECK(check_kernel("bdpf", RadiusUse::voxel, 0.4, diagonal).warning);
  CHECK_FALSE(check_kernel("bdpf", RadiusUse::voxel, 0.3999, diagonal).warning);
  // No kernel: a warning that --radius is ignored, whatever its size; no scene size: no check.
  for (const double radius : {1e-3, 1e3}) {
    const auto ignored = check_kernel("bdpt", RadiusUse::ignored, radius, diagonal);
    CHECK_FALSE(ignored.error);
    REQUIRE(ignored.warning);
    CHECK(ignored.warning->find("bdpt has no kernel") != std::string::npos);
  }
  CHECK_FALSE(check_kernel("vcm", RadiusUse::merge_radius, 1e3, 0).error);
  // Each method reads --radius as it uses it.
  CHECK(renderer::PtMethod::radius_use == RadiusUse::ignored);
  CHECK(renderer::LtMethod::radius_use == RadiusUse::ignored);
  CHECK(renderer::VcmMethod<segpath::VcmMode::bdpt>::radius_use == RadiusUse::ignored);
  for (const RadiusUse use : {renderer::VcmMethod<segpath::VcmMode::ppm>::radius_use, renderer::VcmMethod<segpath::VcmMode::bpm>::radius_use,
                              renderer::VcmMethod<segpath::VcmMode::vcm>::radius_use})
    CHECK(use == RadiusUse::merge_radius);
  for (const RadiusUse use : {renderer::FilteringMethod<segpath::FilteringMode::mvf>::radius_use,
                              renderer::FilteringMethod<segpath::FilteringMode::phf>::radius_use,
                              renderer::FilteringMethod<segpath::FilteringMode::bdpf>::radius_use})
    CHECK(use == RadiusUse::voxel);
}

TEST_CASE("path tracing renders each Cornell box to a finite, positive image", "[renderer]") {
  for (int box = 0; box < 4; ++box) {
    const RenderScene scene = renderer::make_cornell(box, 24, 24);
    renderer::PtMethod pt(renderer::MethodOptions{});
    renderer::Stats stats;
    const auto acc = render(pt, scene, 4, stats, segpath::SerialFor{});
    const double mean = accumulator_mean(acc, 4);
    INFO("box " << box << ": mean " << mean);
    CHECK(std::isfinite(mean));
    CHECK(mean > 0);
    CHECK(stats.paths == 4u * 24u * 24u);
    CHECK(stats.rays >= stats.paths);  // at least the camera ray of every path
    CHECK(stats.dropped.total() == 0);
  }
}

// Box 1's converged mean is 0.2638 (per channel 0.2635, 0.2664, 0.2615; cornell-boxes.md,
// rounded to 4 digits). The image mean is the mean over pixels of per-pixel means of spp
// independent samples, so its variance is sum_p s_p^2 / spp / P^2 with s_p^2 each pixel's
// sample variance; we require |mean - figure| <= 5 sigma + 5e-5 (the figure's rounding).
TEST_CASE("path tracing matches box 1's sanity figure within 5 sigma", "[renderer][stat]") {
  constexpr std::uint32_t size = 128;
  constexpr std::uint64_t spp = 64;
  const RenderScene scene = renderer::make_cornell(1, size, size);
  const segpath::PathTracer<RenderScene> tracer(segpath::PathTracerOptions{renderer::cornell_max_length});
  std::vector<std::array<RunningStats, 4>> pixels(std::size_t(size) * size);  // r, g, b, channel mean
  renderer::TbbFor{}(size, [&](std::size_t row) {
    segpath::DropCounters drops;
    for (std::uint32_t x = 0; x < size; ++x) {
      const auto pixel = std::uint32_t(row) * size + x;
      for (std::uint64_t s = 0; s < spp; ++s) {
        auto rng = segpath::Pcg32::for_sample(2025, pixel, s);
        PixelSink sink{Color(0.0f), &drops};
        tracer.estimate(scene, segpath::EstimateQuery{pixel, s}, rng, sink);
        for (int c = 0; c < 3; ++c) pixels[pixel][std::size_t(c)].add(sink.value[c]);
        pixels[pixel][3].add(channel_mean(sink.value));
      }
    }
  });
  const std::array<double, 4> figure{0.2635, 0.2664, 0.2615, 0.2638};
  for (std::size_t c = 0; c < 4; ++c) {
    double mean = 0, variance = 0;
    for (const auto& p : pixels) {
      mean += p[c].mean();
      variance += p[c].variance() / double(spp);
    }
    const double n = double(pixels.size());
    mean /= n;
    const double sigma = std::sqrt(variance) / n;
    INFO("channel " << c << " (3: mean of channels): mean " << mean << " +- " << sigma << ", figure " << figure[c]);
    CHECK(std::isfinite(mean));
    CHECK(std::abs(mean - figure[c]) <= 5 * sigma + 5e-5);
    CHECK(5 * sigma < 0.02 * figure[c]);  // power: a 2 % error would be detected
  }
}

// Light tracing against path tracing, per 16 x 16 tile of a 64 x 64 image, on the families
// both sample: PT samples whose path leaves that family (first camera hit specular, an
// emitter, or the sky) count as zero. Welch t-test per tile and box (PT: one value per camera
// sample; LT: one value per light path, the sum of its splats in the tile over the tile's
// pixel count), at a Sidak-corrected alpha for a family error rate of 1e-3 over all tiles of
// both boxes. Tiles are large because PT's caustics (wall -> mirror -> light in box 1) are
// heavy-tailed: with 4096 samples per tile its sample variance underestimates the error
// (measured |z| up to 5.5 in 100 runs), with 32768 it does not. Without the restriction, PT
// must be rejected somewhere (everything seen in the mirror): the test can fail.
TEST_CASE("light tracing agrees with path tracing on the paths both sample", "[renderer][stat]") {
  constexpr std::uint32_t size = 64;
  constexpr std::uint64_t pt_spp = 128, lt_iterations = 256;
  const TileGrid grid{size, size, 16};
  const std::array<int, 2> boxes{1, 3};
  const double alpha = segpath::testing::sidak_alpha(1e-3, grid.count() * boxes.size());
  for (const int box : boxes) {
    const RenderScene scene = renderer::make_cornell(box, size, size);
    // PT, restricted and unrestricted, per row (merged in row order).
    const segpath::PathTracer<RenderScene> pt(segpath::PathTracerOptions{renderer::cornell_max_length});
    std::vector<std::vector<RunningStats>> pt_rows(size, std::vector<RunningStats>(grid.count()));
    std::vector<std::vector<RunningStats>> full_rows(size, std::vector<RunningStats>(grid.count()));
    renderer::TbbFor{}(size, [&](std::size_t row) {
      segpath::DropCounters drops;
      for (std::uint32_t x = 0; x < size; ++x) {
        const auto pixel = std::uint32_t(row) * size + x;
        for (std::uint64_t s = 0; s < pt_spp; ++s) {
          auto rng = segpath::Pcg32::for_sample(11, pixel, s);
          const bool shared = light_tracer_family(scene, pixel, rng);
          PixelSink sink{Color(0.0f), &drops};
          pt.estimate(scene, segpath::EstimateQuery{pixel, s}, rng, sink);
          const double v = channel_mean(sink.value);
          pt_rows[row][grid.of(pixel)].add(shared ? v : 0.0);
          full_rows[row][grid.of(pixel)].add(v);
        }
      }
    });
    // LT: light path k of iteration i from its own stream; per-path tile sums.
    const segpath::LightTracer<RenderScene> lt(segpath::LightTracerOptions{renderer::cornell_max_length});
    constexpr std::size_t chunks = 64;
    const std::uint64_t paths = lt_iterations * size * size;
    std::vector<std::vector<RunningStats>> lt_chunks(chunks, std::vector<RunningStats>(grid.count()));
    std::vector<std::uint64_t> lt_dropped(chunks, 0);
    renderer::TbbFor{}(chunks, [&](std::size_t chunk) {
      struct Recorder {
        std::vector<std::pair<std::uint32_t, double>> splats;
        std::uint64_t dropped = 0;
        void add(std::uint32_t pixel, const Color& v) { splats.emplace_back(pixel, channel_mean(v)); }
        void drop(segpath::DropReason) noexcept { ++dropped; }
      } recorder;
      std::vector<std::pair<std::uint32_t, double>> per_tile;
      for (std::uint64_t k = paths * chunk / chunks; k < paths * (chunk + 1) / chunks; ++k) {
        auto rng = segpath::Pcg32::for_sample(12, k, 0);
        recorder.splats.clear();
        lt.estimate(scene, segpath::EstimateQuery{0, k}, rng, recorder);
        per_tile.clear();
        for (const auto& [pixel, v] : recorder.splats) {
          const auto t = grid.of(pixel);
          auto it = std::find_if(per_tile.begin(), per_tile.end(), [&](const auto& e) { return e.first == t; });
          if (it == per_tile.end()) per_tile.emplace_back(t, v);
          else it->second += v;
        }
        for (const auto& [t, v] : per_tile) lt_chunks[chunk][t].add(v / grid.pixels_in(t));
      }
      lt_dropped[chunk] = recorder.dropped;
    });
    for (const auto d : lt_dropped) CHECK(d == 0);
    std::size_t rejected_full = 0;
    for (std::uint32_t t = 0; t < grid.count(); ++t) {
      RunningStats pt_tile, full_tile, lt_tile;
      for (std::uint32_t row = 0; row < size; ++row) {
        pt_tile.merge(pt_rows[row][t]);
        full_tile.merge(full_rows[row][t]);
      }
      for (std::size_t c = 0; c < chunks; ++c) lt_tile.merge(lt_chunks[c][t]);
      lt_tile.merge(zeros(paths - lt_tile.count()));  // paths that left nothing in the tile
      const auto result = segpath::testing::welch_t_test(pt_tile, lt_tile);
      INFO("box " << box << " tile " << t << ": PT " << pt_tile.mean() << " +- " << pt_tile.standard_error() << ", LT "
                  << lt_tile.mean() << " +- " << lt_tile.standard_error() << ", p = " << result.p_value);
      CHECK_FALSE(result.rejects(alpha));
      if (segpath::testing::welch_t_test(full_tile, lt_tile).rejects(alpha)) ++rejected_full;
    }
    INFO("box " << box << ": unrestricted PT rejected on " << rejected_full << " tiles");
    CHECK(rejected_full > 0);
  }
}

TEST_CASE("images do not depend on the thread count", "[renderer]") {
  const RenderScene scene = renderer::make_cornell(1, 40, 30);
  auto run = [&](const std::string& method, int threads) {
    auto m = renderer::make_method(method, renderer::MethodOptions{});
    renderer::Stats stats;
    std::optional<renderer::Accumulator> acc;
    tbb::task_arena arena(threads);
    arena.execute([&] {
      std::visit([&](auto& x) { acc.emplace(render(x, scene, 3, stats, renderer::TbbFor{})); }, *m);
    });
    return std::pair(std::move(*acc), stats);
  };
  for (const std::string method : {"pt", "lt"}) {
    const auto [one, one_stats] = run(method, 1);
    const auto [two, two_stats] = run(method, 2);
    INFO(method);
    REQUIRE(one.pixel_count() == two.pixel_count());
    CHECK(std::memcmp(one.pixels().data(), two.pixels().data(), one.pixels().size_bytes()) == 0);
    CHECK(one_stats.paths == two_stats.paths);
    CHECK(one_stats.rays == two_stats.rays);
    CHECK(one_stats.dropped.counts == two_stats.dropped.counts);
    CHECK(accumulator_mean(one, 3) > 0);
    // A different seed gives a different image (the comparison can fail).
    renderer::MethodOptions other;
    other.seed = 2;
    auto m = renderer::make_method(method, other);
    renderer::Stats stats;
    std::optional<renderer::Accumulator> acc;
    std::visit([&](auto& x) { acc.emplace(render(x, scene, 3, stats, segpath::SerialFor{})); }, *m);
    CHECK(std::memcmp(one.pixels().data(), acc->pixels().data(), one.pixels().size_bytes()) != 0);
  }
}

TEST_CASE("image files read back to the values written", "[renderer]") {
  examples::Image image(5, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x)
      image.at(x, y) = segpath::Rgb<float>(0.1f * float(x) + 0.013f * float(y), 1e-6f * float(x + 1), 37.25f * float(y) + 0.5f);
  const auto dir = std::filesystem::temp_directory_path();
  const std::string stem = (dir / ("segpath_renderer_test_" + std::to_string(::getpid()))).string();
  for (const std::string ext : {".pfm", ".exr", ".PFM"}) {
    const std::string path = stem + ext;
    renderer::write_image(image, path);
    const auto back = renderer::read_image(path);
    std::filesystem::remove(path);
    INFO(path);
    REQUIRE(back.width == 5);
    REQUIRE(back.height == 3);
    for (std::size_t i = 0; i < image.pixels.size(); ++i) CHECK(back.pixels[i] == image.pixels[i]);
    const auto e = renderer::compare(back, image);
    CHECK(e.rmse == 0);
    CHECK(e.relmse == 0);
  }
  // PNG: clamped, sRGB-encoded 8-bit values, row 0 at the top.
  const std::string png = stem + ".png";
  renderer::write_image(image, png);
  int w = 0, h = 0, n = 0;
  unsigned char* data = stbi_load(png.c_str(), &w, &h, &n, 3);
  std::filesystem::remove(png);
  REQUIRE(data != nullptr);
  REQUIRE(w == 5);
  REQUIRE(h == 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x)
      for (int c = 0; c < 3; ++c) {
        const auto expected = static_cast<int>(examples::to_srgb(image.at(x, y)[c]) * 255.0f + 0.5f);
        CHECK(int(data[(y * 5 + x) * 3 + c]) == expected);
      }
  stbi_image_free(data);
  CHECK(int(examples::to_srgb(37.75f) * 255.0f + 0.5f) == 255);

  CHECK_THROWS_AS(renderer::write_image(image, stem + ".txt"), std::runtime_error);
  CHECK_THROWS_AS(renderer::write_image(image, "/nonexistent-dir/x.pfm"), std::runtime_error);
  CHECK_THROWS_AS(renderer::write_image(image, "/nonexistent-dir/x.exr"), std::runtime_error);
  CHECK_THROWS_AS(renderer::read_image(stem + ".missing.pfm"), std::runtime_error);
  {
    std::FILE* f = std::fopen((stem + ".bad.pfm").c_str(), "wb");
    REQUIRE(f);
    std::fputs("PF\n4 4\n-1.0\n\x01\x02", f);  // header, then a truncated body
    std::fclose(f);
    CHECK_THROWS_AS(renderer::read_image(stem + ".bad.pfm"), std::runtime_error);
    std::filesystem::remove(stem + ".bad.pfm");
  }
}

TEST_CASE("RMSE and relMSE follow their definitions", "[renderer]") {
  examples::Image a(2, 1), r(2, 1);
  a.pixels[0] = segpath::Rgb<float>(1.0f, 0.0f, 0.0f);
  r.pixels[0] = segpath::Rgb<float>(0.0f, 0.0f, 0.0f);
  a.pixels[1] = segpath::Rgb<float>(2.0f, 1.0f, 1.0f);
  r.pixels[1] = segpath::Rgb<float>(1.0f, 1.0f, 1.0f);
  const auto e = renderer::compare(a, r);
  CHECK(e.rmse == Approx(std::sqrt(2.0 / 6.0)));
  CHECK(e.relmse == Approx((1.0 / 1e-2 + 1.0 / 1.01) / 6.0));
  CHECK_THROWS_AS(renderer::compare(a, examples::Image(1, 2)), std::runtime_error);
  r.pixels[1].g = std::nanf("");
  CHECK_THROWS_AS(renderer::compare(a, r), std::runtime_error);
}

TEST_CASE("a checkpoint's image options record each method's settings as it runs with them", "[renderer]") {
  renderer::Options o;  // the command line's defaults
  const auto options_of = [&](const std::string& method) {
    o.method = method;
    return renderer::image_options(o);
  };
  const auto has = [](const std::string& text, const std::string& line) { return text.find("\n" + line + "\n") != std::string::npos; };
  const auto number = [](double v) {
    char s[40];
    std::snprintf(s, sizeof s, "%.17g", v);
    return std::string(s);
  };
  // A resolved value as the options write it: shortest exact, as a float where it is one.
  const auto shortest = [](double v) {
    char s[40];
    const float f = float(v);
    return std::string(s, double(f) == v ? std::to_chars(s, s + sizeof s, f).ptr : std::to_chars(s, s + sizeof s, v).ptr);
  };
  // PT and LT: Russian roulette from the third segment and never (the renderer's defaults).
  CHECK(has(options_of("pt"), "roulette-from=3"));
  CHECK(has(options_of("lt"), "roulette-from=0"));
  // The VCM family: the library's alpha and beta, roulette from the first scattering, an
  // automatic radius by its footprints; BDPT merges nothing.
  const segpath::VcmOptions vcm;
  for (const segpath::VcmMode mode : {segpath::VcmMode::ppm, segpath::VcmMode::bpm, segpath::VcmMode::vcm}) {
    const std::string text = options_of(std::string(segpath::to_string(mode)));
    INFO(text);
    CHECK(has(text, "alpha=" + shortest(vcm.alpha)));
    CHECK(has(text, "beta=" + shortest(vcm.light_path_factor)));
    CHECK(has(text, "roulette-from=1"));
    CHECK(has(text, "radius=default (" + number(segpath::radius_in_footprints(mode)) + " footprints)"));
  }
  const std::string bdpt = options_of("bdpt");
  CHECK(has(bdpt, "alpha=default"));
  CHECK(has(bdpt, "radius=default"));
  CHECK(has(bdpt, "beta=" + shortest(vcm.light_path_factor)));
  // Filtering: the library's alpha and beta, in the renderer's float and written as one (the
  // default alpha 0.67f reads "0.67"), the voxel by its footprints.
  const segpath::FilteringOptions<float> filtering;
  for (const std::string method : {"mvf", "phf", "bdpf"}) {
    const std::string text = options_of(method);
    INFO(text);
    CHECK(has(text, "alpha=" + shortest(filtering.alpha)));
    CHECK(has(text, "beta=" + (method == "mvf" ? std::string("default") : shortest(filtering.light_path_ratio))));
    CHECK(has(text, "radius=default (" + number(segpath::filtering::cell_in_footprints) + " footprints)"));
  }
  // A value given on the command line is recorded as the method runs with it: the default's
  // value typed out gives the same options (a checkpoint resumes), another value other options.
  const std::string automatic = options_of("bdpf");
  o.alpha = 0.67;  // as --alpha 0.67 parses: a double, 0.67f in the method
  CHECK(options_of("bdpf") == automatic);
  o.alpha = 0.6;
  CHECK(has(options_of("bdpf"), "alpha=0.6"));
  o.alpha = 0.5;
  CHECK(has(options_of("vcm"), "alpha=0.5"));
  o.alpha.reset();
  o.radius = 0.01;
  CHECK(has(options_of("vcm"), "radius=0.01"));
}
