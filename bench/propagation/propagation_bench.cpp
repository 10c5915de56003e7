// Propagation (Algorithm 1) costs, on BDPF pools of the periodic slab seen through a pinhole:
//  - one Jacobi iteration against the number of segments, 2e4 .. 2e6, as
//    filtering::propagate_pool runs it (link from filtering::Transfer), inputs
//    gathered into slot order beforehand: the log-log slope (of CPU time) is printed at the end
//    (target <= 1.1: linear);
//  - that gathering, once per pool (Transfer::build and prepare_propagation), same sizes;
//  - MMIS denominators + one iteration against cluster occupancy, factorised or not;
//  - bytes per segment (counter);
//  - the naive recursive MMIS estimator (N39) against propagation at depth 5 on one pool
//    (target: propagation >= 1000x faster);
//  - Clustering::build on pools of 2e4 .. 2e6 segments: std::sort against the radix sort,
//    serial and on two threads.
//   build/bench/bench_propagation_propagation_bench
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/estimators/recursive_mmis.hpp>
#include <segpath/sensors/pinhole_camera.hpp>
#include <segpath/testing/periodic_slab.hpp>
#include <segpath/testing/two_threads.hpp>

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <thread>
#include <vector>

namespace {

using namespace segpath;
using T = double;

class Slab : public testing::PeriodicSlab<T> {
 public:
  explicit Slab(std::uint32_t size)
      : testing::PeriodicSlab<T>(testing::PeriodicSlabParameters<T>{1.0, 4.0, 0.7, 0.4, 0.5, 0.6}, {testing::SlabProbe<T>{}}),
        camera_([&] {
          PinholeCameraParameters<T> c;
          c.position = {0.3, 0.2, 0.6};
          c.forward = {0, 0, -1};
          c.right = {1, 0, 0};
          c.up = {0, 1, 0};
          c.width = c.height = size;
          c.fov_x_degrees = c.fov_y_degrees = 90;
          return c;
        }()) {}
  [[nodiscard]] const PinholeCamera<T>& sensor() const noexcept { return camera_; }

 private:
  PinholeCamera<T> camera_;
};

using Filter = SegmentFiltering<Slab>;

FilteringOptions<T> options(bool factorise) {
  FilteringOptions<T> o;
  o.max_length = 6;
  o.light_path_ratio = 0.25;
  o.next_event = false;
  o.factorise = factorise;
  return o;
}

/// A pool with everything propagation needs, built once per size.
struct Prepared {
  Slab scene;
  Filter filter;
  Filter::Context context;
  const Filter::Pool& pool;
  Clustering<T> clustering;
  std::vector<T> weighted_geometry;
  filtering::Transfer<Slab> transfer;
  const FilteringStats& stats;

  Prepared(std::uint32_t size, T cell, bool factorise)
      : scene(size), filter(options(factorise)), context(filter.context(scene, 0, 0, cell)), pool(context.pool), stats(context.stats) {
    filter.build_pool(context);
    filtering::cluster(context, clustering, SerialFor{});
    filtering::compute_densities(context, clustering, SerialFor{});
    weighted_geometry.resize(pool.size());
    for (std::size_t i = 0; i < pool.size(); ++i)
      weighted_geometry[i] = pool.density[i] > 0 ? pool.geometry[i] / pool.density[i] : 0;
    transfer.build(pool, clustering);
  }

  /// The link of filtering::propagate_pool.
  filtering::TransferLink<Slab> link() const { return {scene.bsdf(), transfer}; }
  /// The same by segment ids, for the naive recursion.
  auto id_link() const {
    return [this](std::uint32_t s, std::uint32_t sp) {
      return scene.bsdf().eval(BsdfQuery<T>{pool.segments[s].y, -pool.last_direction[s], pool.first_direction[sp],
                                            Transport::radiance}) *
             pool.chain[s];
    };
  }
};

/// Image side for a pool of about n segments (about 3.6 segments per camera path here).
std::uint32_t side_for(double n) { return std::uint32_t(std::sqrt(n / 3.6)); }

void BM_propagation_iteration(benchmark::State& state) {
  // Voxel size ~ 4 pixel footprints, as in BDPF: the occupancy stays constant with n.
  const std::uint32_t side = side_for(double(state.range(0)));
  const Prepared p(side, 0.6 * 4.0 / side, false);
  const auto link = p.link();
  const PropagationInputs<T, decltype(link)> in{p.clustering, p.pool.emitted, p.weighted_geometry, link};
  std::vector<T> radiance;
  PropagationWorkspace<T> workspace;
  prepare_propagation(in, workspace);
  for (auto _ : state) {
    propagate_prepared(in, 1, radiance, workspace);
    benchmark::DoNotOptimize(radiance.data());
  }
  state.counters["segments"] = double(p.pool.size());
  state.counters["per_cluster"] = double(p.pool.size()) / double(p.clustering.clusters().size());
  // Pool, clustering, G w, radiance, transfer, workspace.
  state.counters["bytes_per_segment"] =
      double(p.pool.bytes_per_segment() + p.clustering.bytes_per_segment() + 2 * sizeof(T)) +
      double(p.transfer.bytes() + workspace.bytes()) / double(p.pool.size());
  state.SetComplexityN(std::int64_t(p.pool.size()));
}
BENCHMARK(BM_propagation_iteration)->Arg(10000)->Arg(30000)->Arg(100000)->Arg(300000)->Arg(1000000)->Unit(benchmark::kMillisecond)->Complexity();

void BM_pool_preparation(benchmark::State& state) {
  // Once per pool (render iteration): the link's copies (filtering::Transfer) and the
  // inputs in slot order.
  const std::uint32_t side = side_for(double(state.range(0)));
  const Prepared p(side, 0.6 * 4.0 / side, false);
  filtering::Transfer<Slab> transfer;
  PropagationWorkspace<T> workspace;
  for (auto _ : state) {
    transfer.build(p.pool, p.clustering);
    const filtering::TransferLink<Slab> link{p.scene.bsdf(), transfer};
    prepare_propagation(PropagationInputs<T, filtering::TransferLink<Slab>>{p.clustering, p.pool.emitted, p.weighted_geometry, link},
                        workspace);
    benchmark::DoNotOptimize(workspace.source.data());
  }
  state.counters["segments"] = double(p.pool.size());
}
BENCHMARK(BM_pool_preparation)->Arg(10000)->Arg(1000000)->Unit(benchmark::kMillisecond);

void BM_occupancy(benchmark::State& state) {
  // Fixed pool, growing voxels: denominators (N39) + one iteration, factorised or not.
  const double cell = double(state.range(0)) / 100.0;
  const bool factorise = state.range(1) != 0;
  Prepared p(128, T(cell), factorise);
  const double pair_evaluations = double(p.stats.pair_evaluations);  // of one denominator pass
  std::vector<T> radiance, scratch;
  for (auto _ : state) {
    filtering::compute_densities(p.context, p.clustering, SerialFor{});
    std::vector<T> weighted_geometry;
    filtering::propagate_pool(p.context, p.clustering, 1, radiance, weighted_geometry, SerialFor{});
    benchmark::DoNotOptimize(radiance.data());
  }
  state.counters["per_cluster"] = double(p.pool.size()) / double(p.clustering.clusters().size());
  state.counters["pair_evaluations"] = pair_evaluations;
  state.SetLabel(factorise ? "factorised" : "O(n m) sums");
}
BENCHMARK(BM_occupancy)->ArgsProduct({{5, 10, 20, 40}, {0, 1}})->Unit(benchmark::kMillisecond);

void BM_naive_vs_propagation(benchmark::State& state) {
  // A pool small enough for the exponential recursion: 12 x 12 pixels, large voxels.
  const bool naive = state.range(0) != 0;
  const Prepared p(12, 1.0, false);
  const auto link = p.id_link();
  std::vector<std::uint32_t> sensor;
  for (std::uint32_t i = 0; i < p.pool.size(); ++i)
    if (p.pool.flags[i] & filtering::sensor_segment) sensor.push_back(i);
  const PropagationInputs<T, decltype(link)> in{p.clustering, p.pool.emitted, p.weighted_geometry, link};
  std::vector<T> radiance, scratch;
  for (auto _ : state) {
    T total = 0;
    if (naive) {
      for (auto s : sensor) total += recursive_mmis_radiance<T>(p.clustering, p.pool.emitted, p.weighted_geometry, link, s, 5);
    } else {
      propagate(in, 5, radiance, scratch);
      for (auto s : sensor) total += radiance[s];
    }
    benchmark::DoNotOptimize(total);
  }
  state.counters["segments"] = double(p.pool.size());
  state.SetLabel(naive ? "naive recursion (N39)" : "propagation");
}
BENCHMARK(BM_naive_vs_propagation)->Arg(1)->Arg(0)->Unit(benchmark::kMicrosecond);

void BM_clustering_build(benchmark::State& state) {
  // Voxel size ~ 4 pixel footprints, as in BDPF; range(1): 0 std::sort, 1 radix; range(2): threads.
  const std::uint32_t side = side_for(double(state.range(0)));
  const Slab scene(side);
  const Filter filter(options(false));
  Filter::Context context = filter.context(scene, 0);
  filter.build_pool(context);
  const auto& pool = context.pool;
  const auto grid = filtering::grid(filter.options(), T(0.6 * 4.0 / side), context.stream);
  Clustering<T> clustering;
  clustering.force_comparison_sort(state.range(1) == 0);
  const bool two_threads = state.range(2) == 2;
  for (auto _ : state) {
    if (two_threads)
      clustering.build(grid, std::span<const Segment<T>>(pool.segments), filtering::canonical_map(scene), segpath::testing::TwoThreadFor{});
    else
      clustering.build(grid, std::span<const Segment<T>>(pool.segments), filtering::canonical_map(scene), SerialFor{});
    benchmark::DoNotOptimize(clustering.clusters().data());
  }
  state.counters["segments"] = double(pool.size());
  state.counters["per_cluster"] = double(pool.size()) / double(clustering.clusters().size());
  state.SetLabel(std::string(clustering.last_sort() == EndpointSort::radix ? "radix" : "std::sort") +
                 (two_threads ? ", 2 threads" : ", serial"));
}
BENCHMARK(BM_clustering_build)
    ->ArgsProduct({{20000, 200000, 2000000}, {0, 1}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// Console output plus the derived figures: the log-log slope of time against segments, and
/// the naive / propagation ratio.
class FiguresReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& r : runs) {
      if (r.run_type != Run::RT_Iteration || r.iterations == 0) continue;
      const std::string name = r.benchmark_name();
      const double t = r.GetAdjustedCPUTime();
      if (name.rfind("BM_propagation_iteration/", 0) == 0 && r.counters.count("segments"))
        scaling_.emplace_back(r.counters.at("segments").value, t);
      if (name == "BM_naive_vs_propagation/1") naive_ = t;
      if (name == "BM_naive_vs_propagation/0") propagation_ = t;
    }
    ConsoleReporter::ReportRuns(runs);
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    if (scaling_.size() >= 2) {
      double sx = 0, sy = 0, sxx = 0, sxy = 0;
      for (const auto& [n, t] : scaling_) {
        const double x = std::log(n), y = std::log(t);
        sx += x, sy += y, sxx += x * x, sxy += x * y;
      }
      const double m = double(scaling_.size());
      std::printf("log-log slope of propagation time against segments: %.3f (target <= 1.1)\n",
                  (m * sxy - sx * sy) / (m * sxx - sx * sx));
    }
    if (naive_ > 0 && propagation_ > 0)
      std::printf("naive recursion / propagation at depth 5: %.0fx (target >= 1000x)\n", naive_ / propagation_);
  }

 private:
  std::vector<std::pair<double, double>> scaling_;
  double naive_ = 0, propagation_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  FiguresReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
