// Samples per second of the reference emitters' sample_emission / sample_towards and of the
// pinhole camera's sample_ray (the cornell-box lights and camera).
//   build/bench/bench_lights_lights_bench
#include <benchmark/benchmark.h>

#include <cstdint>
#include <segpath/core/rng.hpp>
#include <segpath/lights/background_light.hpp>
#include <segpath/lights/directional_light.hpp>
#include <segpath/lights/light_set.hpp>
#include <segpath/lights/point_light.hpp>
#include <segpath/lights/triangle_light.hpp>
#include <segpath/sensors/pinhole_camera.hpp>
#include <vector>

namespace {

using namespace segpath;
using T = float;
using S = Rgb<T>;

const Vec3<T> box_centre(T(0.00973), T(0.02453), T(0));
constexpr T box_radius = T(2.3);

TriangleLights<S> cornell_area_light() {
  const T z = T(1.26002);
  std::vector<EmissiveTriangle<T>> t{{Vec3<T>(T(-0.25), T(0.25), z), Vec3<T>(T(0.25), T(-0.25), z),
                                      Vec3<T>(T(-0.25), T(-0.25), z), 0},
                                     {Vec3<T>(T(0.25), T(-0.25), z), Vec3<T>(T(-0.25), T(0.25), z),
                                      Vec3<T>(T(0.25), T(0.25), z), 1}};
  return TriangleLights<S>(t, S(T(25.03329849)));
}

/// A mesh light of many triangles: selection is a binary search over their areas.
TriangleLights<S> many_triangles(std::uint32_t n) {
  std::vector<EmissiveTriangle<T>> t;
  for (std::uint32_t i = 0; i < n; ++i) {
    const T x = T(i % 64) * T(0.1), y = T(i / 64) * T(0.1);
    t.push_back({Vec3<T>(x, y, 1), Vec3<T>(x + T(0.1), y, 1),
                 Vec3<T>(x, y + T(0.05) + T(i % 7) * T(0.01), 1), i});
  }
  return TriangleLights<S>(t, S(T(1)));
}

template <class E>
void sample_emission(benchmark::State& state, const E& emitter) {
  Pcg32 rng(1, 0);
  for (auto _ : state) {
    const auto s = emitter.sample_emission(
        EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(state.iterations());
}

template <class E>
void sample_towards(benchmark::State& state, const E& emitter) {
  Pcg32 rng(2, 0);
  const auto receiver =
      SurfacePoint<T>::on_surface(Vec3<T>(T(0.1), T(0.2), T(-1.28002)), Vec3<T>(0, 0, 1));
  for (auto _ : state) {
    const auto s = emitter.sample_towards(
        EmitterTowardsQuery<T>{receiver, rng.uniform2<T>(), rng.uniform<T>()});
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(state.iterations());
}

const TriangleLights<S> area = cornell_area_light();
const TriangleLights<S> mesh = many_triangles(4096);
const DirectionalLight<S> sun(Vec3<T>(-1, T(1.5), -1), S(10, 4, 0), box_centre, box_radius);
const BackgroundLight<S> sky(S(T(135) / 255, T(206) / 255, T(250) / 255), box_centre, box_radius);
const PointLight<S> bulb(Vec3<T>(0, T(-0.5), 1), S(T(70) / (4 * pi<T>)));
const LightSet<TriangleLights<S>, DirectionalLight<S>, BackgroundLight<S>, PointLight<S>> all(area,
                                                                                              sun,
                                                                                              sky,
                                                                                              bulb);

void BM_TriangleLights_cornell_emission(benchmark::State& s) { sample_emission(s, area); }
void BM_TriangleLights_cornell_towards(benchmark::State& s) { sample_towards(s, area); }
void BM_TriangleLights_4096_emission(benchmark::State& s) { sample_emission(s, mesh); }
void BM_TriangleLights_4096_towards(benchmark::State& s) { sample_towards(s, mesh); }
void BM_DirectionalLight_emission(benchmark::State& s) { sample_emission(s, sun); }
void BM_DirectionalLight_towards(benchmark::State& s) { sample_towards(s, sun); }
void BM_BackgroundLight_emission(benchmark::State& s) { sample_emission(s, sky); }
void BM_BackgroundLight_towards(benchmark::State& s) { sample_towards(s, sky); }
void BM_LightSet4_emission(benchmark::State& s) { sample_emission(s, all); }
void BM_LightSet4_towards(benchmark::State& s) { sample_towards(s, all); }

void BM_PinholeCamera_sample_ray(benchmark::State& state) {
  const auto camera = cornell_camera<T>(512, 512);
  Pcg32 rng(3, 0);
  std::uint32_t pixel = 0;
  for (auto _ : state) {
    const auto s =
        camera.sample_ray(SensorSampleQuery<T>{pixel, rng.uniform2<T>(), rng.uniform2<T>()});
    benchmark::DoNotOptimize(s);
    pixel = pixel + 1 == camera.pixel_count() ? 0 : pixel + 1;
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_PinholeCamera_importance(benchmark::State& state) {
  const auto camera = cornell_camera<T>(512, 512);
  const auto origin = camera.point();
  Pcg32 rng(4, 0);
  for (auto _ : state) {
    const Vec2<T> u = rng.uniform2<T>();
    const Vec3<T> d = glm::normalize(camera.forward() + (u.x - T(0.5)) * camera.right() +
                                     (u.y - T(0.5)) * camera.up());
    const auto r = camera.importance(SensorQuery<T>{origin, d});
    benchmark::DoNotOptimize(r);
  }
  state.SetItemsProcessed(state.iterations());
}

}  // namespace

BENCHMARK(BM_TriangleLights_cornell_emission);
BENCHMARK(BM_TriangleLights_cornell_towards);
BENCHMARK(BM_TriangleLights_4096_emission);
BENCHMARK(BM_TriangleLights_4096_towards);
BENCHMARK(BM_DirectionalLight_emission);
BENCHMARK(BM_DirectionalLight_towards);
BENCHMARK(BM_BackgroundLight_emission);
BENCHMARK(BM_BackgroundLight_towards);
BENCHMARK(BM_LightSet4_emission);
BENCHMARK(BM_LightSet4_towards);
BENCHMARK(BM_PinholeCamera_sample_ray);
BENCHMARK(BM_PinholeCamera_importance);
BENCHMARK_MAIN();
