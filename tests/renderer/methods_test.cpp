// Tests of every renderer method against path tracing on the Cornell boxes: thread-count
// independence, and per-tile agreement with PT on the path families both sample (unbiased
// methods exactly, kernel and filtering methods within a measured bias bound).
#include "support/catch.hpp"
#include "support/filtering_denominators.hpp"

#include "cornell.hpp"
#include "integrators.hpp"
#if SEGPATH_TEST_OBJ_SCENES
#include "obj_scene.hpp"
#endif
#include "tbb_parallel.hpp"

#include <segpath/integrand/contribution.hpp>
#include <segpath/samplers/sensor_start.hpp>
#include <segpath/testing/statistics.hpp>

#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace {

using renderer::RenderScene;
using segpath::testing::RunningStats;

constexpr std::uint32_t size = 64;  // image side of the agreement tests; 16 tiles of 16 x 16
constexpr std::uint32_t tile_side = 16;
constexpr double family_alpha = 1e-3;

/// The tile of each pixel (-1: not compared) and the number of tiles.
struct Tiles {
  std::vector<int> of;
  std::size_t count = 0;
};

Tiles square_tiles() {
  Tiles t{std::vector<int>(std::size_t(size) * size), std::size_t(size / tile_side) * (size / tile_side)};
  for (std::uint32_t p = 0; p < size * size; ++p) t.of[p] = int((p / size) / tile_side * (size / tile_side) + (p % size) / tile_side);
  return t;
}

double channel_mean(const segpath::Rgb<double>& c) { return (c.r + c.g + c.b) / 3.0; }

template <class P>
renderer::Accumulator render(renderer::Method& method, const RenderScene& scene, std::uint64_t iterations,
                             renderer::Stats& stats, const P& parallel) {
  return std::visit([&](auto& m) {
    for (std::uint64_t i = 0; i < iterations; ++i) m.iterate(scene, stats, parallel);
    return m.sum();
  }, method);
}

/// Each iteration's image is one sample of every pixel: per tile, the iteration's mean over
/// the tile's pixels, one value per iteration ([tile][iteration]).
std::vector<std::vector<double>> iteration_tile_means(const std::string& name, const renderer::MethodOptions& options,
                                                      const RenderScene& scene, const Tiles& tiles, std::uint64_t iterations) {
  auto method = renderer::make_method(name, options);
  REQUIRE(method);
  std::vector<std::vector<double>> result(tiles.count);
  renderer::Stats stats;
  std::vector<double> sum(tiles.count), count(tiles.count);
  std::optional<renderer::Accumulator> before;  // the sum up to the previous iteration
  for (std::uint64_t i = 0; i < iterations; ++i) {
    const renderer::Accumulator& acc = std::visit([&](auto& m) -> const renderer::Accumulator& {
      m.iterate(scene, stats, renderer::TbbFor{});
      return m.sum();
    }, *method);
    std::fill(sum.begin(), sum.end(), 0.0);
    std::fill(count.begin(), count.end(), 0.0);
    for (std::uint32_t p = 0; p < acc.pixel_count(); ++p) {
      if (tiles.of[p] < 0) continue;
      sum[std::size_t(tiles.of[p])] += channel_mean(before ? acc[p] - (*before)[p] : acc[p]);
      count[std::size_t(tiles.of[p])] += 1;
    }
    for (std::size_t t = 0; t < tiles.count; ++t)
      if (count[t] > 0) result[t].push_back(sum[t] / count[t]);
    before = acc;
  }
  CHECK(stats.dropped.total() == 0);
  return result;
}

std::vector<RunningStats> stats_of(const std::vector<std::vector<double>>& samples, double scale = 1.0) {
  std::vector<RunningStats> s(samples.size());
  for (std::size_t t = 0; t < samples.size(); ++t)
    for (const double v : samples[t]) s[t].add(scale * v);
  return s;
}

/// PT (the renderer's PtMethod, one path per pixel per iteration) per pixel sample, and per
/// pixel whether every one of its samples' first camera hit is a non-delta surface that
/// emits nothing towards the camera (the sensor-start sampler replayed on PT's own stream).
struct PtReference {
  std::vector<RunningStats> pixels;
  std::vector<bool> diffuse_first;

  [[nodiscard]] std::vector<RunningStats> tiles(const Tiles& tiles, double scale = 1.0) const {
    std::vector<RunningStats> t(tiles.count);
    for (std::size_t p = 0; p < pixels.size(); ++p) {
      if (tiles.of[p] < 0) continue;
      if (scale == 1.0) {
        t[std::size_t(tiles.of[p])].merge(pixels[p]);
      } else {  // a deliberately wrong reference: the same samples scaled
        RunningStats s;
        s.merge(pixels[p]);
        RunningStats scaled;
        const double n = double(s.count()), m = s.mean(), v = s.variance();
        // n values with mean scale * m and variance scale^2 v, merged exactly.
        scaled.add(scale * m + scale * std::sqrt(v * (n - 1) / 2.0));
        scaled.add(scale * m - scale * std::sqrt(v * (n - 1) / 2.0));
        for (std::uint64_t k = 2; k < s.count(); ++k) scaled.add(scale * m);
        t[std::size_t(tiles.of[p])].merge(scaled);
      }
    }
    return t;
  }
};

PtReference pt_reference(const RenderScene& scene, std::uint64_t seed, std::uint64_t spp) {
  renderer::MethodOptions options;
  options.seed = seed;
  renderer::PtMethod pt(options);
  const std::uint32_t n = scene.sensor().pixel_count();
  PtReference r{std::vector<RunningStats>(n), std::vector<bool>(n, true)};
  renderer::Stats stats;
  const segpath::SensorStartSampler<RenderScene> first;
  std::optional<renderer::Accumulator> before;  // the sum up to the previous iteration
  for (std::uint64_t i = 0; i < spp; ++i) {
    pt.iterate(scene, stats, renderer::TbbFor{});
    const renderer::Accumulator& acc = pt.sum();
    for (std::uint32_t p = 0; p < n; ++p) {
      r.pixels[p].add(channel_mean(before ? acc[p] - (*before)[p] : acc[p]));
      auto rng = segpath::Pcg32::for_sample(seed, p, i);
      const auto s = first.sample(scene, {p}, rng);
      const bool diffuse = s && s->segment.y.kind == segpath::PointKind::surface && !scene.bsdf().is_delta(s->segment.y) &&
                           segpath::is_black(segpath::emission_factor(scene, s->segment, s->direction));
      if (!diffuse) r.diffuse_first[p] = false;
    }
    before = acc;
  }
  CHECK(stats.dropped.total() == 0);
  return r;
}

/// The PT references, computed once per run. Box 1's caustics (wall -> mirror -> light) make
/// PT heavy-tailed: 1024 spp gives 2.6e5 samples per tile, relative standard errors 0.75-2 %
/// per tile (renderer_test.cpp found the sample variance trustworthy from 3.3e4 on). Box 3 is
/// smooth: 256 spp give 0.4-0.9 %.
const PtReference& pt_box(int box) {
  static std::map<int, PtReference> cache;
  auto it = cache.find(box);
  if (it == cache.end()) {
    const RenderScene scene = renderer::make_cornell(box, size, size);
    it = cache.emplace(box, pt_reference(scene, 101, box == 1 ? 1024 : 256)).first;
  }
  return it->second;
}

/// Per tile: the difference method - PT and its standard error.
struct TileDifference {
  double pt, method, difference, sigma, p_value;
};

std::vector<TileDifference> differences(const std::vector<RunningStats>& pt, const std::vector<RunningStats>& method) {
  std::vector<TileDifference> d;
  for (std::size_t t = 0; t < pt.size(); ++t)
    d.push_back({pt[t].mean(), method[t].mean(), method[t].mean() - pt[t].mean(),
                 std::hypot(pt[t].standard_error(), method[t].standard_error()),
                 segpath::testing::welch_t_test(pt[t], method[t]).p_value});
  return d;
}

/// Welch test per tile; returns how many tiles reject at alpha.
std::size_t rejections(const std::vector<RunningStats>& pt, const std::vector<RunningStats>& method, double alpha,
                       const std::string& label, bool expect_none) {
  std::size_t rejected = 0;
  const auto d = differences(pt, method);
  for (std::size_t t = 0; t < d.size(); ++t) {
    const bool rejects = d[t].p_value < alpha;
    rejected += rejects;
    if (expect_none) {
      INFO(label << " tile " << t << ": PT " << d[t].pt << ", method " << d[t].method << ", difference " << d[t].difference
                 << " +- " << d[t].sigma << ", p = " << d[t].p_value);
      CHECK_FALSE(rejects);
    }
  }
  return rejected;
}

}  // namespace

TEST_CASE("every method renders the same image with 1 and 2 threads", "[renderer]") {
  const std::vector<std::pair<std::string, int>> runs = [] {
    std::vector<std::pair<std::string, int>> r;
    for (const auto& name : renderer::method_names()) r.emplace_back(name, 1);
    r.emplace_back("vcm", 3);
    return r;
  }();
  for (const auto& [name, box] : runs) {
    const RenderScene scene = renderer::make_cornell(box, 32, 32);
    auto run = [&](int threads, std::uint64_t seed) {
      renderer::MethodOptions options;
      options.seed = seed;
      auto method = renderer::make_method(name, options);
      REQUIRE(method);
      renderer::Stats stats;
      std::optional<renderer::Accumulator> acc;
      tbb::task_arena arena(threads);
      arena.execute([&] { acc.emplace(render(*method, scene, 2, stats, renderer::TbbFor{})); });
      return std::pair(std::move(*acc), stats);
    };
    const auto [one, one_stats] = run(1, 1);
    const auto [two, two_stats] = run(2, 1);
    const auto [other, other_stats] = run(2, 2);
    INFO(name << " on box " << box);
    REQUIRE(one.pixel_count() == two.pixel_count());
    CHECK(std::memcmp(one.pixels().data(), two.pixels().data(), one.pixels().size_bytes()) == 0);
    CHECK(one_stats.paths == two_stats.paths);
    CHECK(one_stats.rays == two_stats.rays);
    CHECK(one_stats.dropped.counts == two_stats.dropped.counts);
    double sum = 0;
    for (const auto& p : one.pixels()) sum += p.r + p.g + p.b;
    CHECK(std::isfinite(sum));
    CHECK(sum > 0);
    CHECK(std::memcmp(one.pixels().data(), other.pixels().data(), one.pixels().size_bytes()) != 0);
  }
}

// BDPT and PT are unbiased and sample every path family of boxes 1 and 3: a straight Welch
// test per 16 x 16 tile (PT: per-pixel samples; BDPT: per-iteration tile means), Sidak over
// the 32 tiles of both boxes. Power: PT scaled by 1.05 must be rejected on some tile of each
// box (box 3's tiles resolve 0.6 %, box 1's best 0.8 %).
TEST_CASE("BDPT agrees with PT per tile on boxes 1 and 3", "[renderer][stat]") {
  const Tiles tiles = square_tiles();
  const double alpha = segpath::testing::sidak_alpha(family_alpha, 2 * tiles.count);
  for (const int box : {1, 3}) {
    const RenderScene scene = renderer::make_cornell(box, size, size);
    renderer::MethodOptions options;
    options.seed = 202;  // PT's camera streams are for_sample(seed, pixel, iteration), as BDPT's: keep them apart
    const auto bdpt = stats_of(iteration_tile_means("bdpt", options, scene, tiles, 128));
    const std::string label = "box " + std::to_string(box) + " BDPT";
    rejections(pt_box(box).tiles(tiles), bdpt, alpha, label, true);
    CHECK(rejections(pt_box(box).tiles(tiles, 1.05), bdpt, alpha, label + " vs 1.05 PT", false) > 0);
  }
}

// VCM at one pixel footprint (r = 0.052 at 64 x 64, shrinking by alpha = 0.75). Measured at 4
// footprints (0.21), VCM's kernel bias on box 1 is at most -4.4 % +- 1.1 % (floor tile 12; -1.7 %
// on the walls); kernel bias scales like r^2, so at a quarter of that radius it is about -0.3 %,
// below the 0.8-2 % resolution of a tile: a straight Welch test.
TEST_CASE("VCM at a small radius agrees with PT per tile on box 1", "[renderer][stat]") {
  const Tiles tiles = square_tiles();
  const double alpha = segpath::testing::sidak_alpha(family_alpha, tiles.count);
  const RenderScene scene = renderer::make_cornell(1, size, size);
  renderer::MethodOptions options;
  options.seed = 202;
  options.radius = segpath::pixel_footprint(scene);
  const auto vcm = stats_of(iteration_tile_means("vcm", options, scene, tiles, 128));
  rejections(pt_box(1).tiles(tiles), vcm, alpha, "VCM r/4", true);
  CHECK(rejections(pt_box(1).tiles(tiles, 1.05), vcm, alpha, "VCM r/4 vs 1.05 PT", false) > 0);
}

// Boxes 0 (sun) and 2 (point light) have the glass and mirror spheres' caustics, which only
// light paths carry (Dirac chains and light-born chains through glass): PT and BDPT miss the
// ones seen through glass, so the reference is VCM at a quarter of the default radius (as
// above; its kernel bias ~0.3 % on box 1). BDPF at half the default voxel, the bound of box 1's
// filtering test per tile: |BDPF - VCM| <= 5 sigma + 2 % of VCM. Before light paths continued
// through glass and from Dirac lights, BDPF was 4.4 % (box 2) and 29 % (box 0) dark, most of it
// in the caustic tiles. Power: VCM scaled by 1.10 fails the bound on some tile of each box.
TEST_CASE("BDPF agrees with VCM per tile on the Dirac-lit boxes 0 and 2 (caustics through glass)", "[renderer][stat]") {
  const Tiles tiles = square_tiles();
  for (const int box : {2, 0}) {
    const RenderScene scene = renderer::make_cornell(box, size, size);
    renderer::MethodOptions options;
    options.seed = 404;
    options.radius = segpath::pixel_footprint(scene);
    const auto vcm = stats_of(iteration_tile_means("vcm", options, scene, tiles, 256));
    options.seed = 405;
    options.radius = 2 * segpath::pixel_footprint(scene);  // half the default voxel
    const auto bdpf = stats_of(iteration_tile_means("bdpf", options, scene, tiles, 256));
    const auto d = differences(vcm, bdpf);
    std::size_t wrong_rejected = 0;
    for (std::size_t t = 0; t < tiles.count; ++t) {
      INFO("box " << box << " tile " << t << ": VCM " << d[t].pt << ", BDPF " << d[t].method << ", "
                  << d[t].difference / d[t].pt * 100 << " % +- " << d[t].sigma / d[t].pt * 100 << " %");
      CHECK(std::abs(d[t].difference) <= 5 * d[t].sigma + 0.02 * d[t].pt);
      wrong_rejected += std::abs(d[t].method - 1.10 * d[t].pt) > 5 * d[t].sigma + 0.02 * 1.10 * d[t].pt;
    }
    CHECK(wrong_rejected > 0);
  }
}

// MVF and BDPF are biased: the voxel kernel blurs (bias ~ h^2 in smooth regions, ~ h at
// edges), and the MMIS denominators are sums over the technique samples that happen to land in
// each voxel, so 1/D is a ratio estimate whose (upward) bias grows as voxels hold fewer
// samples. Both render at the default voxel h (4 pixel footprints, 0.21) and at h/2 with the
// same seed (MVF 256 iterations, BDPF 1024: its floor tiles need them, see below).
//  - Bias bound at h/2: |method - PT| <= 5 sigma + 2 % of PT per tile. The 2 %: the voxel's
//    blur is at most that of a disk of radius h/2, and VCM's disk of radius h has at most
//    -4.4 % kernel bias on box 1, so ~1.1 % at h and ~0.3 % at h/2 by the h^2 scaling (~2.2 %
//    and ~1.1 % if edge-dominated, scaling like h); MVF's measured tile differences at h and
//    h/2 are all within 2 sigma of PT (|z| <= 2.0, 16 tiles each).
//  - Consistency: halving the voxel must not move a tile's estimate away from PT. Per tile,
//    the paired per-iteration difference (h/2 - h, same seed, so same paths; the clustering
//    still decorrelates them: ~1.3 % standard error per tile at 256 iterations); a tile fails
//    when that move is significant (|z| > 5), points the same way as the h/2 difference to PT,
//    and that difference is itself significant (|z| > 3).
//    With the paper's weighting (--weighting paper) BDPF fails this at beta = 0.25: the floor
//    tiles (12-15) go from +0.3, +0.4, -0.9, +1.7 % at h to +4.7, +5.0, +4.4, +7.0 % at h/2
//    at 256 iterations, a bias that grows as voxels hold fewer technique samples (see the BDPF
//    test below); the tests run BDPF with its default, path-conditioned weighting.
namespace {

using Filter = segpath::SegmentFiltering<renderer::ThreadCountingScene>;

/// Iteration 1's pool of `filter` on `scene`, clustered on voxels of size `cell`.
struct ClusteredPool {
  Filter::Context context;
  segpath::Clustering<float> clustering;
};
ClusteredPool clustered_pool(const Filter& filter, const renderer::ThreadCountingScene& scene, float cell) {
  ClusteredPool p{filter.context(scene, 0, 0, cell), {}};
  filter.build_pool(p.context);
  segpath::filtering::cluster(p.context, p.clustering, segpath::SerialFor{});
  return p;
}

void check_filtering_bias(const std::string& name, std::uint64_t iterations, const RenderScene& scene, const PtReference& reference) {
  const Tiles tiles = square_tiles();
  const double h = 4 * segpath::pixel_footprint(scene);
  renderer::MethodOptions options;
  options.seed = 303;
  options.beta = 0.25;  // sparse light paths: the weighting's cross terms show most
  options.radius = h;
  const auto coarse = iteration_tile_means(name, options, scene, tiles, iterations);
  options.radius = h / 2;
  const auto fine = iteration_tile_means(name, options, scene, tiles, iterations);
  const auto pt = reference.tiles(tiles);
  const auto d_coarse = differences(pt, stats_of(coarse));
  const auto d_fine = differences(pt, stats_of(fine));
  const auto d_wrong = differences(reference.tiles(tiles, 1.10), stats_of(fine));
  std::size_t wrong_rejected = 0;
  for (std::size_t t = 0; t < tiles.count; ++t) {
    RunningStats move;
    for (std::size_t i = 0; i < fine[t].size(); ++i) move.add(fine[t][i] - coarse[t][i]);
    const double z_move = move.mean() / move.standard_error();
    const double z_fine = d_fine[t].difference / d_fine[t].sigma;
    INFO(name << " on " << scene.name() << " tile " << t << ": PT " << d_fine[t].pt << "; at h " << d_coarse[t].difference / d_coarse[t].pt * 100
              << " % +- " << d_coarse[t].sigma / d_coarse[t].pt * 100 << " %; at h/2 "
              << d_fine[t].difference / d_fine[t].pt * 100 << " % +- " << d_fine[t].sigma / d_fine[t].pt * 100
              << " % (z " << z_fine << "); move h -> h/2 " << move.mean() / d_fine[t].pt * 100 << " % (z " << z_move << ")");
    CHECK(std::abs(d_fine[t].difference) <= 5 * d_fine[t].sigma + 0.02 * d_fine[t].pt);
    const bool away = std::abs(z_move) > 5 && std::abs(z_fine) > 3 && (z_move > 0) == (z_fine > 0);
    CHECK_FALSE(away);
    wrong_rejected += std::abs(d_wrong[t].difference) > 5 * d_wrong[t].sigma + 0.02 * d_wrong[t].pt;
  }
  // Power of the bound: a reference 10 % too bright fails it somewhere.
  CHECK(wrong_rejected > 0);
}

}  // namespace

// The mirror and glass spheres make chains on both sides: camera chains through them, and
// light-born chains (light -> mirror -> diffuse, the caustic on box 1's ceiling, and through the
// glass sphere, in and out), whose densities are measured by etendue (area x solid angle at x).
// Every denominator, recomputed by enumerating the pool, with next-event segments on, on every
// box: area light (1), sun (0), point light (2), sky (3); BDPF and PhF (whose sky chains only the
// light start draws: a light predecessor's chain after them is drawn like any other).
TEST_CASE("BDPF and PhF denominators on every box count chains from both sides and next-event segments", "[renderer]") {
  using segpath::FilteringMode;
  for (const FilteringMode mode : {FilteringMode::bdpf, FilteringMode::phf}) {
    for (const int box : {1, 0, 2, 3}) {
      INFO(segpath::to_string(mode) << ", box " << box);
      const bool bdpf = mode == FilteringMode::bdpf;
      const RenderScene cornell = renderer::make_cornell(box, 16, 16);
      const renderer::ThreadCountingScene scene(cornell);
      segpath::FilteringOptions<float> o;
      o.mode = mode;
      o.light_path_ratio = bdpf ? 1 : 4;  // PhF's light paths are all it has past the sensor
      o.next_event = true;
      const Filter filter(o);
      ClusteredPool clustered = clustered_pool(filter, scene, 0.3f);
      const auto& pool = clustered.context.pool;
      const auto& clustering = clustered.clustering;
      segpath::filtering::LightSide<float> side;
      segpath::filtering::compute_densities(clustered.context, clustering, segpath::SerialFor{}, &side);
      std::size_t camera_chains = 0, light_chains = 0, light_transmission_chains = 0, kept_chains = 0;
      for (std::size_t i = 0; i < pool.size(); ++i) {
        if (!(pool.flags[i] & segpath::filtering::chain_segment)) continue;
        kept_chains += segpath::filtering::kept_chain(pool, i);
        const bool camera = (pool.flags[i] & segpath::filtering::camera_born) != 0;
        ++(camera ? camera_chains : light_chains);
        light_transmission_chains += !camera && (pool.flags[i] & segpath::filtering::transmission_chain);
      }
      INFO("chains: camera " << camera_chains << ", light " << light_chains << " (through glass "
                             << light_transmission_chains << "), kept " << kept_chains);
      // The sky's light paths start on a disk around the whole box: few of them hit the spheres.
      CHECK(camera_chains > (bdpf ? 20 : 5));
      CHECK(light_chains > (box == 3 ? 4 : 20));
      if (box != 1) CHECK(light_transmission_chains > (box == 3 ? 1 : 5));  // boxes 0, 2, 3 have the glass sphere
      // (BDPF's camera roulette, continuation 0.7, leaves 121 on box 0 and 83 on box 3 of 256 pixels.)
      if (bdpf) CHECK(pool.next_event_segments > (box == 3 ? 50 : 100));
      if (box == 0 || box == 2) CHECK(kept_chains > 5);  // the sun's or the point light's caustics
      if (box == 3 && !bdpf) CHECK(kept_chains > 0);    // PhF's sky chains
      if (box == 3 && !bdpf) CHECK(light_chains > kept_chains);  // and light predecessors' chains after them
      const auto kernel = segpath::testing::voxel_kernel_oracle(
          pool, segpath::filtering::grid(filter.options(), 0.3f, clustered.context.stream),
          [](const segpath::SurfacePoint<float>& p) { return p.position; });
      const auto [checked, with_techniques] = segpath::testing::check_denominators(filter, scene, pool, kernel);
      segpath::testing::check_light_side(filter, scene, pool, side, kernel);
      CHECK(checked == pool.size());
      CHECK(with_techniques > checked / 10);
    }
  }
}

// The sun's and the sky's light paths start outside the closed box: most hit its walls from
// behind, where the one-sided BSDFs scatter nothing, and the sun is behind the right wall for
// its next-event segments. Such segments carry no light into any junction; pooled, they made
// most wall clusters general (box 3: 5 % of clusters factorised instead of 69 %) and doubled
// BDPF's memory. No pooled segment may bring light to the back of its x.
TEST_CASE("filtering pools no segment that brings light to the back of its x (sun, sky)", "[renderer]") {
  using segpath::FilteringMode;
  for (const FilteringMode mode : {FilteringMode::bdpf, FilteringMode::phf, FilteringMode::mvf}) {
    for (const int box : {0, 3, 1}) {
      INFO(segpath::to_string(mode) << ", box " << box);
      const RenderScene cornell = renderer::make_cornell(box, 16, 16);
      const renderer::ThreadCountingScene scene(cornell);
      segpath::FilteringOptions<float> o;
      o.mode = mode;
      o.light_path_ratio = 4;
      o.next_event = true;
      o.bridges = mode == FilteringMode::bdpf;
      const Filter filter(o);
      auto ctx = filter.context(scene, 0);
      filter.build_pool(ctx);
      const auto& pool = ctx.pool;
      std::size_t surface_x = 0, behind = 0, light_born = 0, bridges = 0;
      for (std::size_t i = 0; i < pool.size(); ++i) {
        const auto& x = pool.segments[i].x;
        if (x.kind != segpath::PointKind::surface) continue;
        ++surface_x;
        light_born += !(pool.flags[i] & segpath::filtering::not_light_born);
        bridges += (pool.flags[i] & segpath::filtering::bridge_segment) != 0;
        behind += !scene.bsdf().scatters_from(x, pool.first_direction[i]);
      }
      INFO(surface_x << " segments with a surface x, " << light_born << " light-born, " << bridges << " bridges");
      CHECK(surface_x > 200);
      if (mode != FilteringMode::mvf) CHECK(light_born > 100);
      if (o.bridges) CHECK(bridges > 50);
      CHECK(behind == 0);
    }
  }
}

// VCM's light subpaths from the sun and the sky hit the closed box from outside as well: their
// ends there light nothing and are not stored (a third of box 0's ends, half of box 3's).
TEST_CASE("VCM stores no light end that light reaches from behind (sun, sky)", "[renderer]") {
  for (const int box : {0, 3, 1}) {
    INFO("box " << box);
    const RenderScene cornell = renderer::make_cornell(box, 16, 16);
    const renderer::ThreadCountingScene scene(cornell);
    segpath::VcmOptions o;
    o.light_path_factor = 4;
    const segpath::VertexConnectionMerging<renderer::ThreadCountingScene> vcm(o);
    segpath::Framebuffer<renderer::Color> image(16, 16);
    segpath::DropCounters drops;
    vcm.render_iteration_at(scene, 0, 0.05f, image, drops);
    std::size_t surface = 0, behind = 0;
    for (const auto& end : vcm.light_ends()) {
      if (end.point.kind != segpath::PointKind::surface) continue;
      ++surface;
      behind += !scene.bsdf().scatters_from(end.point, end.to_previous);
    }
    INFO(surface << " stored ends on surfaces");
    CHECK(surface > 300);
    CHECK(behind == 0);
  }
}

// Next-event segments end on box 1's emitter in crowds, and the emitter reflects nothing
// (black Lambertian): f_r = 0 at those ends whatever their directions, so their clusters still
// factorise (the sum over starts is never needed). Before, one end arriving from the emitter's
// back made the whole cluster general, ~30 M pairs per iteration at 512 x 512.
TEST_CASE("BDPF on box 1: clusters with next-event ends on the black emitter factorise, same image", "[renderer]") {
  const RenderScene cornell = renderer::make_cornell(1, 48, 48);
  const renderer::ThreadCountingScene scene(cornell);
  segpath::FilteringOptions<float> o;
  o.next_event = true;
  const Filter filter(o);
  ClusteredPool clustered = clustered_pool(filter, scene, 0.06f);
  const auto& pool = clustered.context.pool;
  const auto& clustering = clustered.clustering;
  std::vector<std::uint8_t> factorised;
  std::vector<renderer::Color> diffuse;
  segpath::filtering::conditioned_factorisation(clustered.context, clustering, factorised, diffuse, segpath::SerialFor{});
  const auto& bsdf = scene.bsdf();
  std::size_t black_clusters = 0, black_factorised = 0;
  for (std::size_t c = 0; c < clustering.clusters().size(); ++c) {
    const auto& cl = clustering.clusters()[c];
    bool black_end = false, other_end = false;
    for (const std::uint32_t s : clustering.ending_segments(c)) {
      const auto albedo = bsdf.lambertian_albedo(pool.segments[s].y);
      (albedo && segpath::is_black(*albedo) ? black_end : other_end) = true;
    }
    if (!black_end || other_end || cl.begin == cl.middle) continue;  // clusters of emitter ends only
    ++black_clusters;
    black_factorised += factorised[c];
  }
  CHECK(black_clusters > 10);
  CHECK(black_factorised == black_clusters);
  // The image with and without factorisation (float sums in another order).
  segpath::Framebuffer<renderer::Color> a(48, 48), b(48, 48);
  segpath::DropCounters drops;
  filter.render_iteration_at(scene, 0, 0.06f, a, drops);
  o.factorise = false;
  Filter(o).render_iteration_at(scene, 0, 0.06f, b, drops);
  double difference = 0, total = 0;
  for (std::uint32_t p = 0; p < 48 * 48; ++p) {
    difference += std::abs(double(a[p].r) - double(b[p].r));
    total += std::abs(double(b[p].r));
  }
  CHECK(total > 0);
  CHECK(difference <= 1e-4 * total);
  CHECK(drops.total() == 0);
}

TEST_CASE("MVF stays within its bias bound of PT on box 1 and converges as the voxel shrinks", "[renderer][stat]") {
  check_filtering_bias("mvf", 256, renderer::make_cornell(1, size, size), pt_box(1));
}

// BDPF's glossy-floor tiles used to move away from PT as the voxel halved at beta = 0.25 (+7.6 %
// +- 1.4 % at h/2 on tile 12): the paper's chain weight prod 1 / D(s) counts a path neighbour as
// a technique sample only when it was born on the matching side, so it is biased where camera
// and light technique samples share sparse clusters. With the path-conditioned weighting
// (propagation/path_conditioned.hpp, the default) the floor tiles are within -3.1 ... +0.2 %
// of PT at h/2 and every tile is within its bound (measured).
TEST_CASE("BDPF stays within its bias bound of PT on box 1 and converges as the voxel shrinks",
          "[renderer][stat]") {
  check_filtering_bias("bdpf", 1024, renderer::make_cornell(1, size, size), pt_box(1));
}

// Glass under an area light (tests/renderer/data/glass_box.obj: a closed diffuse box, a small
// ceiling light, a glass cube floating under it): the light's caustic through the cube on the
// floor, the box seen through the cube, and chains in and out of the glass on both sides. PT
// samples every family here (the light has area), so BDPF, PhF and MVF must agree with it per
// tile within the bound of the box-1 test, and halving the voxel must not move a tile away. MVF
// used to darken two wall tiles by 4.1 % / 4.8 % at h and 4.9 % / 6.0 % at h/2 (128 iterations),
// growing as the voxels emptied: the chains through a camera path's last segment, lost where no
// other path's technique sample was near (docs/filtering.md, "The camera paths' depth limit").
// With that limit put back, MVF fails here (tile 10 moves -2.8 % from h to h/2, z -5.2).
#if SEGPATH_TEST_OBJ_SCENES
TEST_CASE("BDPF, PhF and MVF agree with PT under an area light through glass and converge as the voxel shrinks",
          "[renderer][stat]") {
  renderer::ObjCamera camera;
  camera.position = {0, -0.9f, 0.3f};
  camera.target = {0, 0.5f, -0.6f};
  camera.up = {0, 0, 1};
  camera.fov_y_degrees = 70;
  const std::filesystem::path data = std::filesystem::path(__FILE__).parent_path() / "data" / "glass_box.obj";
  const RenderScene scene = renderer::load_obj_scene(data.string(), camera, size, size);
  const PtReference reference = pt_reference(scene, 102, 1024);
  check_filtering_bias("bdpf", 256, scene, reference);
  check_filtering_bias("phf", 128, scene, reference);
  check_filtering_bias("mvf", 128, scene, reference);
}
#endif

// Box 3's sky lights the walls and floor through the mirror and glass spheres too. PhF has no
// camera successors, so only its light paths can carry that light: the sky's light starts
// continue through the spheres as chains kept like a Dirac light's (weight 1), and their light
// predecessors continue through the spheres as ordinary chains. Before the first, the sky's
// starts ended at the spheres (PhF -4.1 % at max length 3); before the second, a predecessor's
// chain after a sky start was kept with a zero density and dropped (-3 % at max length 4,
// -6.5 % at 6: the floor in front of the mirror sphere, which sees the sky through the mirror
// by way of the floor). Now both lengths are within 5 sigma + 2 % (the box-1 bound; the small
// fixed voxel's bias, -0.6 % with the spheres removed).
TEST_CASE("PhF carries the sky's light through the spheres of box 3", "[renderer][stat]") {
  constexpr std::uint32_t side = 32;
  const RenderScene scene = renderer::make_cornell(3, side, side);
  const Tiles whole{std::vector<int>(std::size_t(side) * side, 0), 1};
  for (const std::size_t max_length : {3, 6}) {
    INFO("max length " << max_length);
    renderer::MethodOptions options;
    options.seed = 707;
    options.max_length = max_length;
    const RunningStats pt = stats_of(iteration_tile_means("pt", options, scene, whole, 4096))[0];
    options.seed = 708;
    options.beta = 16;
    options.radius = 0.05;
    options.alpha = 0.9999;  // a fixed small voxel
    const RunningStats phf = stats_of(iteration_tile_means("phf", options, scene, whole, 768))[0];
    const double sigma = std::hypot(pt.standard_error(), phf.standard_error());
    INFO("PhF / PT " << phf.mean() / pt.mean() << " +- " << sigma / pt.mean());
    CHECK(std::abs(phf.mean() - pt.mean()) <= 5 * sigma + 0.02 * pt.mean());
    CHECK(5 * sigma + 0.02 * pt.mean() < (max_length == 3 ? 0.041 : 0.06) * pt.mean());  // the old deficits would fail
  }
}

#if SEGPATH_TEST_OBJ_SCENES
/// A closed box of tests/renderer/data seen from (0, -0.9, 0) towards `target`, 70 degrees
/// vertically, side x side pixels.
RenderScene closed_box_view(const char* file, const renderer::Vec3& target, std::uint32_t side) {
  renderer::ObjCamera camera;
  camera.position = {0, -0.9f, 0};
  camera.target = target;
  camera.up = {0, 0, 1};
  camera.fov_y_degrees = 70;
  const std::filesystem::path data = std::filesystem::path(__FILE__).parent_path() / "data" / file;
  return renderer::load_obj_scene(data.string(), camera, side, side);
}

/// Per iteration of `filter` on a side x side image, with voxels of side `cell` (the grid the
/// filter's options give, unjittered where they say so), the image mean over all pixels.
RunningStats iteration_image_means(const Filter& filter, const RenderScene& scene, std::uint32_t side, std::uint64_t iterations,
                                   float cell, segpath::DropCounters& drops) {
  const renderer::ThreadCountingScene counting(scene);
  RunningStats means;
  for (std::uint64_t i = 0; i < iterations; ++i) {
    segpath::Framebuffer<renderer::Color> image(side, side);
    filter.render_iteration_at(counting, i, cell, image, drops, renderer::TbbFor{});
    double mean = 0;
    for (std::uint32_t p = 0; p < image.pixel_count(); ++p) mean += channel_mean(segpath::Rgb<double>(image[p]));
    means.add(mean / image.pixel_count());
  }
  return means;
}

/// BDPF's options at `max_length` and `seed` on unjittered voxels (the closed boxes' walls lie on
/// their faces: no kernel bias).
segpath::FilteringOptions<float> unjittered_bdpf(std::size_t max_length, std::uint64_t seed) {
  segpath::FilteringOptions<float> o;
  o.max_length = max_length;
  o.jitter = false;
  o.seed = seed;
  return o;
}

/// PT's and BDPF's image means per iteration in `scene` (side x side), both at o.max_length,
/// BDPF with `o` on voxels of 1/16 (unjittered where o says so), and the error of their difference.
struct ImageMeans {
  RunningStats pt, bdpf;
  double sigma = 0;
  std::uint64_t drops = 0;
};
ImageMeans pt_and_bdpf_means(const RenderScene& scene, std::uint32_t side, std::uint64_t pt_seed, std::uint64_t pt_iterations,
                             const segpath::FilteringOptions<float>& o, std::uint64_t iterations) {
  renderer::MethodOptions options;
  options.seed = pt_seed;
  options.max_length = o.max_length;
  Tiles whole{std::vector<int>(std::size_t(side) * side, 0), 1};
  ImageMeans m;
  m.pt = stats_of(iteration_tile_means("pt", options, scene, whole, pt_iterations))[0];
  segpath::DropCounters drops;
  m.bdpf = iteration_image_means(Filter(o), scene, side, iterations, 1.0f / 16, drops);
  m.sigma = std::hypot(m.pt.standard_error(), m.bdpf.standard_error());
  m.drops = drops.total();
  return m;
}
#endif

// The closed diffuse box of the residual-bias report (tests/renderer/data/diffuse_box.obj; the
// path-conditioned weighting was 0.4-0.7 % dark there, growing with the path length, until light
// paths ended by roulette instead of at a depth: docs/bias-notes.md). Its walls lie on the faces
// of an unjittered grid of voxels of 1/16, so every voxel's clipped plane is exactly the
// surface it holds and the voxel kernel has no edge bias (the jittered kernel's is O(h): -0.73,
// -0.47, -0.26 % at h = 0.066, 0.033, 0.0165); its blur only moves light within a voxel, which
// the image mean sees at second order (measured with the walls clipped: 0.9999 +- 0.0006).
// BDPF's image mean must then be PT's within 3 standard errors at max length 2, 3 and 10, and
// the test must resolve the old defect (-0.3 % at max length 10 with the walls clipped).
// With bridges too: their density B(s) counts the targets near y_s, the successor among them
// when it is light-born, and the weighting took it as it was until a junction left a target
// successor's term out (conditioned_coefficients): +4.5 % at max length 3, +1.8 % at 10.
#if SEGPATH_TEST_OBJ_SCENES
TEST_CASE("BDPF's image mean is PT's in a closed diffuse box at max length 2, 3 and 10, with bridges too (no kernel bias)",
          "[renderer][stat]") {
  constexpr std::uint32_t side = 32;
  const RenderScene scene = closed_box_view("diffuse_box.obj", {0, 1, 0}, side);
  Tiles whole{std::vector<int>(std::size_t(side) * side, 0), 1};
  // The camera paths' Russian roulette: BDPF's automatic one (continuation 0.7), whose coin every
  // camera successor's density carries, and at max length 10 also none (1); bridges at 3 and 10.
  struct Row {
    std::size_t max_length;
    float camera_continuation;
    bool bridges;
  };
  for (const auto& [max_length, camera_continuation, bridges] :
       {Row{2, -1.0f, false}, Row{3, -1.0f, false}, Row{10, -1.0f, false}, Row{10, 1.0f, false}, Row{3, -1.0f, true},
        Row{10, -1.0f, true}}) {
    renderer::MethodOptions options;
    options.seed = 500 + max_length;
    options.max_length = max_length;
    const RunningStats pt = stats_of(iteration_tile_means("pt", options, scene, whole, 4096))[0];
    segpath::FilteringOptions<float> o;
    o.max_length = max_length;
    o.jitter = false;
    o.seed = 600 + max_length + (camera_continuation > 0.0f ? 1000 : 0) + (bridges ? 2000 : 0);
    o.camera_continuation = camera_continuation;
    o.bridges = bridges;
    segpath::DropCounters drops;
    // 560 iterations: a Poisson count of light paths (1,024 on average here) adds its own spread
    // to each iteration, and 400 no longer resolved 0.3 % at max length 3 and 10 with bridges.
    const RunningStats bdpf = iteration_image_means(Filter(o), scene, side, 560, 1.0f / 16, drops);
    const double sigma = std::hypot(pt.standard_error(), bdpf.standard_error());
    INFO("max length " << max_length << ", camera continuation " << camera_continuation << (bridges ? ", bridges" : "")
                       << ": BDPF / PT " << bdpf.mean() / pt.mean() << " +- " << sigma / pt.mean() << " (PT " << pt.mean()
                       << " +- " << pt.standard_error() << ")");
    CHECK(drops.total() == 0);
    CHECK(std::abs(bdpf.mean() - pt.mean()) <= 3 * sigma);
    CHECK(3 * sigma < 0.003 * pt.mean());  // resolves the old defect
  }
}
#endif

// The same box with few light paths an iteration: 32 x 32 pixels at beta 0.25, N_L = 256. A
// light path's own later visits of the cluster of one of its segments were counted in that
// segment's D_l, and such visits happen only when the segment was drawn, so BDPF was
// O(1 / N_L) dark: -0.20 +- 0.03 % here at max length 10 (docs/filtering.md). A predecessor
// (successor) draw is now a light (camera) technique sample only at its path's first visit of a
// voxel (filtering::Context::visit_grid), and chains no longer go round trips between a segment
// and its own light predecessor or camera parent (ConditionedInputs::backtrack): 0.99913 +-
// 0.00041 (0.99892 with the light paths' rule alone). Power (checked in session 47): with every
// visit counted on both sides, as before, this fails (0.99814 +- 0.00041).
#if SEGPATH_TEST_OBJ_SCENES
TEST_CASE("BDPF's image mean is PT's in the closed diffuse box with 256 light paths an iteration", "[renderer][stat]") {
  constexpr std::uint32_t side = 32;
  segpath::FilteringOptions<float> o = unjittered_bdpf(10, 6010);
  o.light_path_ratio = 0.25f;
  const auto [pt, bdpf, sigma, drops] = pt_and_bdpf_means(closed_box_view("diffuse_box.obj", {0, 1, 0}, side), side, 5010, 8192, o, 6000);
  INFO("BDPF / PT " << bdpf.mean() / pt.mean() << " +- " << sigma / pt.mean());
  CHECK(drops == 0);
  CHECK(std::abs(bdpf.mean() - pt.mean()) <= 3 * sigma);
  CHECK(3 * sigma < 0.0015 * pt.mean());  // resolves the old deficit
}
#endif

// The same box with camera paths that have no depth limit. A camera path that stopped at
// max_length segments drew no successor from its last segment's end, so that end was no camera
// technique sample: the chains through that segment went on only where another path's sample
// lay in the next cluster, and in sparse clusters they were lost. MVF (every chain camera-born)
// at max length 4, here at 32 x 32, was 0.977 of PT with the roulette at 0.7 and 0.964 at its
// default (no roulette) before the limit went (docs/figures.md, session 52); past max_length a
// path now continues with the tail's roulette (TechniqueSet::camera_tail_continuation).
#if SEGPATH_TEST_OBJ_SCENES
TEST_CASE("MVF is PT's in the closed diffuse box with and without a camera roulette (camera paths have no depth limit)",
          "[renderer][stat]") {
  constexpr std::uint32_t side = 32;
  for (const float camera_continuation : {0.7f, -1.0f}) {
    segpath::FilteringOptions<float> o = unjittered_bdpf(4, camera_continuation > 0 ? 7010 : 7011);
    o.mode = segpath::FilteringMode::mvf;
    o.camera_continuation = camera_continuation;
    const auto [pt, mvf, sigma, drops] =
        pt_and_bdpf_means(closed_box_view("diffuse_box.obj", {0, 1, 0}, side), side, 7020, 16384, o, 3000);
    INFO("camera continuation " << camera_continuation << ": MVF / PT " << mvf.mean() / pt.mean() << " +- " << sigma / pt.mean());
    CHECK(drops == 0);
    CHECK(std::abs(mvf.mean() - pt.mean()) <= 3 * sigma);
    CHECK(3 * sigma < 0.002 * pt.mean());  // resolves the old deficits
  }
}
#endif

// The same box under water (tests/renderer/data/water_box.obj: a glass slab of index 1.5 from
// just below the floor to z = -0.5): the floor lies in the medium, the light above it, so the
// light start's chains light -> surface -> floor and the camera successors' chains floor ->
// surface -> light join two media. Such a chain's light-side density converts area x solid angle
// at y to the chain's area x solid angle at x by cos_x / cos_y alone, leaving out the etendue's
// (n_x / n_y)^2, and a light-born chain carries its importance throughput, which differs from
// the radiance one by the same factor; both factors are properties of the chain, so the balance
// weights still sum to one and the image is unbiased (docs/filtering.md). The floor and walls lie
// on the faces of unjittered voxels of 1/16, as above: no kernel bias. Power (checked): with
// either factor alone, light_measure times 2.25 on chains through a transmission or the light
// paths' delta bounces sampled as radiance transport, BDPF / PT is 0.776 or 0.783.
#if SEGPATH_TEST_OBJ_SCENES
TEST_CASE("BDPF's image mean is PT's with the floor under water (chains between two media)", "[renderer][stat]") {
  constexpr std::uint32_t side = 32;
  const auto [pt, bdpf, sigma, drops] =
      pt_and_bdpf_means(closed_box_view("water_box.obj", {0, 0.5f, -0.8f}, side), side, 700, 16384, unjittered_bdpf(4, 800), 3200);
  INFO("BDPF / PT " << bdpf.mean() / pt.mean() << " +- " << sigma / pt.mean() << " (PT " << pt.mean() << " +- "
                    << pt.standard_error() << ")");
  CHECK(drops == 0);
  CHECK(std::abs(bdpf.mean() - pt.mean()) <= 3 * sigma);
  CHECK(3 * sigma < 0.01 * pt.mean());
}
#endif

// PhF's camera side is the sensor segment alone (through any mirror chain), and its light paths
// continue through mirror reflections as light-born chains (light -> mirror -> diffuse, the
// caustics on the ceiling and walls), so on pixels whose every PT sample's first camera hit is
// diffuse it covers every path of box 1 (no glass): it must agree with PT there within the
// voxel bias bound of the MVF/BDPF test (5 sigma + 2 %). Before the light-born chains it was
// 20-64 % darker per tile. Power: a PT 10 % too bright is rejected on some tile.
TEST_CASE("PhF agrees with PT on box 1's diffuse first hits", "[renderer][stat]") {
  Tiles tiles = square_tiles();
  const auto& reference = pt_box(1);
  for (std::size_t p = 0; p < tiles.of.size(); ++p)
    if (!reference.diffuse_first[p]) tiles.of[p] = -1;
  const RenderScene scene = renderer::make_cornell(1, size, size);
  renderer::MethodOptions options;
  options.seed = 303;
  options.beta = 0.25;
  const auto phf = stats_of(iteration_tile_means("phf", options, scene, tiles, 128));
  const auto d = differences(reference.tiles(tiles), phf);
  const auto d_wrong = differences(reference.tiles(tiles, 1.10), phf);
  std::size_t wrong_rejected = 0;
  for (std::size_t t = 0; t < d.size(); ++t) {
    if (!(d[t].pt > 0)) continue;
    INFO("PhF tile " << t << ": PT " << d[t].pt << ", PhF " << d[t].method << " (" << d[t].difference / d[t].pt * 100
                     << " % +- " << d[t].sigma / d[t].pt * 100 << " %)");
    CHECK(std::abs(d[t].difference) <= 5 * d[t].sigma + 0.02 * d[t].pt);
    wrong_rejected += std::abs(d_wrong[t].difference) > 5 * d_wrong[t].sigma + 0.02 * d_wrong[t].pt;
  }
  CHECK(wrong_rejected > 0);
}
