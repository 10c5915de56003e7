// The backtrack partners that filtering::backtrack_partners must give a pool, from its parents
// alone (the round trips the path-conditioned propagation leaves out, propagation/round_trips.hpp).
#pragma once

#include <segpath/algorithms/segment_filtering.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace segpath::testing {

struct ExpectedPartners {
  std::vector<std::uint32_t> partner;  // per segment; no_cluster: none
  std::size_t camera = 0, light = 0;   // pairs of a camera successor, of a light predecessor
  std::size_t chained = 0;             // pairs with a chain (delta bounces) on either side
  bool one_predecessor = true;         // no parent has two light predecessors
};

/// A camera successor's partner is its parent (the junction successor -> parent is skipped), a
/// parent's is its light predecessor (parent -> predecessor is skipped).
template <class Pool>
ExpectedPartners expected_partners(const Pool& pool) {
  ExpectedPartners e;
  e.partner.assign(pool.size(), no_cluster);
  for (std::uint32_t i = 0; i < pool.size(); ++i) {
    const std::uint32_t t = pool.parent[i];
    if (t == filtering::no_parent) continue;
    if (pool.flags[i] & filtering::camera_born) {
      e.partner[i] = t;
      ++e.camera;
    } else {
      e.one_predecessor = e.one_predecessor && e.partner[t] == no_cluster;
      e.partner[t] = i;
      ++e.light;
    }
    e.chained += ((pool.flags[i] | pool.flags[t]) & filtering::chain_segment) ? 1 : 0;
  }
  return e;
}

/// Draws `filter`'s iteration-0 pool in `scene` and compares backtrack_partners with the oracle.
struct PartnersCheck {
  ExpectedPartners expected;
  bool same = false;  // backtrack_partners gave exactly expected.partner
};
template <class Filter, class Scene>
PartnersCheck check_backtrack_partners(const Filter& filter, const Scene& scene) {
  auto ctx = filter.context(scene, 0);
  filter.build_pool(ctx);
  std::vector<std::uint32_t> backtrack;
  filtering::backtrack_partners(ctx.pool, backtrack, SerialFor{});
  PartnersCheck c{expected_partners(ctx.pool)};
  c.same = backtrack == c.expected.partner;
  return c;
}

}  // namespace segpath::testing
