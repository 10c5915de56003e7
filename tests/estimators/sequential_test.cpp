// Segment path tracing (sequential estimator, Dirac kernel) is unbiased on the sphere
// interior: every probe and every bounce, float and double, by Student t-tests.
#include <segpath/estimators/sequential.hpp>
#include <segpath/kernels/dirac.hpp>
#include <segpath/testing/sphere_interior.hpp>
#include <segpath/testing/statistics.hpp>

#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

template <class T>
testing::SphereInterior<T> make_sphere() {
  testing::SphereInteriorParameters<T> p;
  p.center = {T(0.5), T(-1), T(2)};
  p.radius = T(1.5);
  p.emission_mean = T(1);
  p.emission_gradient = {T(0.3), T(-0.2), T(0.6)};
  p.albedo_mean = T(0.6);
  p.albedo_gradient = {T(-0.15), T(0.2), T(0.1)};
  return testing::SphereInterior<T>(
      p, {{0, 0, 1}, {1, 0, 0}, {0, -1, 0}, {1, 1, -1}, {-0.3, 0.5, -0.8}});
}

/// Records one value per estimate call.
template <class S>
struct RecordingSink {
  S value{};
  bool dropped = false;
  void add(std::uint32_t, const S& v) noexcept { value = v; }
  void drop(DropReason) noexcept { dropped = true; }
};

}  // namespace

TEMPLATE_TEST_CASE("sequential estimator: construction and concept", "[estimators]", float, double) {
  using T = TestType;
  using Scn = testing::SphereInterior<T>;
  static_assert(LightSampledScene<Scn>);
  static_assert(Estimator<SequentialEstimator<Scn, DiracKernel<T>>, Scn>);
  static_assert(SegmentSampler<SensorStartSampler<Scn>, Scn>);
  static_assert(SegmentSampler<NextSegmentSampler<Scn, DiracKernel<T>>, Scn>);
  CHECK_THROWS_AS((SequentialEstimator<Scn, DiracKernel<T>>(DiracKernel<T>{}, {0, 3})), std::invalid_argument);
  CHECK_THROWS_AS((SequentialEstimator<Scn, DiracKernel<T>>(DiracKernel<T>{}, {4, 3})), std::invalid_argument);
}

TEMPLATE_TEST_CASE("sampled segment densities match the samplers' pdf", "[estimators][samplers]", float, double) {
  using T = TestType;
  const auto scene = make_sphere<T>();
  using Scn = testing::SphereInterior<T>;
  SensorStartSampler<Scn> first;
  NextSegmentSampler<Scn, DiracKernel<T>> next{DiracKernel<T>{}};
  Pcg32 rng(7, 1);
  for (int i = 0; i < 1000; ++i) {
    const std::uint32_t pixel = static_cast<std::uint32_t>(i % 5);
    auto s1 = first.sample(scene, {pixel}, rng);
    REQUIRE(s1);
    CHECK(first.pdf(scene, {pixel}, s1->segment) == Approx(s1->pdf).epsilon(1e-4));
    CHECK(first.pdf(scene, {(pixel + 1) % 5}, s1->segment) == T(0));
    auto s2 = next.sample(scene, {s1->segment}, rng);
    REQUIRE(s2);
    CHECK(next.pdf(scene, {s1->segment}, s2->segment) == Approx(s2->pdf).epsilon(1e-3));
    // The sampled factor is the contribution factor of (N17).
    CHECK(s2->factor == Approx(link_factor(scene, DiracKernel<T>{}, s1->segment, s2->segment)).epsilon(1e-4));
    // The whole path's g / p equals the product of the per-segment ratios.
    SegmentPath<T, 2> path;
    path.push_back(s1->segment);
    path.push_back(s2->segment);
    const auto g = path_contribution(scene, DiracKernel<T>{}, path);
    REQUIRE(g);
    CHECK(g->pixel == pixel);
    const T product = (s1->factor / s1->pdf) * (s2->factor / s2->pdf) * emission_factor(scene, s2->segment);
    CHECK(g->value / (s1->pdf * s2->pdf) == Approx(product).epsilon(1e-3));
  }
}

namespace {

/// Mean of `samples` estimates of probe `pixel`, as RunningStats-like (n, mean, variance).
template <class Est, class Scn>
testing::RunningStats run_probe(const Est& estimator, const Scn& scene, std::uint32_t pixel,
                                std::uint64_t samples, std::uint64_t seed, std::uint64_t* drops = nullptr) {
  testing::RunningStats stats;
  for (std::uint64_t i = 0; i < samples; ++i) {
    Pcg32 rng = Pcg32::for_sample(seed, pixel, i);
    RecordingSink<typename Scn::Spectrum> sink;
    estimator.estimate(scene, EstimateQuery{pixel, i}, rng, sink);
    if (sink.dropped && drops) ++*drops;
    stats.add(static_cast<double>(sink.dropped ? 0 : sink.value));
  }
  return stats;
}

}  // namespace

namespace {

constexpr unsigned max_bounce = 5;
constexpr std::uint32_t probe_count = 5;
constexpr std::uint64_t samples_per_test = 20000;
// t-tests in this file: 2 types x 5 probes x (6 bounces + 1 full), family alpha 0.01.
const double per_test_alpha = testing::sidak_alpha(0.01, 2 * probe_count * (max_bounce + 2));

/// A sphere whose BSDF sampler under-reports its density by 10 %: the deliberately wrong
/// variant the same t-test must reject.
template <class T>
class SphereWithWrongPdf : public testing::SphereInterior<T> {
 public:
  using testing::SphereInterior<T>::SphereInterior;
  class Materials {
   public:
    explicit Materials(const testing::SphereInterior<T>& s) : inner_(s.bsdf()) {}
    [[nodiscard]] T eval(const BsdfQuery<T>& q) const noexcept { return inner_.eval(q); }
    [[nodiscard]] std::optional<BsdfSample<T>> sample(const BsdfSampleQuery<T>& q) const noexcept {
      auto s = inner_.sample(q);
      if (s) s->pdf *= T(0.9);
      return s;
    }
    [[nodiscard]] T pdf(const BsdfQuery<T>& q) const noexcept { return inner_.pdf(q); }

   private:
    typename testing::SphereInterior<T>::Materials inner_;
  };
  [[nodiscard]] Materials bsdf() const noexcept { return Materials(*this); }
};

}  // namespace

TEMPLATE_TEST_CASE("segment path tracing is unbiased inside the sphere, per bounce", "[estimators][stat]", float,
                   double) {
  using T = TestType;
  const auto scene = make_sphere<T>();
  using Scn = testing::SphereInterior<T>;
  for (std::uint32_t pixel = 0; pixel < probe_count; ++pixel) {
    const Vec3<T> x = scene.probe_target(pixel);
    double full_expected = 0;
    for (unsigned bounce = 0; bounce <= max_bounce; ++bounce) {
      const double expected = scene.bounce_radiance_at(x, bounce);
      full_expected += expected;
      const SequentialEstimator<Scn, DiracKernel<T>> estimator(DiracKernel<T>{}, {bounce + 1, bounce + 1});
      std::uint64_t drops = 0;
      const auto stats = run_probe(estimator, scene, pixel, samples_per_test, 1000 + bounce, &drops);
      const auto t = testing::student_t_test(stats, expected);
      INFO("probe " << pixel << " bounce " << bounce << ": mean " << stats.mean() << " +- "
                    << stats.standard_error() << ", expected " << expected << ", p = " << t.p_value);
      CHECK(drops == 0);
      if (stats.variance() == 0) {
        // Bounce 0 is deterministic (the probe sees L_e exactly): no t-test, a rounding bound.
        CHECK(stats.mean() == Approx(expected).epsilon(1e-5));
      } else {
        CHECK_FALSE(t.rejects(per_test_alpha));
      }
    }
    // All paths up to max_bounce + 1 segments against the truncated closed form.
    const SequentialEstimator<Scn, DiracKernel<T>> estimator(DiracKernel<T>{}, {1, max_bounce + 1});
    const auto stats = run_probe(estimator, scene, pixel, samples_per_test, 77);
    const auto t = testing::student_t_test(stats, full_expected);
    INFO("probe " << pixel << " all bounces: mean " << stats.mean() << " +- " << stats.standard_error()
                  << ", expected " << full_expected << ", p = " << t.p_value);
    CHECK_FALSE(t.rejects(per_test_alpha));
  }
}

TEMPLATE_TEST_CASE("the same t-test rejects an estimator whose pdf is off by 10 %", "[estimators][stat]", float,
                   double) {
  using T = TestType;
  const auto base = make_sphere<T>();
  const SphereWithWrongPdf<T> scene(base.parameters(), std::vector<Vec3<T>>{{0, 0, 1}});
  using Scn = SphereWithWrongPdf<T>;
  static_assert(segpath::Scene<Scn>);
  const Vec3<T> x = scene.probe_target(0);
  for (unsigned bounce = 1; bounce <= 2; ++bounce) {
    const SequentialEstimator<Scn, DiracKernel<T>> estimator(DiracKernel<T>{}, {bounce + 1, bounce + 1});
    const auto stats = run_probe(estimator, scene, 0, samples_per_test, 5);
    const auto t = testing::student_t_test(stats, scene.bounce_radiance_at(x, bounce));
    INFO("bounce " << bounce << ": mean " << stats.mean() << " +- " << stats.standard_error() << ", p = " << t.p_value);
    CHECK(t.rejects(per_test_alpha));
  }
}
