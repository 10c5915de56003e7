// The multi-technique MIS estimator (N36, N37) with sequential and next-event path techniques:
// densities, weights summing to one, unbiasedness per path length on the sphere interior, and
// rejection of a variant whose denominator misses one technique.
#include <cmath>
#include <segpath/estimators/multi_technique.hpp>
#include <segpath/kernels/dirac.hpp>
#include <segpath/testing/sphere_interior.hpp>
#include <segpath/testing/statistics.hpp>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

/// The sphere interior whose next-event sampling (sample_towards) prefers the +z half:
/// area density (1 + a u_z) / |M|, u the outward unit vector. The radiometry, hence the closed
/// form, is the sphere's; only the light technique's density differs from BSDF sampling's.
template <class T>
class SphereWithSkewedLight : public testing::SphereInterior<T> {
 public:
  using Base = testing::SphereInterior<T>;
  SphereWithSkewedLight(const testing::SphereInteriorParameters<T>& p,
                        const std::vector<Vec3<T>>& probes)
      : Base(p, probes) {}

  static constexpr T skew = T(0.6);

  class Emission {
   public:
    explicit Emission(const SphereWithSkewedLight& s) : s_(&s), inner_(s.Base::emitter()) {}
    [[nodiscard]] T radiance(const EmissionQuery<T>& q) const noexcept {
      return inner_.radiance(q);
    }
    [[nodiscard]] std::optional<EmissionSample<T>> sample_emission(
        const EmissionSampleQuery<T>& q) const noexcept {
      return inner_.sample_emission(q);
    }
    [[nodiscard]] EmissionPdf<T> pdf_emission(const EmissionPdfQuery<T>& q) const noexcept {
      return inner_.pdf_emission(q);
    }
    [[nodiscard]] std::optional<EmitterTowardsSample<T>> sample_towards(
        const EmitterTowardsQuery<T>& q) const noexcept {
      // z has density (1 + a z) / 2 on [-1, 1]: invert its quadratic CDF.
      const T disc = T(1) - T(2) * skew * (T(1) - skew / T(2) - T(2) * q.u.x);
      const T z = std::clamp((std::sqrt(std::max(disc, T(0))) - T(1)) / skew, T(-1), T(1));
      const T r = std::sqrt(std::max(T(0), T(1) - z * z));
      const T phi = T(2) * pi<T> * q.u.y;
      const SurfacePoint<T> y = s_->point_at(Vec3<T>(r * std::cos(phi), r * std::sin(phi), z));
      const Vec3<T> to_receiver = q.receiver.position - y.position;
      const T d2 = glm::dot(to_receiver, to_receiver);
      if (!(d2 > T(0))) return std::nullopt;
      const T pdf = density(y);
      if (!(pdf > T(0))) return std::nullopt;
      return EmitterTowardsSample<T>{y, radiance(EmissionQuery<T>{y, to_receiver / std::sqrt(d2)}),
                                     pdf};
    }
    [[nodiscard]] T pdf_towards(const EmitterPdfTowardsQuery<T>& q) const noexcept {
      return density(q.point);
    }

   private:
    [[nodiscard]] T density(const SurfacePoint<T>& y) const noexcept {
      const T uz = (y.position.z - s_->parameters().center.z) / s_->parameters().radius;
      return (T(1) + skew * uz) / s_->area();
    }
    const SphereWithSkewedLight* s_;
    typename Base::Emission inner_;
  };
  [[nodiscard]] Emission emitter() const noexcept { return Emission(*this); }
};

template <class T>
SphereWithSkewedLight<T> make_scene() {
  testing::SphereInteriorParameters<T> p;
  p.center = {T(0.5), T(-1), T(2)};
  p.radius = T(1.5);
  p.emission_mean = T(1);
  p.emission_gradient = {T(0.3), T(-0.2), T(0.6)};
  p.albedo_mean = T(0.6);
  p.albedo_gradient = {T(-0.15), T(0.2), T(0.1)};
  return SphereWithSkewedLight<T>(p, {{0, 0, 1}, {1, 0, 0}, {-0.3, 0.5, -0.8}});
}

constexpr std::size_t max_length = 4;

template <class T>
using Scn = SphereWithSkewedLight<T>;
template <class T>
using Seq = SequentialPathTechnique<Scn<T>, DiracKernel<T>, max_length>;
template <class T>
using Nee = LightBridgePathTechnique<Scn<T>, DiracKernel<T>, max_length>;
template <class T>
using Estimator2 = MultiTechniqueEstimator<Scn<T>, DiracKernel<T>, Seq<T>, Nee<T>>;

/// A technique that draws like Tech but reports density 0 for every path: in the estimator it
/// removes Tech's term from the other technique's denominators (the deliberately wrong variant).
template <class Tech>
struct HiddenPdf : Tech {
  using Tech::Tech;
  using Path = typename Tech::Path;
  template <class Scene>
  [[nodiscard]] auto pdf(const Scene&, const PathQuery&, const Path&) const noexcept {
    return typename Scene::Scalar(0);
  }
};

/// Sums every contribution to the pixel it is added to.
template <class S>
struct SummingSink {
  std::uint32_t pixel = 0;
  S value{};
  std::uint64_t drops = 0;
  std::uint64_t foreign = 0;
  void add(std::uint32_t p, const S& v) noexcept {
    if (p == pixel)
      value += v;
    else
      ++foreign;
  }
  void drop(DropReason) noexcept { ++drops; }
};

template <class Est, class Scene>
testing::RunningStats run_probe(const Est& estimator, const Scene& scene, std::uint32_t pixel,
                                std::uint64_t samples, std::uint64_t seed, std::uint64_t& bad) {
  testing::RunningStats stats;
  for (std::uint64_t i = 0; i < samples; ++i) {
    Pcg32 rng = Pcg32::for_sample(seed, pixel, i);
    SummingSink<typename Scene::Spectrum> sink{pixel};
    estimator.estimate(scene, EstimateQuery{pixel, i}, rng, sink);
    bad += sink.drops + sink.foreign;
    stats.add(static_cast<double>(sink.value));
  }
  return stats;
}

}  // namespace

TEMPLATE_TEST_CASE("multi-technique estimator: concepts and construction", "[estimators]", float,
                   double) {
  using T = TestType;
  static_assert(LightSampledScene<Scn<T>>);
  static_assert(PathTechnique<Seq<T>, Scn<T>>);
  static_assert(PathTechnique<Nee<T>, Scn<T>>);
  static_assert(!PathTechnique<NextSegmentSampler<Scn<T>, DiracKernel<T>>, Scn<T>>);
  static_assert(Estimator<Estimator2<T>, Scn<T>>);
  const DiracKernel<T> k;
  CHECK_THROWS_AS(Estimator2<T>(k, 0, {1, 1}, MisHeuristic::balance, Seq<T>(k), Nee<T>(k)),
                  std::invalid_argument);
  CHECK_THROWS_AS(Estimator2<T>(k, 5, {1, 1}, MisHeuristic::balance, Seq<T>(k), Nee<T>(k)),
                  std::invalid_argument);
  CHECK_THROWS_AS(Estimator2<T>(k, 2, {0, 0}, MisHeuristic::balance, Seq<T>(k), Nee<T>(k)),
                  std::invalid_argument);
  const auto e = make_multi_technique_estimator<Scn<T>>(k, 3, {2, 1}, MisHeuristic::power,
                                                        Seq<T>(k), Nee<T>(k));
  CHECK(e.length() == 3);
  CHECK(e.counts()[0] == 2);
}

TEMPLATE_TEST_CASE("path techniques: pdf of a drawn path equals its density", "[estimators]", float,
                   double) {
  using T = TestType;
  const auto scene = make_scene<T>();
  const DiracKernel<T> k;
  const Seq<T> seq(k);
  const Nee<T> nee(k);
  const T tolerance = std::is_same_v<T, float> ? T(2e-3) : T(1e-9);
  Pcg32 rng(11, 3);
  for (int i = 0; i < 300; ++i) {
    const PathQuery q{static_cast<std::uint32_t>(i % 3), static_cast<std::size_t>(1 + i % 4)};
    const auto a = seq.sample(scene, q, rng);
    REQUIRE(a);
    CHECK(a->path.size() == q.length);
    CHECK(seq.pdf(scene, q, a->path) == Approx(a->pdf).epsilon(tolerance));
    CHECK(seq.pdf(scene, {(q.pixel + 1) % 3, q.length}, a->path) == T(0));
    CHECK(seq.pdf(scene, {q.pixel, q.length + 1}, a->path) == T(0));
    if (q.length < 2) {
      CHECK_FALSE(nee.sample(scene, q, rng));
      CHECK(nee.pdf(scene, q, a->path) == T(0));
      continue;
    }
    const auto b = nee.sample(scene, q, rng);
    REQUIRE(b);
    CHECK(nee.pdf(scene, q, b->path) == Approx(b->pdf).epsilon(tolerance));
    // Both techniques can produce each other's paths (Lambertian sphere, area light everywhere).
    CHECK(nee.pdf(scene, q, a->path) > T(0));
    CHECK(seq.pdf(scene, q, b->path) > T(0));
  }
}

TEST_CASE("multi-technique weights sum to one on random paths (N37)", "[estimators]") {
  using T = double;
  const auto scene = make_scene<T>();
  const DiracKernel<T> k;
  Pcg32 rng(5, 9);
  SensorStartSampler<Scn<T>> first;
  for (const MisHeuristic h : {MisHeuristic::balance, MisHeuristic::power}) {
    for (std::size_t length = 2; length <= max_length; ++length) {
      const Estimator2<T> e(k, length, {1, 3}, h, Seq<T>(k), Nee<T>(k));
      for (int trial = 0; trial < 200; ++trial) {
        // A random connected path: the probe's segment, then uniformly drawn sphere points.
        const std::uint32_t pixel = static_cast<std::uint32_t>(trial % 3);
        SegmentPath<T, max_length> path;
        path.push_back(first.sample(scene, {pixel}, rng)->segment);
        while (path.size() < length) {
          const auto y = scene.sample_area(AreaSampleQuery<T>{uniform2<T>(rng)});
          path.push_back(Segment<T>{path.back().y, y->point});
        }
        const auto n_p = e.densities(scene, pixel, path);
        REQUIRE(n_p[0] > 0);
        REQUIRE(n_p[1] > 0);
        const auto w = e.weights(scene, pixel, path);
        CHECK(w[0] + w[1] == Approx(1.0).epsilon(1e-6));
        const double a = h == MisHeuristic::balance ? n_p[0] : n_p[0] * n_p[0];
        const double b = h == MisHeuristic::balance ? n_p[1] : n_p[1] * n_p[1];
        CHECK(w[0] == Approx(a / (a + b)).epsilon(1e-12));
        // Seen from another probe no technique can draw the path: all weights vanish.
        const auto none = e.weights(scene, (pixel + 1) % 3, path);
        CHECK(none[0] == 0);
        CHECK(none[1] == 0);
      }
    }
  }
}

namespace {
constexpr std::uint32_t probe_count = 3;
constexpr std::uint64_t samples_per_test = 20000;
// t-tests in this file: 2 types x 3 lengths x 3 probes x 2 heuristics, plus 2 types x 2 lengths
// for the wrong variant; family alpha 0.01.
const double per_test_alpha = testing::sidak_alpha(0.01, 2 * 3 * probe_count * 2 + 2 * 2);
}  // namespace

TEMPLATE_TEST_CASE("multi-technique MIS is unbiased per path length inside the sphere",
                   "[estimators][stat]", float, double) {
  using T = TestType;
  const auto scene = make_scene<T>();
  const DiracKernel<T> k;
  for (const MisHeuristic h : {MisHeuristic::balance, MisHeuristic::power}) {
    for (std::size_t length = 2; length <= max_length; ++length) {
      const Estimator2<T> e(k, length, {1, 2}, h, Seq<T>(k), Nee<T>(k));
      for (std::uint32_t pixel = 0; pixel < probe_count; ++pixel) {
        const double expected =
            scene.bounce_radiance_at(scene.probe_target(pixel), static_cast<unsigned>(length - 1));
        std::uint64_t bad = 0;
        const auto stats = run_probe(e, scene, pixel, samples_per_test, 300 + length, bad);
        const auto t = testing::student_t_test(stats, expected);
        INFO("heuristic " << int(h) << " k " << length << " probe " << pixel << ": mean "
                          << stats.mean() << " +- " << stats.standard_error() << ", expected "
                          << expected << ", p = " << t.p_value);
        CHECK(bad == 0);
        CHECK_FALSE(t.rejects(per_test_alpha));
      }
    }
  }
}

TEMPLATE_TEST_CASE("the same t-test rejects a denominator missing one technique",
                   "[estimators][stat]", float, double) {
  using T = TestType;
  const auto scene = make_scene<T>();
  const DiracKernel<T> k;
  for (std::size_t length = 2; length <= 3; ++length) {
    const MultiTechniqueEstimator<Scn<T>, DiracKernel<T>, Seq<T>, HiddenPdf<Nee<T>>> wrong(
        k, length, {1, 2}, MisHeuristic::balance, Seq<T>(k), HiddenPdf<Nee<T>>(k));
    std::uint64_t bad = 0;
    const auto stats = run_probe(wrong, scene, 0, samples_per_test, 900 + length, bad);
    const auto t = testing::student_t_test(
        stats, scene.bounce_radiance_at(scene.probe_target(0), static_cast<unsigned>(length - 1)));
    INFO("k " << length << ": mean " << stats.mean() << " +- " << stats.standard_error()
              << ", p = " << t.p_value);
    CHECK(t.rejects(per_test_alpha));
  }
}
