// Samples per second of each reference BSDF's sample() (the Cornell-box materials), in float
// and double, over a spread of fixed directions.
//   build/bench/bench_materials_bsdf_bench
#include <benchmark/benchmark.h>

#include <array>
#include <segpath/core/rng.hpp>
#include <segpath/core/warp.hpp>
#include <segpath/materials/material_set.hpp>

namespace {

using namespace segpath;

template <class T>
std::array<Vec3<T>, 64> fixed_directions() {
  std::array<Vec3<T>, 64> out{};
  Pcg32 rng(1, 1);
  for (auto& d : out) {
    Vec3<T> v = square_to_uniform_sphere(rng.uniform2<T>());
    d = Vec3<T>(v.x, v.y, std::abs(v.z) + T(0.01));
    d = glm::normalize(d);
  }
  return out;
}

template <class T, class B>
void sample_loop(benchmark::State& state, const B& bsdf) {
  const auto point = SurfacePoint<T>::on_surface(Vec3<T>(0), Vec3<T>(0, 0, 1));
  const auto fixed = fixed_directions<T>();
  Pcg32 rng(7, 3);
  std::size_t i = 0;
  for (auto _ : state) {
    const auto s = bsdf.sample(
        BsdfSampleQuery<T>{point, fixed[i++ & 63], rng.uniform2<T>(), rng.uniform<T>()});
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}

template <class T>
void lambertian(benchmark::State& s) {
  sample_loop<T>(s, Lambertian<Rgb<T>>{Rgb<T>(T(0.8))});
}
template <class T>
void phong(benchmark::State& s) {
  sample_loop<T>(s, Phong<Rgb<T>>(Rgb<T>(T(0.7)), T(90)));
}
template <class T>
void glossy(benchmark::State& s) {
  sample_loop<T>(s, Glossy<Rgb<T>>(Rgb<T>(T(0.1)), Rgb<T>(T(0.7)), T(90)));
}
template <class T>
void mirror(benchmark::State& s) {
  sample_loop<T>(s, Mirror<Rgb<T>>());
}
template <class T>
void dielectric(benchmark::State& s) {
  sample_loop<T>(s, Dielectric<Rgb<T>>(T(1.6)));
}
/// The floor through MaterialSet's variant dispatch, to show what the dispatch costs.
template <class T>
void material_set_glossy(benchmark::State& state) {
  MaterialSet<Rgb<T>> set;
  set.add(Lambertian<Rgb<T>>{Rgb<T>(T(0.8))});
  const auto id = set.add(Glossy<Rgb<T>>(Rgb<T>(T(0.1)), Rgb<T>(T(0.7)), T(90)));
  auto point = SurfacePoint<T>::on_surface(Vec3<T>(0), Vec3<T>(0, 0, 1));
  point.material_id = id;
  const auto fixed = fixed_directions<T>();
  Pcg32 rng(7, 3);
  std::size_t i = 0;
  for (auto _ : state) {
    const auto s =
        set.sample(BsdfSampleQuery<T>{point, fixed[i++ & 63], rng.uniform2<T>(), rng.uniform<T>()});
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}

BENCHMARK_TEMPLATE(lambertian, float);
BENCHMARK_TEMPLATE(lambertian, double);
BENCHMARK_TEMPLATE(phong, float);
BENCHMARK_TEMPLATE(phong, double);
BENCHMARK_TEMPLATE(glossy, float);
BENCHMARK_TEMPLATE(glossy, double);
BENCHMARK_TEMPLATE(mirror, float);
BENCHMARK_TEMPLATE(mirror, double);
BENCHMARK_TEMPLATE(dielectric, float);
BENCHMARK_TEMPLATE(dielectric, double);
BENCHMARK_TEMPLATE(material_set_glossy, float);
BENCHMARK_TEMPLATE(material_set_glossy, double);

}  // namespace

BENCHMARK_MAIN();
