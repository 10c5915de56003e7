// The hash grid of VCM's merging (kernels/hash_grid.hpp): build and query cost for photon-like
// items on the walls of a unit box, with the merging state stored in the grid (what VCM does)
// against indices into a separate array of 92-byte light ends (the layout before session 17).
//   build/bench/bench_kernels_hash_grid_bench [--benchmark_filter=query]
#include <segpath/core/rng.hpp>
#include <segpath/kernels/hash_grid.hpp>
#include <segpath/testing/two_threads.hpp>

#include <benchmark/benchmark.h>

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

namespace {

using namespace segpath;
using T = float;

/// The size of VCM's 52-byte merging state (VcmPhoton<Rgb<float>>).
struct Payload {
  std::array<T, 11> state{};
  std::uint32_t length = 0;
};
/// The size of a VcmVertex<Rgb<float>> (92 bytes), whose position the index layout reads too.
struct LightEnd {
  Vec3<T> position{};
  std::array<T, 17> rest{};
  std::uint32_t length = 0;
};

/// n points on the six walls of the unit box, in random order (light ends of random paths).
std::vector<LightEnd> light_ends(std::size_t n, std::uint64_t stream = 1) {
  Pcg32 rng(5, stream);
  std::vector<LightEnd> ends(n);
  for (auto& e : ends) {
    const auto wall = std::uint32_t(rng.uniform<T>() * 6) % 6;
    Vec3<T> p(rng.uniform<T>(), rng.uniform<T>(), rng.uniform<T>());
    p[wall % 3] = T(wall / 3);
    e.position = p;
    e.length = 1 + std::uint32_t(rng.uniform<T>() * 4);
  }
  return ends;
}

/// A radius giving about `per_query` items per query on the box's area of 6.
T radius_for(std::size_t n, T per_query) { return std::sqrt(per_query * T(6) / (T(3.14159265) * T(n))); }

void build_payload(benchmark::State& state) {
  const auto ends = light_ends(std::size_t(state.range(0)));
  HashGrid<T, Payload> grid;
  const T r = radius_for(ends.size(), 20);
  const auto position_of = [&](std::size_t i) { return std::optional(ends[i].position); };
  const auto item_of = [&](std::size_t i) { return Payload{{}, ends[i].length}; };
  for (auto _ : state) {
    if (state.range(1) == 2) grid.build(ends.size(), r, position_of, item_of, testing::TwoThreadFor{});
    else grid.build(ends.size(), r, position_of, item_of);
    benchmark::DoNotOptimize(grid.size());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(build_payload)->ArgsProduct({{100000, 1000000}, {1, 2}})->ArgNames({"items", "threads"})->Unit(benchmark::kMillisecond);

/// Queries at random points of the walls; the items found are summed through their state.
template <bool InGrid>
void query(benchmark::State& state) {
  const auto ends = light_ends(std::size_t(state.range(0)));
  const T r = radius_for(ends.size(), 20);
  HashGrid<T, Payload> payload_grid;
  HashGrid<T, std::uint32_t> index_grid;
  if constexpr (InGrid)
    payload_grid.build(
        ends.size(), r, [&](std::size_t i) { return std::optional(ends[i].position); },
        [&](std::size_t i) { return Payload{{}, ends[i].length}; });
  else
    index_grid.build(
        ends.size(), r, [&](std::size_t i) { return std::optional(ends[i].position); },
        [](std::size_t i) { return std::uint32_t(i); });
  const auto queries = light_ends(65536, 2);  // other points than the items
  std::size_t q = 0;
  std::uint64_t found = 0, sum = 0;
  for (auto _ : state) {
    const Vec3<T>& p = queries[q++ & 65535].position;
    if constexpr (InGrid)
      payload_grid.for_each_within(p, [&](const Payload& item, const Vec3<T>&) { sum += item.length, ++found; });
    else
      index_grid.for_each_within(p, [&](std::uint32_t i, const Vec3<T>&) { sum += ends[i].length, ++found; });
  }
  benchmark::DoNotOptimize(sum);
  state.counters["items_per_query"] = double(found) / double(state.iterations());
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_TEMPLATE(query, true)->Name("query/state_in_grid")->Arg(1000000)->ArgName("items");
BENCHMARK_TEMPLATE(query, false)->Name("query/index_into_light_ends")->Arg(1000000)->ArgName("items");

}  // namespace

BENCHMARK_MAIN();
