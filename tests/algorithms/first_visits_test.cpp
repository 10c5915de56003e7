// The paths stage's first-visit rule and round-trip partners through delta chains
// (algorithms/filtering/paths.hpp, propagation.hpp backtrack_partners). A path draws a
// technique sample only at its first visit of a voxel (filtering::Context::visit_grid), and
// what it draws at a repeat visit joins no chain (G = 0): the path-conditioned weighting assumes
// a path holds at most one technique sample per cluster (docs/filtering.md, "A light path's
// repeat visits"). Through glass the draw happens at the chain's far end, after its delta
// bounces: here a light predecessor that leaves the submerged square upwards is reflected by
// the interface (mostly totally) back down to the square, so every light path that comes back
// to a voxel does so through a chain. The slab tests (segment_filtering_test.cpp) have no delta
// surfaces.
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/testing/submerged_plane.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <vector>

#include "support/backtrack_oracle.hpp"
#include "support/catch.hpp"
#include "support/filtering_scenes.hpp"

using namespace segpath;

namespace {

using GlassScene = testing::PointLitSubmergedPlane<double>;
using Filter = SegmentFiltering<GlassScene>;

/// The square (primitive 0) is Lambertian: a path tries a draw at every vertex on it (paths have
/// no depth limit); the interface (primitive 1) is delta and draws no technique sample.
bool on_square(const SurfacePoint<double>& p) { return p.kind == PointKind::surface && p.primitive_id == 0; }

/// point_lit_glass's square, interface and light seen by 64 probes (8 x 8 targets over the
/// square, tilted by up to 0.5 rad): camera paths enough to come back to a voxel too.
GlassScene probed_glass() {
  std::vector<testing::SubmergedProbe<double>> probes;
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j)
      probes.push_back({Vec2<double>(-1.5 + 3.0 * i / 7, -1.5 + 3.0 * j / 7), 0.5 * (i - 3.5) / 3.5});
  return GlassScene({2, 0.5, 1, 1.5, 1, 0.5}, probes);
}

}  // namespace

// Power (checked): a repeat visit's chain given its G fails 32 assertions on light paths and 6
// on camera paths; the visits also keyed at the interface's delta vertices fails 3,594.
TEST_CASE("segment filtering: through glass, a path draws technique samples only at its first visit of a voxel, and its "
          "repeat visits' chains carry nothing",
          "[algorithms]") {
  const GlassScene scene = probed_glass();
  FilteringOptions<double> o = testing::point_lit_glass_options(FilteringMode::bdpf);
  o.max_length = 8;          // camera paths of up to three chains on the square
  o.light_path_ratio = 30;   // 1,920 light paths an iteration
  o.initial_cell_size = 1;   // voxels large against the square (4 x 4): repeat visits are common
  o.next_event = false;      // below: every segment with a parent is the one its path drew next
  const Filter filter(o);
  // Per side (0 camera, 1 light): technique samples, repeat visits, and repeat visits whose draw
  // is a chain through the interface.
  std::array<std::size_t, 2> technique{}, repeats{}, chain_repeats{};
  std::size_t paths_checked = 0, shared = 0;
  for (std::uint64_t iteration = 0; iteration < 8; ++iteration) {
    auto ctx = filter.context(scene, iteration, 0, 1.0);
    filter.build_pool(ctx);
    const auto& pool = ctx.pool;
    Clustering<double> clustering;
    filtering::cluster(ctx, clustering, SerialFor{});
    std::vector<std::uint32_t> drawn(pool.size(), filtering::no_parent);
    for (std::uint32_t i = 0; i < pool.size(); ++i)
      if (pool.parent[i] != filtering::no_parent) drawn[pool.parent[i]] = i;
    // The cluster of the vertex at which segment i of a path draws the next: x on a light path,
    // y on a camera path (after the chain's delta bounces).
    const auto cluster_at = [&](std::uint32_t i, bool light) { return light ? clustering.cluster_of_x(i) : clustering.cluster_of_y(i); };
    std::map<std::uint32_t, std::vector<std::size_t>> held;  // cluster -> the paths of its technique samples
    const auto check_path = [&](std::uint32_t first, bool light) {
      const std::size_t path = paths_checked++;
      std::vector<std::uint32_t> visited;  // clusters of the path's technique samples so far
      for (std::uint32_t i = first; i != filtering::no_parent; i = drawn[i]) {
        const SurfacePoint<double>& v = light ? pool.segments[i].x : pool.segments[i].y;
        const std::uint16_t flag = light ? filtering::light_technique : filtering::camera_technique;
        const bool tries = on_square(v);  // camera and light paths have no depth limit
        if (!tries) {
          CHECK((pool.flags[i] & flag) == 0);
          CHECK(drawn[i] == filtering::no_parent);
          continue;
        }
        const std::uint32_t c = cluster_at(i, light);
        REQUIRE(c != no_cluster);
        const bool first_visit = std::find(visited.begin(), visited.end(), c) == visited.end();
        CHECK(((pool.flags[i] & flag) != 0) == first_visit);
        if (drawn[i] != filtering::no_parent) {
          const std::uint32_t next = drawn[i];
          CHECK(((pool.flags[next] & filtering::repeat_visit_born) != 0) == !first_visit);
          if (first_visit) CHECK(pool.geometry[next] > 0.0);
          if (!first_visit) {
            CHECK(pool.geometry[next] == 0.0);
            chain_repeats[light] += (pool.flags[next] & filtering::chain_segment) ? 1 : 0;
          }
        }
        if (pool.flags[i] & flag) held[c].push_back(path);
        if (first_visit) {
          visited.push_back(c);
          ++technique[light];
        } else {
          ++repeats[light];
        }
      }
    };
    for (std::uint32_t i = 0; i < pool.size(); ++i) {
      if (pool.flags[i] & filtering::light_start) check_path(i, true);
      if (pool.flags[i] & filtering::sensor_segment) check_path(i, false);
    }
    // What the rule is for, by the pool's own flags: no cluster holds two technique samples of
    // one path.
    for (auto& [cluster, paths] : held) {
      std::sort(paths.begin(), paths.end());
      const bool twice = std::adjacent_find(paths.begin(), paths.end()) != paths.end();
      if (twice) CHECK_FALSE(twice);
      shared += paths.size() > 1;
    }
  }
  for (const int light : {0, 1}) {
    INFO((light ? "light" : "camera") << " paths: " << technique[light] << " technique samples, " << repeats[light]
                                      << " repeat visits, " << chain_repeats[light] << " of them drawing a chain");
    CHECK(technique[light] > 10);
    CHECK(repeats[light] > 3);
    CHECK(chain_repeats[light] > 2);
  }
  INFO("light paths: " << chain_repeats[1] << " repeat visits drawing a chain through the interface");
  CHECK(chain_repeats[1] > 15);
  CHECK(shared > 20);
}

// backtrack_partners pairs a segment with the one that drew it (a camera successor with its
// parent, a parent with its light predecessor) whatever either is: through glass both are often
// chains, and the partner must still be the drawn one, not a piece of its chain. Power
// (checked): chains left out of backtrack_partners fail.
TEST_CASE("segment filtering: through glass, a chain's backtrack partner is its light predecessor or its camera parent",
          "[algorithms]") {
  const GlassScene scene = probed_glass();
  FilteringOptions<double> o = testing::point_lit_glass_options(FilteringMode::bdpf);
  o.max_length = 8;
  o.light_path_ratio = 30;
  const Filter filter(o);
  const testing::PartnersCheck check = testing::check_backtrack_partners(filter, scene);
  CHECK(check.expected.one_predecessor);
  CHECK(check.same);
  CHECK(check.expected.chained > 100);
}
