// Path tracing (segpath::PathTracer, NEE + MIS, at most 10 segments) on Cornell box 1 at
// 512 x 512 through the Embree adapter: one path per pixel per benchmark iteration, 2 threads
// (rows interleaved); reports PT iterations/s and rays/s (intersect + visible calls).
// Target (issue): >= 1.5x SmallVCM's PT on this kind of machine, 4.4 it/s -> 6.6 it/s.
// Arguments: threads, and the path length from which Russian roulette runs (0: never, the
// PathTracer default; SmallVCM's PT uses roulette, so it casts fewer rays per iteration).
// With 1 thread, rates are per CPU second of that thread (robust to other load on the
// machine); with 2 threads, per wall-clock second.
//   build/bench/renderer/bench_renderer_cornell_pt_bench
#include <benchmark/benchmark.h>

#include <cstdint>
#include <vector>

#include "pt_harness.hpp"

namespace {

/// `ByView` false: the path tracer copies the scene's emitter (its triangle tables) per path,
/// as it does for RenderScene itself.
template <bool ByView>
void pt_cornell(benchmark::State& state) {
  const auto threads = static_cast<std::uint32_t>(state.range(0));
  const auto roulette_from = static_cast<std::size_t>(state.range(1));
  const renderer::RenderScene scene = renderer::make_cornell(1, 512, 512);
  using Scene = bench::ObservedScene<bench::RayCounter, ByView>;
  const segpath::PathTracer<Scene> pt(
      segpath::PathTracerOptions{renderer::cornell_max_length, segpath::MisHeuristic::power, roulette_from});
  std::vector<bench::Color> image(scene.sensor().pixel_count(), bench::Color(0));
  std::vector<bench::RayCounter> counters(threads);
  std::uint64_t iteration = 0, drops = 0;
  for (auto _ : state) drops += bench::pt_iteration(scene, pt, iteration++, counters, image);
  std::uint64_t rays = 0;
  for (const auto& c : counters) rays += c.rays;
  double sum = 0;
  for (const auto& c : image) sum += double(segpath::average(c));
  state.counters["it/s"] = benchmark::Counter(double(iteration), benchmark::Counter::kIsRate);
  state.counters["rays/s"] = benchmark::Counter(double(rays), benchmark::Counter::kIsRate);
  state.counters["rays/it"] = double(rays) / double(iteration);
  state.counters["mean"] = sum / double(image.size()) / double(iteration);
  state.counters["drops"] = double(drops);
}

}  // namespace

BENCHMARK_TEMPLATE(pt_cornell, true)->Args({2, 0})->Args({2, 2})->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(5.0);
BENCHMARK_TEMPLATE(pt_cornell, true)->Args({1, 0})->Args({1, 2})->Unit(benchmark::kMillisecond)->MinTime(5.0);
BENCHMARK_TEMPLATE(pt_cornell, false)->Args({1, 0})->Unit(benchmark::kMillisecond)->MinTime(5.0);

BENCHMARK_MAIN();
