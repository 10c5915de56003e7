// Where EmbreeManifold's direct traversal (adapters/embree/brute_force.hpp) stops paying: the
// same queries through Traversal::brute_force and Traversal::embree on scenes of N primitives,
// a closed room (12 triangles) with N - 12 small random triangles inside, or N - 14 of them
// and two spheres, or (_boxes) (N - 12) / 12 small closed boxes of 12 triangles each, whose
// triangles form the bounded runs the direct traversal skips as a whole. Queries: rays from
// points on the room's surfaces in cosine-ish random directions (intersect), and visibility
// between two such points. Each scene reports its expected direct tests
// (EmbreeManifold::expected_direct_tests()); where the per-query times cross is what
// EmbreeManifold::brute_force_max_expected_tests() should be (docs/figures.md).
//   build/bench/renderer/bench_renderer_embree_traversal_bench
#include <benchmark/benchmark.h>

#include "segpath/adapters/embree.hpp"
#include "segpath/adapters/embree/box_mesh.hpp"
#include "segpath/core/rng.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

namespace {

using T = float;
using M = segpath::EmbreeManifold<T>;
using V = segpath::Vec3<T>;

/// The inside of the unit cube, its six faces as two triangles each, normals inwards.
M::Mesh room() { return segpath::box_mesh<T>(V(0), V(1), segpath::BoxFacing::inwards); }

/// What fills the room: random triangles, the same and two spheres, or small boxes.
enum class Clutter { triangles, spheres, boxes };

M::Description scene(std::uint32_t primitives, Clutter kind, M::Traversal traversal) {
  M::Description d;
  d.traversal = traversal;
  d.meshes.push_back(room());
  const bool spheres = kind == Clutter::spheres;
  const std::uint32_t sphere_count = spheres ? 2 : 0;
  segpath::Pcg32 rng(7, 11);
  auto u = [&] { return rng.uniform<T>(); };
  M::Mesh clutter;
  if (kind == Clutter::boxes) {
    for (std::uint32_t k = 12; k + 12 <= primitives; k += 12) {
      const V c(T(0.15) + T(0.7) * u(), T(0.15) + T(0.7) * u(), T(0.15) + T(0.7) * u());
      segpath::append_box<T>(clutter, c - T(0.04), c + T(0.04), segpath::BoxFacing::outwards);
    }
    if (!clutter.triangles.empty()) d.meshes.push_back(clutter);
    return d;
  }
  for (std::uint32_t k = 12 + sphere_count; k < primitives; ++k) {
    const V c(T(0.15) + T(0.7) * u(), T(0.15) + T(0.7) * u(), T(0.15) + T(0.7) * u());
    const auto base = std::uint32_t(clutter.positions.size());
    for (int v = 0; v < 3; ++v) clutter.positions.push_back(c + T(0.12) * V(u() - T(0.5), u() - T(0.5), u() - T(0.5)));
    clutter.triangles.push_back({base, base + 1, base + 2});
  }
  if (!clutter.triangles.empty()) d.meshes.push_back(clutter);
  if (spheres) {
    d.spheres.push_back({V(T(0.3), T(0.25), T(0.3)), T(0.18), 0});
    d.spheres.push_back({V(T(0.7), T(0.25), T(0.65)), T(0.18), 0});
  }
  return d;
}

/// Points on the room's walls (the first mesh): where a path's rays start.
std::vector<segpath::SurfacePoint<T>> wall_points(const M& manifold, std::size_t n) {
  std::vector<segpath::SurfacePoint<T>> points;
  segpath::Pcg32 rng(3, 5);
  while (points.size() < n) {
    const auto s = manifold.sample_area({rng.uniform2<T>()});
    if (s && s->point.primitive_id < 12) points.push_back(s->point);
  }
  return points;
}

void intersect(benchmark::State& state, M::Traversal traversal, Clutter kind) {
  const M manifold(scene(std::uint32_t(state.range(0)), kind, traversal));
  const auto points = wall_points(manifold, 4096);
  std::vector<segpath::IntersectQuery<T>> queries;
  segpath::Pcg32 rng(9, 1);
  for (const auto& p : points) {
    // Into the room: the normal plus a random unit vector, normalised.
    V d = p.normal + glm::normalize(V(rng.uniform<T>() - T(0.5), rng.uniform<T>() - T(0.5), rng.uniform<T>() - T(0.5)));
    queries.push_back({segpath::Ray<T>{p.position, glm::normalize(d)}});
  }
  state.counters["expected_tests"] = manifold.expected_direct_tests();
  std::size_t hits = 0;
  for (auto _ : state)
    for (const auto& q : queries) hits += manifold.intersect(q).has_value() ? 1 : 0;
  benchmark::DoNotOptimize(hits);
  state.SetItemsProcessed(std::int64_t(state.iterations()) * std::int64_t(queries.size()));
}

void visible(benchmark::State& state, M::Traversal traversal, Clutter kind) {
  const M manifold(scene(std::uint32_t(state.range(0)), kind, traversal));
  const auto points = wall_points(manifold, 4096);
  state.counters["expected_tests"] = manifold.expected_direct_tests();
  std::size_t seen = 0;
  for (auto _ : state)
    for (std::size_t i = 0; i + 1 < points.size(); i += 2) seen += manifold.visible({points[i], points[i + 1]}) ? 1 : 0;
  benchmark::DoNotOptimize(seen);
  state.SetItemsProcessed(std::int64_t(state.iterations()) * std::int64_t(points.size() / 2));
}

void sizes(benchmark::internal::Benchmark* b) {
  for (int n : {16, 20, 24, 28, 32, 40, 48, 64}) b->Arg(n);
}

/// Scenes of a room and 1-30 boxes.
void box_sizes(benchmark::internal::Benchmark* b) {
  for (int n : {24, 48, 72, 96, 132, 180, 252, 372}) b->Arg(n);
}

BENCHMARK_CAPTURE(intersect, direct, M::Traversal::brute_force, Clutter::triangles)->Apply(sizes);
BENCHMARK_CAPTURE(intersect, embree, M::Traversal::embree, Clutter::triangles)->Apply(sizes);
BENCHMARK_CAPTURE(intersect, direct_spheres, M::Traversal::brute_force, Clutter::spheres)->Apply(sizes);
BENCHMARK_CAPTURE(intersect, embree_spheres, M::Traversal::embree, Clutter::spheres)->Apply(sizes);
BENCHMARK_CAPTURE(intersect, direct_boxes, M::Traversal::brute_force, Clutter::boxes)->Apply(box_sizes);
BENCHMARK_CAPTURE(intersect, embree_boxes, M::Traversal::embree, Clutter::boxes)->Apply(box_sizes);
BENCHMARK_CAPTURE(visible, direct, M::Traversal::brute_force, Clutter::triangles)->Apply(sizes);
BENCHMARK_CAPTURE(visible, embree, M::Traversal::embree, Clutter::triangles)->Apply(sizes);
BENCHMARK_CAPTURE(visible, direct_spheres, M::Traversal::brute_force, Clutter::spheres)->Apply(sizes);
BENCHMARK_CAPTURE(visible, embree_spheres, M::Traversal::embree, Clutter::spheres)->Apply(sizes);
BENCHMARK_CAPTURE(visible, direct_boxes, M::Traversal::brute_force, Clutter::boxes)->Apply(box_sizes);
BENCHMARK_CAPTURE(visible, embree_boxes, M::Traversal::embree, Clutter::boxes)->Apply(box_sizes);

}  // namespace

BENCHMARK_MAIN();
