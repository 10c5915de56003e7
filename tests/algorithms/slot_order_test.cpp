// The pool renumbered in the clusters' ending-slot order (algorithms/filtering/slot_order.hpp)
// is a renaming only: every pool array and the clustering follow the new numbering, ending slot
// i holds segment i, and the densities and the propagation (the paper's weighting and the
// path-conditioned one) give every segment the numbers it had before, bit for bit; and the
// renderer's iteration, which renumbers, gives the image of the stages run without it.
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/testing/sphere_interior.hpp>
#include <segpath/testing/submerged_plane.hpp>
#include <segpath/testing/two_threads.hpp>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "custom_technique/cosine_surface_sampler.hpp"
#include "support/filtering_scenes.hpp"
#include "support/catch.hpp"

using namespace segpath;

namespace {

bool same_point(const SurfacePoint<double>& a, const SurfacePoint<double>& b) {
  return a.position == b.position && a.normal == b.normal && a.shading_normal == b.shading_normal &&
         a.primitive_id == b.primitive_id && a.material_id == b.material_id && a.kind == b.kind;
}

/// Segments of the context `before` that differ from their renamed copy in `after`, over every
/// array of the pool and the user techniques' densities (parents compared through the renaming).
template <class Context>
std::size_t pool_mismatches(const Context& before_ctx, const Context& after_ctx, const std::vector<std::uint32_t>& new_of_old) {
  const auto &before = before_ctx.pool, &after = after_ctx.pool;
  REQUIRE(before_ctx.extra_density.size() == after_ctx.extra_density.size());
  std::size_t mismatches = 0;
  for (std::size_t s = 0; s < before.size(); ++s) {
    const std::uint32_t t = new_of_old[s];
    const std::uint32_t parent = before.parent[s] == filtering::no_parent ? filtering::no_parent : new_of_old[before.parent[s]];
    mismatches += !(same_point(before.segments[s].x, after.segments[t].x) && same_point(before.segments[s].y, after.segments[t].y) &&
                    before.first_direction[s] == after.first_direction[t] && before.last_direction[s] == after.last_direction[t] &&
                    before.chain[s] == after.chain[t] && before.emitted[s] == after.emitted[t] &&
                    before.geometry[s] == after.geometry[t] && before.density[s] == after.density[t] &&
                    before.sensor_weight[s] == after.sensor_weight[t] && before.pixel[s] == after.pixel[t] &&
                    parent == after.parent[t] && before.flags[s] == after.flags[t] && before.pieces[s] == after.pieces[t] &&
                    (before_ctx.extra_density.empty() || before_ctx.extra_density[s] == after_ctx.extra_density[t]));
  }
  return mismatches;
}

/// What check_renaming saw: segments, those whose y end is in no cluster, those with a value.
struct Seen {
  std::size_t segments = 0, unclustered = 0, valued = 0, extra_densities = 0;
};

/// Draws one pool of `scene`, clusters it, renames a copy into slot order and runs the later
/// stages on both.
template <class Scn, class... Extra>
Seen check_renaming(const Scn& scene, const FilteringOptions<double>& o, const std::string& what,
                    const FilteringTechnique<Extra>&... extra) {
  INFO(what);
  const SegmentFiltering<Scn, Extra...> filter(o, extra...);
  auto before = filter.context(scene, 2, 0, filter.initial_cell_size(scene));
  filter.build_pool(before);
  Clustering<double> clustering_before;
  filtering::cluster(before, clustering_before, SerialFor{});
  auto after = before;
  Clustering<double> clustering_after = clustering_before, of_nothing;
  if (before.pool.size() > 0) CHECK_THROWS_AS(filtering::order_by_slot(after, of_nothing, SerialFor{}), std::invalid_argument);
  filtering::order_by_slot(after, clustering_after, testing::TwoThreadFor{});

  // The numbering expected: the ending slots' segments in slot order, then the others in order.
  const std::size_t n = before.pool.size();
  const auto ending = clustering_before.ending_segments();
  std::vector<std::uint32_t> new_of_old(n, 0);
  std::vector<bool> ends_in_slot(n, false);
  for (std::size_t i = 0; i < ending.size(); ++i) new_of_old[ending[i]] = std::uint32_t(i), ends_in_slot[ending[i]] = true;
  std::uint32_t next = std::uint32_t(ending.size());
  for (std::size_t s = 0; s < n; ++s)
    if (!ends_in_slot[s]) new_of_old[s] = next++;
  REQUIRE(after.pool.size() == n);
  REQUIRE(next == n);
  std::size_t identity_mismatches = 0;
  for (std::size_t i = 0; i < clustering_after.ending_segments().size(); ++i)
    identity_mismatches += clustering_after.ending_segments()[i] != i;
  CHECK(identity_mismatches == 0);
  CHECK(pool_mismatches(before, after, new_of_old) == 0);
  CHECK(after.pool.next_event_segments == before.pool.next_event_segments);
  CHECK(after.pool.bridge_targets == before.pool.bridge_targets);

  // The later stages, on the drawn order and on the slot order.
  const int iterations = int(o.max_length) - 1;
  const bool conditioned = path_conditioned(o);
  auto finish = [&](auto& ctx, const Clustering<double>& clustering, std::vector<typename Scn::Spectrum>& radiance,
                    std::vector<double>& geometry) {
    filtering::LightSide<double> side;
    filtering::compute_densities(ctx, clustering, SerialFor{}, conditioned ? &side : nullptr);
    if (conditioned) filtering::propagate_conditioned_pool(ctx, clustering, side, iterations, radiance, geometry, SerialFor{});
    else filtering::propagate_pool(ctx, clustering, iterations, radiance, geometry, SerialFor{});
  };
  std::vector<typename Scn::Spectrum> radiance_before, radiance_after;
  std::vector<double> geometry_before, geometry_after;
  finish(before, clustering_before, radiance_before, geometry_before);
  finish(after, clustering_after, radiance_after, geometry_after);
  CHECK(pool_mismatches(before, after, new_of_old) == 0);  // the densities D
  REQUIRE(radiance_after.size() == n);
  REQUIRE(geometry_after.size() == n);
  std::size_t value_mismatches = 0, nonzero = 0;
  for (std::size_t s = 0; s < n; ++s) {
    value_mismatches += !(radiance_before[s] == radiance_after[new_of_old[s]] && geometry_before[s] == geometry_after[new_of_old[s]]);
    nonzero += !is_black(radiance_before[s]);
  }
  CHECK(value_mismatches == 0);
  return {n, n - ending.size(), nonzero, before.extra_density.size()};
}

}  // namespace

TEST_CASE("the pool in slot order is a renaming: every array, the clusters and the propagated values follow it",
          "[algorithms]") {
  const auto glass = testing::point_lit_glass();
  const auto sphere = testing::sphere_furnace();
  for (const FilteringMode mode : {FilteringMode::mvf, FilteringMode::phf, FilteringMode::bdpf}) {
    const Seen g = check_renaming(glass, testing::point_lit_glass_options(mode), std::string("submerged plane, ") + to_string(mode));
    FilteringOptions<double> o = testing::sphere_furnace_options(mode);
    o.bridges = mode == FilteringMode::bdpf;
    const Seen p = check_renaming(sphere, o, std::string("sphere interior, ") + to_string(mode));
    INFO(to_string(mode));
    // Not vacuous: segments ending off the clusters (at the point light) keep their order after
    // the slots' (MVF has no technique for the light's chains: its submerged plane stays black).
    CHECK(g.unclustered > 0);
    if (mode != FilteringMode::mvf) CHECK(g.valued > g.segments / 10);
    CHECK(p.segments > 500);
    CHECK(p.valued > p.segments / 2);
  }
  // A user's own technique: its densities are renamed with the pool.
  using Cosine = example::CosineSurfaceSampler<testing::PhotographedSphereInterior<double>>;
  FilteringOptions<double> o;
  o.max_length = 5;
  o.initial_cell_size = 0.3;
  const Seen u = check_renaming(sphere, o, "sphere interior, bdpf with a user technique", FilteringTechnique<Cosine>{Cosine{}, 0.5});
  CHECK(u.extra_densities == u.segments);
}

// The renderer's path (cluster_in_slot_order inside render_iteration_at, on two threads) against
// the same stages run without the renumbering: the same image, pixel for pixel.
TEST_CASE("BDPF's iteration, which renumbers its pool, gives the image of the stages without it", "[algorithms]") {
  const testing::PhotographedSphereInterior<double> scene(12);
  FilteringOptions<double> o;
  o.mode = FilteringMode::bdpf;
  o.max_length = 5;
  o.initial_cell_size = 0.3;
  o.seed = 4;
  REQUIRE(path_conditioned(o));
  const SegmentFiltering<testing::PhotographedSphereInterior<double>> filter(o);
  const std::uint32_t pixels = 12 * 12;
  for (const std::uint64_t iteration : {0, 3}) {
    const double cell = filter.kernel_schedule(scene).at(iteration);
    Framebuffer<double> rendered(12, 12);
    DropCounters drops;
    filter.render_iteration_at(scene, iteration, cell, rendered, drops, testing::TwoThreadFor{});
    // The stages in the drawn order.
    auto ctx = filter.context(scene, iteration, 0, cell);
    filter.build_pool(ctx);
    Clustering<double> clustering;
    filtering::cluster(ctx, clustering, SerialFor{});
    filtering::LightSide<double> side;
    filtering::compute_densities(ctx, clustering, SerialFor{}, &side);
    std::vector<double> radiance, geometry;
    filtering::propagate_conditioned_pool(ctx, clustering, side, int(o.max_length) - 1, radiance, geometry, SerialFor{});
    Framebuffer<double> staged(12, 12);
    for (std::size_t i = 0; i < ctx.pool.size(); ++i)
      if (ctx.pool.flags[i] & filtering::sensor_segment) staged.add(ctx.pool.pixel[i], radiance[i] * (ctx.pool.sensor_weight[i] * geometry[i]));
    std::size_t differ = 0, lit = 0;
    for (std::uint32_t p = 0; p < pixels; ++p) {
      differ += rendered.pixels()[p] != staged.pixels()[p];
      lit += rendered.pixels()[p] > 0;
    }
    CHECK(differ == 0);
    CHECK(lit == pixels);
  }
}
