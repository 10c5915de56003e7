// The generic sequential estimator (segment path tracing, Dirac kernel) on the sphere
// interior next to a hand-written loop that computes the same estimate from the same
// random numbers. Targets: generic / hand-written <= 1.05 (issue 2), <= 1.10 (issue 14);
// measured figures in docs/figures.md.
//   build/bench/bench_estimators_sequential_bench --benchmark_repetitions=5
#include <segpath/estimators/sequential.hpp>
#include <segpath/kernels/dirac.hpp>
#include <segpath/testing/sphere_interior.hpp>

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace {

using namespace segpath;
constexpr std::size_t max_length = 8;
constexpr std::uint32_t probe_count = 16;
constexpr std::uint64_t samples_per_iteration = 1 << 14;

template <class T>
testing::SphereInterior<T> make_scene() {
  testing::SphereInteriorParameters<T> p;
  p.radius = T(1.5);
  p.emission_mean = T(1);
  p.emission_gradient = {T(0.3), T(-0.2), T(0.6)};
  p.albedo_mean = T(0.6);
  p.albedo_gradient = {T(-0.15), T(0.2), T(0.1)};
  std::vector<Vec3<T>> probes;
  for (std::uint32_t i = 0; i < probe_count; ++i) {
    const T z = T(1) - T(2) * (T(i) + T(0.5)) / T(probe_count);
    const T phi = T(2.39996) * T(i);
    const T r = std::sqrt(T(1) - z * z);
    probes.push_back({r * std::cos(phi), r * std::sin(phi), z});
  }
  return testing::SphereInterior<T>(p, probes);
}

template <class T>
struct SumSink {
  T sum = 0;
  void add(std::uint32_t, const T& v) noexcept { sum += v; }
  void drop(DropReason) noexcept {}
};

/// What a renderer author would write by hand for this scene: the probe ray, the far root
/// of the sphere, cosine sampling about the inward normal with throughput *= albedo (the
/// f cos / p of a Lambertian), emission at every hit. It draws the same uniforms in the same
/// order as the generic samplers, so both compute the same estimate.
template <class T>
T hand_written(const testing::SphereInterior<T>& scene, std::uint32_t pixel, Pcg32& rng) noexcept {
  const auto& p = scene.parameters();
  const Ray<T>& probe = scene.sensor().probe(pixel);
  rng.uniform2<T>();  // sensor position (unused by a probe)
  rng.uniform2<T>();  // sensor direction (unused by a probe)
  Vec3<T> origin = probe.origin, dir = probe.direction;
  T total = 0, beta = 1;
  for (std::size_t length = 1;; ++length) {
    const Vec3<T> oc = origin - p.center;
    const T b = glm::dot(dir, oc);
    const T t = -b + std::sqrt(b * b - (glm::dot(oc, oc) - p.radius * p.radius));
    const Vec3<T> u = glm::normalize(oc + dir * t);  // outward unit vector at the hit
    const Vec3<T> hit = p.center + u * p.radius;
    total += beta * (p.emission_mean + glm::dot(p.emission_gradient, u));
    if (length == max_length) break;
    rng.uniform2<T>();  // kernel (unused: Dirac)
    const Vec2<T> ub = rng.uniform2<T>();
    rng.uniform<T>();  // lobe
    // Cosine direction about n = -u: concentric disk, lifted, in the Duff et al. frame.
    const T a = T(2) * ub.x - T(1), c = T(2) * ub.y - T(1);
    T dx = 0, dy = 0;
    if (a != T(0) || c != T(0)) {
      T r, phi;
      if (std::abs(a) > std::abs(c)) { r = a; phi = (pi<T> / T(4)) * (c / a); }
      else { r = c; phi = pi<T> / T(2) - (pi<T> / T(4)) * (a / c); }
      dx = r * std::cos(phi);
      dy = r * std::sin(phi);
    }
    const T dz = std::sqrt(std::max(T(0), T(1) - dx * dx - dy * dy));
    const Vec3<T> n = -u;
    const T sign = std::copysign(T(1), n.z);
    const T fa = T(-1) / (sign + n.z);
    const T fb = n.x * n.y * fa;
    const Vec3<T> tangent(T(1) + sign * n.x * n.x * fa, sign * fb, -sign * n.x);
    const Vec3<T> bitangent(fb, sign + n.y * n.y * fa, -n.y);
    if (!(dz > T(0))) break;
    beta *= p.albedo_mean + glm::dot(p.albedo_gradient, u);
    origin = hit;
    dir = tangent * dx + bitangent * dy + n * dz;
  }
  return total;
}

template <class T>
void BM_generic_sequential(benchmark::State& state) {
  const auto scene = make_scene<T>();
  using Scn = testing::SphereInterior<T>;
  const SequentialEstimator<Scn, DiracKernel<T>> estimator(DiracKernel<T>{}, {1, max_length});
  std::uint64_t base = 0;
  for (auto _ : state) {
    SumSink<T> sink;
    for (std::uint64_t i = 0; i < samples_per_iteration; ++i) {
      const auto pixel = static_cast<std::uint32_t>(i % probe_count);
      Pcg32 rng = Pcg32::for_sample(1, pixel, base + i);
      estimator.estimate(scene, EstimateQuery{pixel, base + i}, rng, sink);
    }
    benchmark::DoNotOptimize(sink.sum);
    base += samples_per_iteration;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * samples_per_iteration));
}

template <class T>
void BM_hand_written_sequential(benchmark::State& state) {
  const auto scene = make_scene<T>();
  std::uint64_t base = 0;
  for (auto _ : state) {
    T sum = 0;
    for (std::uint64_t i = 0; i < samples_per_iteration; ++i) {
      const auto pixel = static_cast<std::uint32_t>(i % probe_count);
      Pcg32 rng = Pcg32::for_sample(1, pixel, base + i);
      sum += hand_written(scene, pixel, rng);
    }
    benchmark::DoNotOptimize(sum);
    base += samples_per_iteration;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * samples_per_iteration));
}

/// Both loops must compute the same estimates, or the comparison means nothing.
template <class T>
bool same_estimates() {
  const auto scene = make_scene<T>();
  using Scn = testing::SphereInterior<T>;
  const SequentialEstimator<Scn, DiracKernel<T>> estimator(DiracKernel<T>{}, {1, max_length});
  for (std::uint64_t i = 0; i < 4096; ++i) {
    const auto pixel = static_cast<std::uint32_t>(i % probe_count);
    Pcg32 a = Pcg32::for_sample(3, pixel, i), b = a;
    SumSink<T> sink;
    estimator.estimate(scene, EstimateQuery{pixel, i}, a, sink);
    const T h = hand_written(scene, pixel, b);
    if (std::abs(sink.sum - h) > T(1e-3) * std::abs(h)) {
      std::fprintf(stderr, "mismatch at sample %llu: generic %g, hand-written %g\n",
                   static_cast<unsigned long long>(i), double(sink.sum), double(h));
      return false;
    }
  }
  return true;
}

}  // namespace

BENCHMARK_TEMPLATE(BM_generic_sequential, float);
BENCHMARK_TEMPLATE(BM_hand_written_sequential, float);
BENCHMARK_TEMPLATE(BM_generic_sequential, double);
BENCHMARK_TEMPLATE(BM_hand_written_sequential, double);

int main(int argc, char** argv) {
  if (!same_estimates<float>() || !same_estimates<double>()) return EXIT_FAILURE;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return EXIT_FAILURE;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return EXIT_SUCCESS;
}
