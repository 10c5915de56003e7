// Marginal segment path sampling (N41, N42) on the periodic slab: the light-merge technique's
// densities, reduction to SMIS for one family, agreement of the estimator with the generic
// formula, unbiasedness per path length, and rejection of a denominator missing a family.
#include <cmath>
#include <segpath/estimators/marginal.hpp>
#include <segpath/kernels/dirac.hpp>
#include <segpath/kernels/disk.hpp>
#include <segpath/testing/periodic_slab.hpp>
#include <segpath/testing/statistics.hpp>
#include <segpath/weights/smis.hpp>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

template <class T>
testing::PeriodicSlab<T> make_slab() {
  testing::PeriodicSlabParameters<T> p;
  p.height = T(1);
  p.period = T(1);
  p.emission_a = T(1);
  p.emission_b = T(0.5);
  p.albedo_a = T(0.6);
  p.albedo_b = T(0.4);
  return testing::PeriodicSlab<T>(
      p,
      {testing::SlabProbe<T>{{T(0.2), T(0.3), T(0.5)}, testing::SlabSide::a, {T(0.1), T(0.7)}},
       testing::SlabProbe<T>{{T(0.5), T(0.5), T(0.25)}, testing::SlabSide::b, {T(0.9), T(0.2)}}});
}

constexpr std::size_t max_length = 4;
constexpr std::size_t max_lights = 8;
template <class T>
using Slab = testing::PeriodicSlab<T>;
template <class T>
using Merge = LightMergePathTechnique<Slab<T>, DiracKernel<T>, DiskKernel<T>, max_length>;
template <class T>
using Marginal =
    MarginalPathEstimator<Slab<T>, DiracKernel<T>, DiskKernel<T>, max_length, max_lights>;
template <class T>
using Path = SegmentPath<T, max_length>;

template <class S>
struct SummingSink {
  S value{};
  std::uint64_t drops = 0;
  void add(std::uint32_t, const S& v) noexcept { value += v; }
  void drop(DropReason) noexcept { ++drops; }
};

/// The draws of one Marginal::estimate call, replayed in the same order from the same stream:
/// light technique samples, then n_s sequential paths, then one merge path per light sample.
template <class T>
struct Draws {
  std::vector<Segment<T>> lights;
  std::vector<Path<T>> paths;
};

template <class T>
Draws<T> replay(const Marginal<T>& e, const Slab<T>& scene, std::uint32_t pixel, std::size_t n_s,
                std::size_t n_l, Pcg32& rng) {
  Draws<T> d;
  LightStartSampler<Slab<T>> light_start;
  for (std::size_t j = 0; j < n_l; ++j)
    if (const auto l = light_start.sample(scene, {}, rng)) d.lights.push_back(l->segment);
  const PathQuery q{pixel, e.length()};
  for (std::size_t j = 0; j < n_s; ++j)
    if (const auto p = e.sequential().sample(scene, q, rng)) d.paths.push_back(p->path);
  for (const auto& l : d.lights)
    if (const auto p = e.merge().sample(scene, q, l, rng)) d.paths.push_back(p->path);
  return d;
}

}  // namespace

TEMPLATE_TEST_CASE("marginal estimator: concepts and construction", "[estimators]", float, double) {
  using T = TestType;
  static_assert(LightSampledScene<Slab<T>>);
  static_assert(Estimator<Marginal<T>, Slab<T>>);
  const DiracKernel<T> k;
  const DiskKernel<T> m(T(0.3));
  CHECK_THROWS_AS(Marginal<T>(k, m, 1, 1, 2), std::invalid_argument);
  CHECK_THROWS_AS(Marginal<T>(k, m, 5, 1, 2), std::invalid_argument);
  CHECK_THROWS_AS(Marginal<T>(k, m, 2, 0, 2), std::invalid_argument);
  CHECK_THROWS_AS(Marginal<T>(k, m, 2, 1, max_lights + 1), std::invalid_argument);
  CHECK_NOTHROW(Marginal<T>(k, m, 2, 1, 0));
}

TEMPLATE_TEST_CASE("light-merge technique: pdf of a drawn path equals its density", "[estimators]",
                   float, double) {
  using T = TestType;
  const auto scene = make_slab<T>();
  const Merge<T> merge(DiracKernel<T>{}, DiskKernel<T>(T(0.3)));
  LightStartSampler<Slab<T>> light_start;
  const T tolerance = std::is_same_v<T, float> ? T(2e-3) : T(1e-9);
  Pcg32 rng(21, 4);
  int drawn = 0;
  for (int i = 0; i < 400; ++i) {
    const PathQuery q{static_cast<std::uint32_t>(i % 2), static_cast<std::size_t>(2 + i % 3)};
    const auto l = light_start.sample(scene, {}, rng);
    REQUIRE(l);
    const auto p = merge.sample(scene, q, l->segment, rng);
    if (!p) continue;  // the merged end fell on the plane of x_k: not visible
    ++drawn;
    CHECK(p->path.size() == q.length);
    CHECK(merge.pdf(scene, q, p->path, l->segment) == Approx(p->pdf).epsilon(tolerance));
    // The last end lies within the merge radius of the light end of l, and nowhere else.
    Segment<T> far = l->segment;
    far.y.position += Vec3<T>(T(0.7), 0, 0);
    CHECK(merge.pdf(scene, q, p->path, far) == T(0));
    CHECK(merge.pdf(scene, {(q.pixel + 1) % 2, q.length}, p->path, l->segment) == T(0));
  }
  CHECK(drawn > 100);
}

TEST_CASE("marginal estimate with a single family reduces to SMIS", "[estimators]") {
  using T = double;
  const auto scene = make_slab<T>();
  const Merge<T> merge(DiracKernel<T>{}, DiskKernel<T>(T(0.3)));
  LightStartSampler<Slab<T>> light_start;
  Pcg32 rng(8, 2);
  for (std::size_t length = 2; length <= max_length; ++length) {
    for (int trial = 0; trial < 30; ++trial) {
      const PathQuery q{static_cast<std::uint32_t>(trial % 2), length};
      std::vector<Segment<T>> lights;
      std::vector<Path<T>> paths;
      for (int j = 0; j < 6; ++j) {
        lights.push_back(light_start.sample(scene, {}, rng)->segment);
        if (const auto p = merge.sample(scene, q, lights.back(), rng)) paths.push_back(p->path);
      }
      const auto pdf = [&](const Path<T>& path, const Segment<T>& l) {
        return merge.pdf(scene, q, path, l);
      };
      const auto g = [&](const Path<T>& path) {
        const auto c = path_contribution(scene, DiracKernel<T>{}, path);
        return c ? c->value : T(0);
      };
      const T mmis = marginal_estimate(paths, g, ConditionalFamily(lights, pdf));
      const T smis = smis_estimate(paths, lights, g, pdf);
      CHECK(mmis == Approx(smis).epsilon(1e-12));
    }
  }
}

TEST_CASE("marginal estimator equals the generic (N42) sum on the same draws", "[estimators]") {
  using T = double;
  const auto scene = make_slab<T>();
  const Marginal<T> e(DiracKernel<T>{}, DiskKernel<T>(T(0.3)), 3, 2, 5);
  int nonzero = 0;
  for (std::uint64_t i = 0; i < 200; ++i) {
    const std::uint32_t pixel = static_cast<std::uint32_t>(i % 2);
    Pcg32 rng = Pcg32::for_sample(4, pixel, i);
    SummingSink<T> sink;
    e.estimate(scene, EstimateQuery{pixel, i}, rng, sink);
    REQUIRE(sink.drops == 0);
    Pcg32 again = Pcg32::for_sample(4, pixel, i);
    const Draws<T> d = replay(e, scene, pixel, 2, 5, again);
    const auto g = [&](const Path<T>& path) {
      const auto c = path_contribution(scene, DiracKernel<T>{}, path);
      return c ? c->value : T(0);
    };
    const T expected =
        marginal_estimate(d.paths, g, e.sequential_family(scene, pixel),
                          e.merge_family(scene, pixel, std::span<const Segment<T>>(d.lights)));
    CHECK(sink.value == Approx(expected).epsilon(1e-12));
    // Hand-written denominator of one path: 2 p_seq + sum_j p(s | l_j).
    if (!d.paths.empty()) {
      const Path<T>& path = d.paths.back();
      const PathQuery q{pixel, 3};
      double denominator = 2 * e.sequential().pdf(scene, q, path);
      for (const auto& l : d.lights) denominator += e.merge().pdf(scene, q, path, l);
      CHECK(mmis_denominator(path, e.sequential_family(scene, pixel),
                             e.merge_family(scene, pixel, std::span<const Segment<T>>(d.lights))) ==
            Approx(denominator).epsilon(1e-12));
    }
    if (sink.value != 0) ++nonzero;
  }
  CHECK(nonzero > 100);
}

namespace {
constexpr std::uint64_t samples_per_test = 20000;
// t-tests in this file: 2 types x 3 lengths x 2 probes, plus 2 types x 2 lengths for the wrong
// variant; family alpha 0.01.
const double per_test_alpha = testing::sidak_alpha(0.01, 2 * 3 * 2 + 2 * 2);
}  // namespace

TEMPLATE_TEST_CASE("marginal path sampling is unbiased per path length on the slab",
                   "[estimators][stat]", float, double) {
  using T = TestType;
  const auto scene = make_slab<T>();
  for (std::size_t length = 2; length <= max_length; ++length) {
    const Marginal<T> e(DiracKernel<T>{}, DiskKernel<T>(T(0.3)), length, 1, 4);
    for (std::uint32_t pixel = 0; pixel < 2; ++pixel) {
      const double expected =
          scene.bounce_radiance(scene.probe_side(pixel), static_cast<unsigned>(length - 1));
      testing::RunningStats stats;
      std::uint64_t drops = 0;
      for (std::uint64_t i = 0; i < samples_per_test; ++i) {
        Pcg32 rng = Pcg32::for_sample(40 + length, pixel, i);
        SummingSink<T> sink;
        e.estimate(scene, EstimateQuery{pixel, i}, rng, sink);
        drops += sink.drops;
        stats.add(static_cast<double>(sink.value));
      }
      const auto t = testing::student_t_test(stats, expected);
      INFO("k " << length << " probe " << pixel << ": mean " << stats.mean() << " +- "
                << stats.standard_error() << ", expected " << expected << ", p = " << t.p_value);
      CHECK(drops == 0);
      CHECK_FALSE(t.rejects(per_test_alpha));
    }
  }
}

TEMPLATE_TEST_CASE("the same t-test rejects a marginal denominator missing the sequential family",
                   "[estimators][stat]", float, double) {
  using T = TestType;
  const auto scene = make_slab<T>();
  for (std::size_t length = 2; length <= 3; ++length) {
    const Marginal<T> e(DiracKernel<T>{}, DiskKernel<T>(T(0.3)), length, 1, 4);
    const auto g = [&](const Path<T>& path) {
      const auto c = path_contribution(scene, DiracKernel<T>{}, path);
      return c ? c->value : T(0);
    };
    testing::RunningStats stats;
    for (std::uint64_t i = 0; i < samples_per_test; ++i) {
      Pcg32 rng = Pcg32::for_sample(70 + length, 0, i);
      const Draws<T> d = replay(e, scene, 0, 1, 4, rng);
      stats.add(static_cast<double>(marginal_estimate(
          d.paths, g, e.merge_family(scene, 0, std::span<const Segment<T>>(d.lights)))));
    }
    const auto t = testing::student_t_test(
        stats, scene.bounce_radiance(scene.probe_side(0), static_cast<unsigned>(length - 1)));
    INFO("k " << length << ": mean " << stats.mean() << " +- " << stats.standard_error()
              << ", p = " << t.p_value);
    CHECK(t.rejects(per_test_alpha));
  }
}
