// Not built by CMake: the per-chain-length harness of docs/bias-notes.md (build line there).
// Per-chain-length image means of BDPF on one pool per iteration: the pool, clusters and
// denominators of max_length, propagated for k = 1 .. max_length - 1 iterations.
#include "renderer/obj_scene.hpp"
#include <segpath/algorithms/segment_filtering.hpp>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <string>
#include <vector>
using namespace segpath;
using renderer::T;
using renderer::Color;
int main(int argc, char** argv) {
  if (argc < 8) { std::fprintf(stderr, "harness OBJ W ML CELL BETA ITER NEE [paper] [seed] [disk]\n"); return 1; }
  const std::string obj = argv[1];
  const unsigned W = std::atoi(argv[2]);
  const std::size_t ml = std::atoi(argv[3]);
  const double cell = std::atof(argv[4]);
  const double beta = std::atof(argv[5]);
  const int iters = std::atoi(argv[6]);
  const bool nee = std::atoi(argv[7]) != 0;
  const bool paper = argc > 8 && std::atoi(argv[8]) != 0;
  const std::uint64_t seed = argc > 9 ? std::atoll(argv[9]) : 1;
  const bool disk = argc > 10 && std::atoi(argv[10]) != 0;
  renderer::ObjCamera cam;
  cam.position = {0, -0.9f, 0}; cam.target = {0, 1, 0}; cam.up = {0, 0, 1}; cam.fov_y_degrees = 70;
  const renderer::RenderScene scene = renderer::load_obj_scene(obj, cam, W, W);
  FilteringOptions<T> o;
  o.mode = FilteringMode::bdpf;
  o.max_length = ml;
  o.light_path_ratio = T(beta);
  o.next_event = nee;
  o.seed = seed;
  o.support = disk ? FilteringSupport::disk : FilteringSupport::voxel;
  o.weighting = paper ? FilteringWeighting::paper : FilteringWeighting::path_conditioned;
  using F = SegmentFiltering<renderer::RenderScene>;
  const F f(o);
  std::vector<double> sum(ml, 0), sum2(ml, 0);
  for (int it = 0; it < iters; ++it) {
    auto ctx = f.context(scene, std::uint64_t(it), 0, T(cell));
    f.build_pool(ctx);
    const auto& pool = ctx.pool;
    std::vector<Color> radiance;
    std::vector<T> wg;
    Clustering<T> clustering;
    DiskJunctions<T> junctions;
    filtering::LightSide<T> side;
    if (!disk) {
      filtering::cluster(ctx, clustering, SerialFor{});
      filtering::compute_densities(ctx, clustering, SerialFor{}, paper ? nullptr : &side);
    } else {
      filtering::join(ctx, junctions, SerialFor{});
      filtering::compute_densities(ctx, junctions, SerialFor{});
      if (!paper) filtering::light_side(ctx, junctions, side, SerialFor{});
    }
    for (std::size_t k = 1; k < ml; ++k) {
      if (!disk) {
        if (paper) filtering::propagate_pool(ctx, clustering, int(k), radiance, wg, SerialFor{});
        else filtering::propagate_conditioned_pool(ctx, clustering, side, int(k), radiance, wg, SerialFor{});
      } else {
        if (paper) filtering::propagate_pool(ctx, junctions, int(k), radiance, wg, SerialFor{});
        else filtering::propagate_conditioned_pool(ctx, junctions, side, int(k), radiance, wg, SerialFor{});
      }
      double total = 0;
      for (std::size_t i = 0; i < pool.size(); ++i) {
        if (!(pool.flags[i] & filtering::sensor_segment)) continue;
        const Color v = radiance[i] * (pool.sensor_weight[i] * wg[i]);
        if (is_finite(v)) total += (double(v.r) + double(v.g) + double(v.b)) / 3.0;
      }
      const double mean = total / double(W * W);
      sum[k] += mean; sum2[k] += mean * mean;
    }
  }
  for (std::size_t k = 1; k < ml; ++k) {
    const double m = sum[k] / iters, var = (sum2[k] / iters - m * m) * iters / (iters - 1);
    std::printf("len<=%zu %.6f %.6f\n", k + 1, m, std::sqrt(var / iters));
  }
}
