// Samples per second of every segment sampler of SPEC 1.6 on the sphere interior (kernel
// samplers with a disk kernel on the periodic slab, where the disk kernel is exact).
//   build/bench/bench_samplers_samplers_bench
#include <segpath/kernels/dirac.hpp>
#include <segpath/kernels/disk.hpp>
#include <segpath/samplers/approximate.hpp>
#include <segpath/samplers/bridge.hpp>
#include <segpath/samplers/bsdf_directed.hpp>
#include <segpath/samplers/light_next.hpp>
#include <segpath/samplers/light_start.hpp>
#include <segpath/samplers/next_segment.hpp>
#include <segpath/samplers/raytraced.hpp>
#include <segpath/samplers/sensor_start.hpp>
#include <segpath/samplers/uniform.hpp>
#include <segpath/testing/periodic_slab.hpp>
#include <segpath/testing/sphere_interior.hpp>

#include <benchmark/benchmark.h>

#include <vector>

namespace {

using namespace segpath;
constexpr int batch = 1 << 12;

template <class T>
testing::SphereInterior<T> make_sphere() {
  testing::SphereInteriorParameters<T> p;
  p.radius = T(1.5);
  p.emission_gradient = {T(0.3), T(-0.2), T(0.6)};
  p.albedo_mean = T(0.6);
  p.albedo_gradient = {T(-0.15), T(0.2), T(0.1)};
  return testing::SphereInterior<T>(p, {{0, 0, 1}});
}

template <class T>
testing::PeriodicSlab<T> make_slab() {
  testing::PeriodicSlabParameters<T> p;
  p.period = 4;
  return testing::PeriodicSlab<T>(p, {testing::SlabProbe<T>{}});
}

/// Draws `batch` samples per iteration and reports items (samples drawn, accepted or not).
template <class Smp, class Scn>
void run(benchmark::State& state, const Smp& smp, const Scn& scene, const typename Smp::Technique& t) {
  Pcg32 rng(1, 2);
  using T = typename Scn::Scalar;
  for (auto _ : state) {
    T sum = 0;
    for (int i = 0; i < batch; ++i) {
      const auto s = smp.sample(scene, t, rng);
      if (s) sum += s->pdf;
    }
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * batch);
}

template <class T>
Segment<T> sphere_segment(const testing::SphereInterior<T>& scene) {
  return Segment<T>{scene.point_at(glm::normalize(Vec3<T>(T(0.2), T(0.3), T(-0.9)))),
                    scene.point_at(glm::normalize(Vec3<T>(T(-0.5), T(0.1), T(0.8))))};
}

template <class T>
void BM_uniform(benchmark::State& state) {
  const auto scene = make_sphere<T>();
  run(state, UniformSegmentSampler<testing::SphereInterior<T>>{}, scene, {});
}
template <class T>
void BM_raytraced(benchmark::State& state) {
  const auto scene = make_sphere<T>();
  run(state, RaytracedSegmentSampler<testing::SphereInterior<T>>{}, scene, {});
}
template <class T>
void BM_bsdf_directed(benchmark::State& state) {
  const auto scene = make_sphere<T>();
  run(state, BsdfDirectedSegmentSampler<testing::SphereInterior<T>>{}, scene, {Vec3<T>(0, 0, 1)});
}
template <class T>
void BM_light_start(benchmark::State& state) {
  const auto scene = make_sphere<T>();
  run(state, LightStartSampler<testing::SphereInterior<T>>{}, scene, {});
}
template <class T>
void BM_sensor_start(benchmark::State& state) {
  const auto scene = make_sphere<T>();
  run(state, SensorStartSampler<testing::SphereInterior<T>>{}, scene, {0});
}
template <class T>
void BM_next_segment_dirac(benchmark::State& state) {
  const auto scene = make_sphere<T>();
  const Segment<T> previous = sphere_segment(scene);
  run(state, NextSegmentSampler<testing::SphereInterior<T>, DiracKernel<T>>{DiracKernel<T>{}}, scene, {previous});
}
template <class T>
void BM_next_segment_disk(benchmark::State& state) {
  const auto scene = make_slab<T>();
  const Segment<T> previous{scene.point_on(testing::SlabSide::a, T(1), T(0.2)),
                            scene.point_on(testing::SlabSide::b, T(0.3), T(-0.4))};
  run(state, NextSegmentSampler<testing::PeriodicSlab<T>, DiskKernel<T>>{DiskKernel<T>(T(0.3))}, scene, {previous});
}
template <class T>
void BM_light_next_dirac(benchmark::State& state) {
  const auto scene = make_sphere<T>();
  const Segment<T> next = sphere_segment(scene);
  run(state, LightNextSegmentSampler<testing::SphereInterior<T>, DiracKernel<T>>{DiracKernel<T>{}}, scene, {next});
}
template <class T>
void BM_light_next_disk(benchmark::State& state) {
  const auto scene = make_slab<T>();
  const Segment<T> next{scene.point_on(testing::SlabSide::b, T(0.3), T(-0.4)),
                        scene.point_on(testing::SlabSide::a, T(1), T(0.2))};
  run(state, LightNextSegmentSampler<testing::PeriodicSlab<T>, DiskKernel<T>>{DiskKernel<T>(T(0.3))}, scene, {next});
}
template <class T>
void BM_approximate_next(benchmark::State& state) {
  const auto scene = make_sphere<T>();
  const Segment<T> s = sphere_segment(scene);
  run(state, ApproximateNextSegmentSampler<testing::SphereInterior<T>, DiskKernel<T>>{DiskKernel<T>(T(0.2))}, scene,
      {s});
}
template <class T>
void BM_approximate_light_next(benchmark::State& state) {
  const auto scene = make_sphere<T>();
  const Segment<T> s = sphere_segment(scene);
  run(state, ApproximateLightNextSegmentSampler<testing::SphereInterior<T>, DiskKernel<T>>{DiskKernel<T>(T(0.2))},
      scene, {s});
}
template <class T>
void BM_kernel_bridge_disk(benchmark::State& state) {
  const auto scene = make_slab<T>();
  const Segment<T> camera{scene.point_on(testing::SlabSide::b, T(0.7), T(0.1)),
                          scene.point_on(testing::SlabSide::a, T(0.2), T(0.3))};
  const Segment<T> light{scene.point_on(testing::SlabSide::b, T(-0.4), T(0.6)),
                         scene.point_on(testing::SlabSide::a, T(1.5), T(-0.5))};
  run(state, KernelBridgeSampler<testing::PeriodicSlab<T>, DiskKernel<T>>{DiskKernel<T>(T(0.3))}, scene,
      {camera, light});
}
template <class T>
void BM_light_bridge_dirac(benchmark::State& state) {
  const auto scene = make_sphere<T>();
  const Segment<T> camera = sphere_segment(scene);
  run(state, LightBridgeSampler<testing::SphereInterior<T>, DiracKernel<T>>{DiracKernel<T>{}}, scene, {camera});
}

}  // namespace

BENCHMARK_TEMPLATE(BM_sensor_start, float);
BENCHMARK_TEMPLATE(BM_sensor_start, double);
BENCHMARK_TEMPLATE(BM_next_segment_dirac, float);
BENCHMARK_TEMPLATE(BM_next_segment_dirac, double);
BENCHMARK_TEMPLATE(BM_next_segment_disk, float);
BENCHMARK_TEMPLATE(BM_next_segment_disk, double);
BENCHMARK_TEMPLATE(BM_uniform, float);
BENCHMARK_TEMPLATE(BM_uniform, double);
BENCHMARK_TEMPLATE(BM_raytraced, float);
BENCHMARK_TEMPLATE(BM_raytraced, double);
BENCHMARK_TEMPLATE(BM_bsdf_directed, float);
BENCHMARK_TEMPLATE(BM_bsdf_directed, double);
BENCHMARK_TEMPLATE(BM_light_start, float);
BENCHMARK_TEMPLATE(BM_light_start, double);
BENCHMARK_TEMPLATE(BM_light_next_dirac, float);
BENCHMARK_TEMPLATE(BM_light_next_dirac, double);
BENCHMARK_TEMPLATE(BM_light_next_disk, float);
BENCHMARK_TEMPLATE(BM_light_next_disk, double);
BENCHMARK_TEMPLATE(BM_approximate_next, float);
BENCHMARK_TEMPLATE(BM_approximate_next, double);
BENCHMARK_TEMPLATE(BM_approximate_light_next, float);
BENCHMARK_TEMPLATE(BM_approximate_light_next, double);
BENCHMARK_TEMPLATE(BM_kernel_bridge_disk, float);
BENCHMARK_TEMPLATE(BM_kernel_bridge_disk, double);
BENCHMARK_TEMPLATE(BM_light_bridge_dirac, float);
BENCHMARK_TEMPLATE(BM_light_bridge_dirac, double);

BENCHMARK_MAIN();
