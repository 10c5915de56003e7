// Propagation (Algorithm 1) equals the naive recursive MMIS estimator (N39) on random small
// pools, with and without round trips between backtrack partners, and the factorised clusters
// give the same numbers as the general sum.
#include <segpath/estimators/recursive_mmis.hpp>
#include <segpath/propagation/propagate.hpp>

#include <algorithm>
#include <vector>

#include "support/catch.hpp"
#include "support/random_backtracks.hpp"

using namespace segpath;

namespace {

/// A random pool: segment ends scattered over a few voxels so that clusters hold several
/// starting and ending segments; some ends are off the manifold (no cluster).
struct RandomPool {
  std::vector<Segment<double>> segments;
  std::vector<double> emitted, weighted_geometry, diffuse;
  std::vector<double> link_table;  // link(s, s') for every pair
  std::size_t n = 0;
};

RandomPool make_pool(Pcg32& rng) {
  RandomPool pool;
  pool.n = 4 + rng.next_u32() % 9;
  auto point = [&] {
    if (rng.uniform<double>() < 0.08) return SurfacePoint<double>::at_point({0, 0, -5});
    return SurfacePoint<double>::on_surface({rng.uniform<double>() * 2, rng.uniform<double>() * 2, 0.5}, {0, 0, 1});
  };
  for (std::size_t i = 0; i < pool.n; ++i) {
    pool.segments.push_back({point(), point()});
    pool.emitted.push_back(rng.uniform<double>() < 0.5 ? 0.0 : rng.uniform<double>() * 3);
    pool.weighted_geometry.push_back(rng.uniform<double>() < 0.1 ? 0.0 : rng.uniform<double>());
    pool.diffuse.push_back(0.1 + rng.uniform<double>());
  }
  pool.link_table.resize(pool.n * pool.n);
  for (auto& l : pool.link_table) l = rng.uniform<double>() * 0.8;
  return pool;
}

}  // namespace

TEST_CASE("propagation equals the naive recursive MMIS estimator on 1000 random pools", "[propagation][estimators]") {
  Pcg32 rng(2025, 6);
  int compared = 0, nontrivial = 0, self_joined = 0, backtracked = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    const RandomPool pool = make_pool(rng);
    Clustering<double> clustering;
    clustering.build(VoxelGrid<double>(1.0, Vec3<double>(rng.uniform<double>(), rng.uniform<double>(), 0.5)),
                     pool.segments);
    auto link = [&](std::uint32_t s, std::uint32_t sp) { return pool.link_table[s * pool.n + sp]; };
    const std::vector<std::uint32_t> backtrack =
        trial % 2 ? testing::random_backtracks(rng, clustering, pool.n) : std::vector<std::uint32_t>{};
    const PropagationInputs<double, decltype(link)> inputs{clustering, pool.emitted, pool.weighted_geometry, link, {}, {}, {},
                                                           backtrack};
    const int depth = 1 + int(rng.next_u32() % 5);
    std::vector<double> radiance, scratch;
    propagate(inputs, depth, radiance, scratch);
    for (std::uint32_t s = 0; s < pool.n; ++s) {
      const double reference =
          recursive_mmis_radiance<double>(clustering, pool.emitted, pool.weighted_geometry, link, s, depth, backtrack);
      CHECK(radiance[s] == Approx(reference).epsilon(1e-12).margin(1e-300));
      ++compared;
      if (reference != pool.emitted[s]) ++nontrivial;
      if (reference != recursive_mmis_radiance<double>(clustering, pool.emitted, pool.weighted_geometry, link, s, depth)) ++backtracked;
      self_joined += clustering.cluster_of_y(s) != no_cluster && clustering.cluster_of_y(s) == clustering.cluster_of_x(s);
    }
  }
  // The pools must exercise the recursion, not only L_e, segments with both ends in one
  // cluster (which must not join themselves) and round trips (which must be left out).
  CHECK(nontrivial > compared / 4);
  CHECK(self_joined > 100);
  CHECK(backtracked > 300);
}

TEST_CASE("a segment never joins itself, general or factorised", "[propagation]") {
  // One short segment, both ends in one voxel, with a self-junction gain K f_r G w = 100 x 1 x 1
  // (a glossy peak at a short segment's two ends): were it joined to itself, k sweeps would
  // raise L to about 100^k. Its companion t starts there too and is joined.
  const auto at = [](double x) { return SurfacePoint<double>::on_surface({x, 0.5, 0.5}, {0, 0, 1}); };
  const std::vector<Segment<double>> segments{{at(0.2), at(0.3)}, {at(0.4), at(5.5)}};
  const std::vector<double> emitted{1.0, 2.0}, weighted_geometry{1.0, 0.5}, diffuse{1.0, 1.0};
  Clustering<double> clustering;
  clustering.build(VoxelGrid<double>(1.0), segments);
  REQUIRE(clustering.cluster_of_x(0) == clustering.cluster_of_y(0));
  const double kernel = clustering.clusters()[clustering.cluster_of_y(0)].kernel;
  auto link = [&](std::uint32_t, std::uint32_t) { return 100.0 / kernel; };
  const std::vector<std::uint8_t> factorised(clustering.clusters().size(), 1);
  auto diffuse_link = [&](std::uint32_t s, std::uint32_t) { return diffuse[s]; };
  const PropagationInputs<double, decltype(link)> general{clustering, emitted, weighted_geometry, link};
  const std::vector<double> scaled{100.0 / kernel, 100.0 / kernel};
  const PropagationInputs<double, decltype(diffuse_link)> fast{clustering, emitted, weighted_geometry, diffuse_link, scaled,
                                                                factorised};
  for (const int k : {1, 5}) {
    std::vector<double> a, b, scratch;
    propagate(general, k, a, scratch);
    propagate(fast, k, b, scratch);
    const double expected = 1.0 + 100.0 * 0.5 * 2.0;  // L_e(s) + gain(s -> t) L_e(t), t ends outside
    CHECK(a[0] == Approx(expected));
    CHECK(b[0] == Approx(expected));
    CHECK(recursive_mmis_radiance<double>(clustering, emitted, weighted_geometry, link, 0, k) == Approx(expected));
  }
}

TEST_CASE("a chain goes no round trip with the segment that drew it, general or factorised", "[propagation]") {
  // a ends where b starts and b ends where a starts (a light path's segment and the predecessor
  // it drew that came back to its voxel), each junction of gain K f_r G w = 100 x 1 x 0.5 = 50
  // (a glossy lobe's peak): were a -> b -> a chains summed, k sweeps would raise L to about
  // 2500^(k / 2). a's other successor t ends outside and carries L_e = 2.
  const auto at = [](double x, double z) { return SurfacePoint<double>::on_surface({x, 0.5, z}, {0, 0, 1}); };
  const std::vector<Segment<double>> segments{{at(0.2, 0.5), at(0.3, 3.5)}, {at(0.4, 3.5), at(0.5, 0.5)}, {at(0.6, 3.5), at(7.5, 0.5)}};
  const std::vector<double> emitted{1.0, 1.0, 2.0}, weighted_geometry{0.5, 0.5, 0.5};
  const std::vector<std::uint32_t> backtrack{1, no_cluster, no_cluster};  // b drew from a (or a from b)
  Clustering<double> clustering;
  clustering.build(VoxelGrid<double>(1.0), segments);
  REQUIRE(clustering.cluster_of_y(0) == clustering.cluster_of_x(1));
  REQUIRE(clustering.cluster_of_y(1) == clustering.cluster_of_x(0));
  const double kernel = clustering.clusters()[clustering.cluster_of_y(0)].kernel;
  auto link = [&](std::uint32_t, std::uint32_t) { return 100.0 / kernel; };
  const std::vector<std::uint8_t> factorised(clustering.clusters().size(), 1);
  const std::vector<double> scaled(3, 100.0 / kernel);
  for (const int k : {1, 2, 5, 9}) {
    std::vector<double> general, fast, partners, scratch;
    propagate(PropagationInputs<double, decltype(link)>{clustering, emitted, weighted_geometry, link, {}, {}, {}, backtrack}, k, general,
              scratch);
    propagate(PropagationInputs<double, decltype(link)>{clustering, emitted, weighted_geometry, link, scaled, factorised, {}, backtrack},
              k, fast, scratch);
    // Either partner may name the other.
    propagate(PropagationInputs<double, decltype(link)>{clustering, emitted, weighted_geometry, link, {}, {}, {},
                                                        std::vector<std::uint32_t>{no_cluster, 0, no_cluster}},
              k, partners, scratch);
    // a -> b ends there (b's one successor is a), a -> t ends at t; b -> a goes on to t only.
    const double a = 1.0 + 50.0 * 1.0 + 50.0 * 2.0;
    const double b = 1.0 + 50.0 * (1.0 + (k >= 2 ? 50.0 * 2.0 : 0.0));
    for (const auto* r : {&general, &fast, &partners}) {
      CHECK((*r)[0] == Approx(a));
      CHECK((*r)[1] == Approx(b));
      CHECK((*r)[2] == 2.0);
    }
    CHECK(recursive_mmis_radiance<double>(clustering, emitted, weighted_geometry, link, 0, k, backtrack) == Approx(a));
    CHECK(recursive_mmis_radiance<double>(clustering, emitted, weighted_geometry, link, 1, k, backtrack) == Approx(b));
  }
}

namespace {

/// In factorised clusters the link depends on the ending segment only: diffuse[s].
auto factorised_link(const RandomPool& pool, const Clustering<double>& clustering, const std::vector<std::uint8_t>& factorised) {
  return [&pool, &clustering, &factorised](std::uint32_t s, std::uint32_t sp) {
    const std::uint32_t c = clustering.cluster_of_y(s);
    return c != no_cluster && factorised[c] ? pool.diffuse[s] : pool.link_table[s * pool.n + sp];
  };
}

}  // namespace

TEST_CASE("factorised clusters give the same radiance as the general O(n m) sum", "[propagation]") {
  Pcg32 rng(77, 6);
  for (int trial = 0; trial < 300; ++trial) {
    const RandomPool pool = make_pool(rng);
    Clustering<double> clustering;
    clustering.build(VoxelGrid<double>(1.0), pool.segments);
    std::vector<std::uint8_t> factorised(clustering.clusters().size());
    for (auto& f : factorised) f = rng.uniform<double>() < 0.6 ? 1 : 0;
    const auto link = factorised_link(pool, clustering, factorised);
    const PropagationInputs<double, decltype(link)> general{clustering, pool.emitted, pool.weighted_geometry, link};
    const PropagationInputs<double, decltype(link)> fast{clustering, pool.emitted, pool.weighted_geometry, link,
                                                         pool.diffuse, factorised};
    std::vector<double> a, b, scratch;
    propagate(general, 4, a, scratch);
    propagate(fast, 4, b, scratch);
    for (std::size_t s = 0; s < pool.n; ++s) CHECK(b[s] == Approx(a[s]).epsilon(1e-12).margin(1e-300));
  }
}

TEST_CASE("a link by slots gives the same radiance, and a prepared workspace can be reused", "[propagation]") {
  // The slot form of the link reads per-slot copies; the same numbers, bit for bit.
  Pcg32 rng(5, 6);
  int nontrivial = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const RandomPool pool = make_pool(rng);
    Clustering<double> clustering;
    clustering.build(VoxelGrid<double>(1.0), pool.segments);
    std::vector<std::uint8_t> factorised(clustering.clusters().size());
    for (auto& f : factorised) f = rng.uniform<double>() < 0.3 ? 1 : 0;
    const auto link = factorised_link(pool, clustering, factorised);
    const PropagationInputs<double, decltype(link)> by_id{clustering, pool.emitted, pool.weighted_geometry, link,
                                                          pool.diffuse, factorised};
    std::vector<double> a, scratch;
    propagate(by_id, 4, a, scratch);

    std::vector<double> ending_diffuse(clustering.ending_slot_count());
    for (std::size_t i = 0; i < ending_diffuse.size(); ++i) ending_diffuse[i] = pool.diffuse[clustering.ending_segments()[i]];
    auto slot_link = [&](std::uint32_t s, std::uint32_t, std::uint32_t i, std::uint32_t j) {
      const std::uint32_t c = clustering.cluster_of_y(s);
      return factorised[c] ? ending_diffuse[i] : pool.link_table[s * pool.n + clustering.starting_segments()[j]];
    };
    const PropagationInputs<double, decltype(slot_link)> by_slot{clustering, pool.emitted, pool.weighted_geometry, slot_link,
                                                                 pool.diffuse, factorised};
    std::vector<double> b, c;
    PropagationWorkspace<double> workspace;
    propagate(by_slot, 4, b, workspace);
    propagate_prepared(by_slot, 2, c, workspace);  // fewer iterations on the same preparation
    propagate_prepared(by_slot, 4, c, workspace);
    for (std::uint32_t s = 0; s < pool.n; ++s) {
      CHECK(b[s] == a[s]);
      CHECK(c[s] == a[s]);
      if (a[s] != pool.emitted[s]) ++nontrivial;
    }
  }
  CHECK(nontrivial > 300);
}

TEST_CASE("propagation rejects bad input", "[propagation]") {
  Clustering<double> clustering;
  std::vector<Segment<double>> none;
  clustering.build(VoxelGrid<double>(1.0), none);
  auto link = [](std::uint32_t, std::uint32_t) { return 1.0; };
  std::vector<double> emitted{1.0}, wg;
  const PropagationInputs<double, decltype(link)> inputs{clustering, emitted, wg, link};
  std::vector<double> r, s;
  CHECK_THROWS_AS(propagate(inputs, 1, r, s), std::invalid_argument);
  const PropagationInputs<double, decltype(link)> ok{clustering, emitted, emitted, link};
  CHECK_THROWS_AS(propagate(ok, 0, r, s), std::invalid_argument);
  propagate(ok, 3, r, s);  // a segment in no cluster keeps its emitted radiance
  CHECK(r[0] == 1.0);
  // Backtrack partners: one per segment or none.
  const std::vector<std::uint32_t> two_partners{no_cluster, no_cluster};
  const PropagationInputs<double, decltype(link)> mismatched{clustering, emitted, emitted, link, {}, {}, {}, two_partners};
  CHECK_THROWS_AS(propagate(mismatched, 1, r, s), std::invalid_argument);

  // A workspace prepared for other inputs (or none) is rejected.
  Pcg32 rng(3, 1);
  RandomPool pool;
  while (pool.n == 0 || clustering.starting_slot_count() == 0) {
    pool = make_pool(rng);
    clustering.build(VoxelGrid<double>(1.0), pool.segments);
  }
  std::vector<std::uint8_t> factorised(clustering.clusters().size(), 1);
  const PropagationInputs<double, decltype(link)> plain{clustering, pool.emitted, pool.weighted_geometry, link};
  const PropagationInputs<double, decltype(link)> fast{clustering, pool.emitted, pool.weighted_geometry, link, pool.diffuse,
                                                       factorised};
  PropagationWorkspace<double> workspace;
  CHECK_THROWS_AS(propagate_prepared(plain, 1, r, workspace), std::invalid_argument);
  prepare_propagation(fast, workspace);
  CHECK_THROWS_AS(propagate_prepared(plain, 1, r, workspace), std::invalid_argument);
  CHECK_NOTHROW(propagate_prepared(fast, 1, r, workspace));
}

namespace {

/// The recursion of recursive_mmis_radiance with a budget of segments left after s: a start
/// s' of p(s') pieces joins only if they fit (propagation/segment_budget.hpp); s was reached
/// from `from` (no_cluster: none), and no chain goes back to it where the two are partners.
double budgeted_radiance(const Clustering<double>& clustering, const RandomPool& pool, const std::vector<std::uint16_t>& pieces,
                         const std::vector<std::uint32_t>& backtrack, std::uint32_t s, int budget, std::uint32_t from = no_cluster) {
  double value = pool.emitted[s];
  const std::uint32_t c = clustering.cluster_of_y(s);
  if (c == no_cluster) return value;
  const Cluster<double>& cluster = clustering.clusters()[c];
  const bool partners = from != no_cluster && !backtrack.empty() && (backtrack[s] == from || backtrack[from] == s);
  double sum = 0;
  for (const std::uint32_t sp : clustering.starting_segments(c)) {
    if (sp == s || budget - int(pieces[sp]) < 0 || (partners && sp == from)) continue;
    sum += pool.link_table[s * pool.n + sp] * pool.weighted_geometry[sp] *
           budgeted_radiance(clustering, pool, pieces, backtrack, sp, budget - pieces[sp], s);
  }
  return value + sum * cluster.kernel;
}

}  // namespace

TEST_CASE("chains of several pieces count as that many segments, general or factorised", "[propagation]") {
  Pcg32 rng(77, 2);
  int compared = 0, cut = 0, backtracked = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const RandomPool pool = make_pool(rng);
    std::vector<std::uint16_t> pieces(pool.n);
    for (auto& p : pieces) p = std::uint16_t(rng.uniform<double>() < 0.6 ? 1 : 2 + rng.next_u32() % 3);
    Clustering<double> clustering;
    clustering.build(VoxelGrid<double>(1.0, Vec3<double>(rng.uniform<double>(), rng.uniform<double>(), 0.5)), pool.segments);
    // Round trips with chains: the part taken out is the one at the budget the start was read at.
    const std::vector<std::uint32_t> backtrack =
        trial % 2 ? testing::random_backtracks(rng, clustering, pool.n) : std::vector<std::uint32_t>{};
    auto link = [&](std::uint32_t s, std::uint32_t sp) { return pool.link_table[s * pool.n + sp]; };
    auto diffuse_link = [&](std::uint32_t s, std::uint32_t) { return pool.diffuse[s]; };
    const std::vector<std::uint8_t> all(clustering.group_count(), 1);
    const int iterations = 1 + int(rng.next_u32() % 5);
    std::vector<double> radiance, factorised, scratch;
    PropagationWorkspace<double> workspace;
    propagate(PropagationInputs<double, decltype(link)>{clustering, pool.emitted, pool.weighted_geometry, link, {}, {}, pieces,
                                                        backtrack},
              iterations, radiance, workspace);
    // The lagged values it reports: at least one ring of p per ending slot of a chain of p > 1
    // and a watch per start and ending slot; none without chains.
    std::size_t ring_values = 0;
    for (const std::uint32_t s : clustering.ending_segments()) ring_values += pieces[s] > 1 ? pieces[s] : 0;
    if (ring_values > 0)
      CHECK(workspace.lagged_bytes >= ring_values * sizeof(double) +
                                          (clustering.ending_segments().size() + clustering.starting_segments().size()) * 4);
    // The round trips' peak it reports: none without partners (and on voxels the search holds
    // no index of its own); checked below against the values round trips change.
    const std::size_t round_trip_bytes = workspace.round_trip_bytes;
    if (backtrack.empty()) CHECK(round_trip_bytes == 0);
    std::vector<double> unchained;
    propagate(PropagationInputs<double, decltype(link)>{clustering, pool.emitted, pool.weighted_geometry, link, {}, {}, {}}, iterations,
              unchained, workspace);
    CHECK(workspace.lagged_bytes == 0);
    CHECK(workspace.round_trip_bytes == 0);
    propagate(PropagationInputs<double, decltype(diffuse_link)>{clustering, pool.emitted, pool.weighted_geometry, diffuse_link,
                                                                pool.diffuse, all, pieces, backtrack},
              iterations, factorised, scratch);
    RandomPool diffuse_pool = pool;
    for (std::size_t s = 0; s < pool.n; ++s)
      for (std::size_t sp = 0; sp < pool.n; ++sp) diffuse_pool.link_table[s * pool.n + sp] = pool.diffuse[s];
    int trial_backtracked = 0;
    for (std::uint32_t s = 0; s < pool.n; ++s) {
      // Paths of at most iterations + 1 segments, s's own pieces included.
      const int budget = iterations + 1 - int(pieces[s]);
      const double reference = budget < 0 ? 0.0 : budgeted_radiance(clustering, pool, pieces, backtrack, s, budget);
      const double reference_diffuse = budget < 0 ? 0.0 : budgeted_radiance(clustering, diffuse_pool, pieces, backtrack, s, budget);
      if (budget >= 0 && reference != budgeted_radiance(clustering, pool, pieces, {}, s, budget)) ++trial_backtracked;
      CHECK(radiance[s] == Approx(reference).epsilon(1e-12).margin(1e-300));
      CHECK(factorised[s] == Approx(reference_diffuse).epsilon(1e-12).margin(1e-300));
      ++compared;
      if (budget >= 0 && reference != recursive_mmis_radiance<double>(clustering, pool.emitted, pool.weighted_geometry, link, s,
                                                                       iterations))
        ++cut;
    }
    backtracked += trial_backtracked;
    // Where round trips change values, their entries and parts are reported.
    if (trial_backtracked > 0) CHECK(round_trip_bytes > 0);
  }
  CHECK(compared > 2000);
  CHECK(cut > 300);  // the budget changes many values: chains are not counted as one segment
  CHECK(backtracked > 50);
}
