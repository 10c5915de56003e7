// The propagation over voxel clusters frees the pool's end points, directions, chain
// throughputs and parents once it reads them no more (filtering::PoolGeometry::release,
// Pool::release_geometry): the memory is returned and every segment's value is the one it has
// with the pool kept, bit for bit, for the paper's weighting (MVF, PhF) and the
// path-conditioned one (BDPF), on the drawn order and on the slot order.
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/testing/two_threads.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "support/catch.hpp"
#include "support/filtering_scenes.hpp"

using namespace segpath;

namespace {

template <class Pl>
std::size_t geometry_capacity(const Pl& pool) {
  return pool.segments.capacity() + pool.first_direction.capacity() + pool.last_direction.capacity() + pool.chain.capacity() +
         pool.parent.capacity();
}

/// Propagates one pool of `scene` twice, keeping and releasing its geometry; returns the number
/// of segments with a value (the check is not vacuous where it is large).
template <class Scn>
std::size_t check_release(const Scn& scene, const FilteringOptions<double>& o, bool slot_order, const std::string& what) {
  INFO(what << (slot_order ? ", slot order" : ", drawn order"));
  const SegmentFiltering<Scn> filter(o);
  auto kept = filter.context(scene, 1, 0, filter.initial_cell_size(scene));
  filter.build_pool(kept);
  Clustering<double> clustering;
  if (slot_order) filtering::cluster_in_slot_order(kept, clustering, SerialFor{});
  else filtering::cluster(kept, clustering, SerialFor{});
  const bool conditioned = path_conditioned(o);
  filtering::LightSide<double> side;
  filtering::compute_densities(kept, clustering, SerialFor{}, conditioned ? &side : nullptr);
  auto released = kept;
  const std::size_t n = kept.pool.size();
  REQUIRE(geometry_capacity(released.pool) > 0);
  const int iterations = int(o.max_length) - 1;
  std::vector<typename Scn::Spectrum> radiance_kept, radiance_released;
  std::vector<double> geometry_kept, geometry_released;
  if (conditioned) {
    filtering::propagate_conditioned_pool(kept, clustering, side, iterations, radiance_kept, geometry_kept, SerialFor{});
    filtering::propagate_conditioned_pool(released, clustering, side, iterations, radiance_released, geometry_released,
                                          testing::TwoThreadFor{}, filtering::PoolGeometry::release);
  } else {
    filtering::propagate_pool(kept, clustering, iterations, radiance_kept, geometry_kept, SerialFor{});
    filtering::propagate_pool(released, clustering, iterations, radiance_released, geometry_released, testing::TwoThreadFor{},
                              filtering::PoolGeometry::release);
  }
  CHECK(kept.pool.segments.size() == n);  // the default keeps it
  CHECK(geometry_capacity(released.pool) == 0);
  // What the gather reads is still there.
  CHECK(released.pool.size() == n);
  CHECK(released.pool.sensor_weight.size() == n);
  CHECK(released.pool.pixel.size() == n);
  REQUIRE(radiance_released.size() == n);
  REQUIRE(geometry_released.size() == n);
  std::size_t mismatches = 0, valued = 0;
  for (std::size_t s = 0; s < n; ++s) {
    mismatches += !(radiance_kept[s] == radiance_released[s] && geometry_kept[s] == geometry_released[s]);
    valued += !is_black(radiance_kept[s]);
  }
  CHECK(mismatches == 0);
  return valued;
}

}  // namespace

TEST_CASE("the propagation frees the pool's end points when asked and gives the values it gives with them",
          "[algorithms]") {
  const auto glass = testing::point_lit_glass();
  const auto sphere = testing::sphere_furnace();
  for (const FilteringMode mode : {FilteringMode::mvf, FilteringMode::phf, FilteringMode::bdpf}) {
    for (const bool slot_order : {false, true}) {
      const std::size_t g =
          check_release(glass, testing::point_lit_glass_options(mode), slot_order, std::string("submerged plane, ") + to_string(mode));
      FilteringOptions<double> o = testing::sphere_furnace_options(mode);
      const std::size_t p = check_release(sphere, o, slot_order, std::string("sphere interior, ") + to_string(mode));
      // Without the factorised sums: every cluster reads the transfer's copies.
      o.factorise = false;
      o.transfer_cache_bytes = 0;
      const std::size_t q = check_release(sphere, o, slot_order, std::string("sphere interior, unfactorised, ") + to_string(mode));
      INFO(to_string(mode));
      if (mode != FilteringMode::mvf) CHECK(g > 50);  // MVF has no technique for the light's chains
      CHECK(p > 500);
      CHECK(q > 500);
    }
  }
}
