// The path-conditioned propagation equals a naive enumeration of every chain with the
// conditioned weight of propagation/path_conditioned.hpp written out per chain, on random small
// pools over voxel clusters and disks, and does not depend on the number of threads.
#include <segpath/propagation/path_conditioned.hpp>
#include <segpath/testing/two_threads.hpp>

#include <algorithm>
#include <cstring>
#include <limits>
#include <functional>
#include <thread>
#include <vector>

#include "support/catch.hpp"
#include "support/random_backtracks.hpp"

using namespace segpath;

namespace {

struct RandomSides {
  std::vector<Segment<double>> segments;
  std::vector<double> emitted, geometry, density, light, light_technique;
  std::vector<std::uint32_t> terms;
  std::vector<std::uint8_t> flags;
  std::vector<double> link_table, light_table;  // per ordered pair
  std::vector<double> bridge_target_term, bridge_density;  // empty: no bridges
  std::vector<std::uint32_t> backtrack;  // empty: none
  std::size_t n = 0;
  [[nodiscard]] double link(std::uint32_t s, std::uint32_t sp) const { return link_table[s * n + sp]; }
  [[nodiscard]] double light_pair(std::uint32_t s, std::uint32_t sp) const { return light_table[s * n + sp]; }
  /// The propagation inputs over these tables.
  [[nodiscard]] auto inputs() const {
    auto by_link = [this](std::uint32_t s, std::uint32_t sp) { return link(s, sp); };
    auto by_light_pair = [this](std::uint32_t s, std::uint32_t sp) { return light_pair(s, sp); };
    return ConditionedInputs<double, decltype(by_link), decltype(by_light_pair)>{
        emitted, geometry, density, light, terms, light_technique, flags, by_link, by_light_pair, {}, bridge_target_term, bridge_density,
        backtrack};
  }
  /// Backtrack partners (ConditionedInputs::backtrack) over `near`, the starts near y_s.
  template <class Near>
  void add_backtracks(Pcg32& rng, const Near& near) { backtrack = testing::random_backtracks(rng, near, n); }
  /// Whether s and s' are backtrack partners (either way round).
  [[nodiscard]] bool partners(std::uint32_t s, std::uint32_t sp) const {
    return !backtrack.empty() && s != sp && (backtrack[s] == sp || backtrack[sp] == s);
  }
  /// Bridges: some segments not light-born are bridge-born; the targets are the light technique
  /// samples, so B(s) is q_b(s) times the targets among the starts near y_s (`near`, as the
  /// renderer counts them). A bridge-born s keeps no other density beyond D_l sometimes, so G can
  /// be 0 when its successor is its only target.
  template <class Near>
  void add_bridges(Pcg32& rng, const Near& near) {
    bridge_target_term.assign(n, 0.0);
    bridge_density.assign(n, 0.0);
    for (std::uint32_t s = 0; s < n; ++s) {
      if (!(flags[s] & conditioned_light_born) && rng.uniform<double>() < 0.5) flags[s] |= conditioned_bridge_born;
      if (rng.uniform<double>() < 0.2) continue;  // a segment no bridge can draw
      std::uint32_t targets = 0;
      for (const std::uint32_t u : near(s)) targets += (flags[u] & conditioned_light_technique) ? 1 : 0;
      bridge_target_term[s] = 0.1 + rng.uniform<double>();
      bridge_density[s] = bridge_target_term[s] * double(targets);
      if ((flags[s] & conditioned_bridge_born) && targets > 0 && rng.uniform<double>() < 0.3) density[s] = light[s];
      density[s] += bridge_density[s];
    }
  }
};

/// Random sides and densities; D_l(s) sums the light technique samples among `near(s)` (the
/// segments a light technique could draw s from) as the algorithm does.
RandomSides make_sides(Pcg32& rng) {
  RandomSides p;
  p.n = 4 + rng.next_u32() % 9;
  auto point = [&] {
    if (rng.uniform<double>() < 0.06) return SurfacePoint<double>::at_point({0, 0, -5});
    return SurfacePoint<double>::on_surface({rng.uniform<double>() * 1.6, rng.uniform<double>() * 1.6, 0.5}, {0, 0, 1});
  };
  for (std::size_t i = 0; i < p.n; ++i) {
    p.segments.push_back({point(), point()});
    p.emitted.push_back(rng.uniform<double>() < 0.4 ? 0.0 : rng.uniform<double>() * 3);
    p.geometry.push_back(rng.uniform<double>() < 0.08 ? 0.0 : 0.2 + rng.uniform<double>());
    std::uint8_t f = 0;
    if (rng.uniform<double>() < 0.5) f |= conditioned_light_born;
    if (rng.uniform<double>() < 0.75) f |= conditioned_potential;
    if ((f & conditioned_light_born) && (f & conditioned_potential) && rng.uniform<double>() < 0.7) f |= conditioned_light_technique;
    p.flags.push_back(f);
  }
  p.link_table.resize(p.n * p.n);
  p.light_table.resize(p.n * p.n);
  for (auto& l : p.link_table) l = rng.uniform<double>() * 0.8;
  for (auto& q : p.light_table) q = rng.uniform<double>() < 0.3 ? 0.0 : rng.uniform<double>() * 2;
  return p;
}

template <class Near>
void finish_densities(RandomSides& p, Pcg32& rng, const Near& near) {
  p.density.assign(p.n, 0);
  p.light.assign(p.n, 0);
  p.light_technique.assign(p.n, 0);
  p.terms.assign(p.n, 0);
  for (std::uint32_t s = 0; s < p.n; ++s) {
    if (rng.uniform<double>() < 0.4) {  // a light-start term
      const double d = 0.1 + rng.uniform<double>();
      p.light[s] += d, p.terms[s] += 1;
      if (rng.uniform<double>() < 0.7) p.light_technique[s] += d;
    }
    for (const std::uint32_t u : near(s)) {
      if (!(p.flags[u] & conditioned_light_technique) || !(p.light_pair(s, u) > 0)) continue;
      p.light[s] += p.light_pair(s, u), p.terms[s] += 1;
      if (rng.uniform<double>() < 0.7) p.light_technique[s] += p.light_pair(s, u);
    }
    // The rest of D (camera side): zero for some light-born segments.
    const bool no_rest = (p.flags[s] & conditioned_light_born) && rng.uniform<double>() < 0.4;
    p.density[s] = p.light[s] + (no_rest ? 0.0 : 0.05 + rng.uniform<double>());
  }
}

/// The conditioned weight of one chain, written out (header comment of path_conditioned.hpp),
/// bridges included: where s_{a+1} is a bridge target (a light technique sample), G(s_a) leaves
/// its term q_b out of the bridge density B, and a bridge-born s_a weighs B' / (G B).
double chain_weight(const RandomSides& p, const std::vector<std::uint32_t>& chain) {
  const std::size_t k = chain.size();
  auto ql = [&](std::size_t a) {  // q_l(s_a | s_{a+1}), 0 unless s_{a+1} is a potential light technique
    return (p.flags[chain[a + 1]] & conditioned_potential) ? p.light_pair(chain[a], chain[a + 1]) : 0.0;
  };
  auto other_terms = [&](std::size_t a) {  // positive terms of D_l(s_a) without s_{a+1}
    const bool excluded = (p.flags[chain[a + 1]] & conditioned_light_technique) && ql(a) > 0;
    return p.terms[chain[a]] - (excluded ? 1u : 0u);
  };
  std::vector<bool> e(k);
  e[k - 1] = p.light[chain[k - 1]] > 0;
  for (std::size_t a = k - 1; a-- > 0;) e[a] = other_terms(a) > 0 || (ql(a) > 0 && e[a + 1]);
  double w = 1;
  for (std::size_t a = 0; a < k; ++a) {
    const std::uint32_t s = chain[a];
    const bool light_born = p.flags[s] & conditioned_light_born;
    if (a > 0 && (p.flags[chain[a - 1]] & conditioned_light_born) && other_terms(a - 1) == 0) {
      w *= light_born && (p.flags[s] & conditioned_light_technique) && p.light_technique[s] > 0 ? 1 / p.light_technique[s] : 0.0;
    } else if (a == k - 1) {
      w *= p.density[s] > 0 ? 1 / p.density[s] : 0.0;
    } else {
      const bool excluded = (p.flags[chain[a + 1]] & conditioned_light_technique) && ql(a) > 0;
      const double light_other = other_terms(a) > 0 ? std::max(0.0, p.light[s] - (excluded ? ql(a) : 0.0)) : 0.0;
      const double lambda = light_other > 0 ? light_other : ql(a);
      const double target_term = p.bridge_target_term.empty() ? 0.0 : p.bridge_target_term[s];
      const bool target_next = (p.flags[chain[a + 1]] & conditioned_light_technique) && target_term > 0;
      const double rest = std::max(0.0, std::max(0.0, p.density[s] - p.light[s]) - (target_next ? target_term : 0.0));
      const double g = rest + (e[a] ? lambda : 0.0);
      const bool bridge_born = p.flags[s] & conditioned_bridge_born;
      const double own = target_next && bridge_born && p.bridge_density[s] > 0
                             ? 1 - std::min(1.0, target_term / p.bridge_density[s])
                             : 1.0;
      if (light_born) w *= e[a] && g > 0 && p.light[s] > 0 ? lambda / (g * p.light[s]) : 0.0;
      else w *= g > 0 ? own / g : 0.0;
    }
  }
  return w;
}

/// Sum over every chain of at most depth + 1 segments starting with s of
/// prod (K f_r G) L_e(last) x chain_weight.
/// With `pieces`, a segment s' stands for pieces[s'] segments and chains are limited to depth
/// + 1 of those (propagation/segment_budget.hpp).
template <class Near, class Kernel>
double naive(const RandomSides& p, std::uint32_t s, int depth, const Near& near, const Kernel& kernel,
             const std::vector<std::uint16_t>& pieces = {}) {
  const auto pieces_of = [&](std::uint32_t sp) { return pieces.empty() ? 1 : int(pieces[sp]); };
  std::vector<std::uint32_t> chain{s};
  // A chain never goes a -> b -> a between partners (ConditionedInputs::backtrack).
  const auto round_trip = [&](std::uint32_t sp) {
    return chain.size() >= 2 && chain[chain.size() - 2] == sp && p.partners(chain.back(), sp);
  };
  std::function<double(double, int)> walk = [&](double throughput, int left) -> double {
    double sum = throughput * p.emitted[chain.back()] * chain_weight(p, chain);
    const std::uint32_t last = chain.back();
    for (const std::uint32_t sp : near(last)) {
      if (!(p.geometry[sp] > 0) || left - pieces_of(sp) < 0 || round_trip(sp)) continue;
      chain.push_back(sp);
      sum += walk(throughput * p.link(last, sp) * kernel(last) * p.geometry[sp], left - pieces_of(sp));
      chain.pop_back();
    }
    return sum;
  };
  const int left = depth + 1 - pieces_of(s);
  return left < 0 ? 0.0 : walk(1.0, left);
}

/// The supports of a random pool and, per segment s, the starts it joins (never itself) and
/// its kernel: disks of radius 0.6, or voxels of 0.8 on a randomly shifted grid.
struct Neighbourhoods {
  Clustering<double> clustering;
  DiskJunctions<double> junctions;
  std::vector<std::vector<std::uint32_t>> near;
  std::vector<double> kernel;
  int self_joined = 0;  ///< segments whose two ends share a cluster
};

Neighbourhoods neighbourhoods(const RandomSides& p, bool disk, Pcg32& rng) {
  Neighbourhoods h{{}, {}, std::vector<std::vector<std::uint32_t>>(p.n), std::vector<double>(p.n, 0), 0};
  if (disk) {
    h.junctions.build(0.6, p.segments);
    for (std::uint32_t s = 0; s < p.n; ++s) {
      const auto span = h.junctions.starting_near(s);
      h.near[s].assign(span.begin(), span.end());
      h.kernel[s] = h.junctions.kernel();
    }
    return h;
  }
  h.clustering.build(VoxelGrid<double>(0.8, Vec3<double>(rng.uniform<double>(), rng.uniform<double>(), 0.5)), p.segments);
  for (std::uint32_t s = 0; s < p.n; ++s) {
    const std::uint32_t c = h.clustering.cluster_of_y(s);
    if (c == no_cluster) continue;
    const Cluster<double>& cl = h.clustering.clusters()[c];
    for (const std::uint32_t sp : h.clustering.starting_segments(c))
      if (sp != s) h.near[s].push_back(sp);  // never itself
    h.self_joined += h.clustering.cluster_of_x(s) == c;
    h.kernel[s] = cl.kernel;
  }
  return h;
}

}  // namespace

TEST_CASE("path-conditioned propagation equals the naive chain enumeration on 400 random pools, with bridges too",
          "[propagation]") {
  Pcg32 rng(2026, 11);
  int compared = 0, nontrivial = 0, forced_light = 0, self_joined = 0, bridged = 0, backtracked = 0;
  for (int trial = 0; trial < 400; ++trial) {
    RandomSides p = make_sides(rng);
    const bool disk = trial % 2 == 1;
    Neighbourhoods hood = neighbourhoods(p, disk, rng);
    const Clustering<double>& clustering = hood.clustering;
    const DiskJunctions<double>& junctions = hood.junctions;
    const auto& near = hood.near;
    const auto& kernel = hood.kernel;
    self_joined += hood.self_joined;
    auto near_of = [&](std::uint32_t s) -> const std::vector<std::uint32_t>& { return near[s]; };
    finish_densities(p, rng, near_of);
    if (trial % 4 >= 2) p.add_bridges(rng, near_of);  // on both supports
    if (trial % 8 >= 4) p.add_backtracks(rng, near_of);  // on both supports, with and without bridges
    RandomSides without_bridges = p;  // the same densities, the bridge terms of the weight left out
    without_bridges.bridge_target_term.clear();
    without_bridges.bridge_density.clear();
    const auto inputs = p.inputs();
    const int depth = 1 + int(rng.next_u32() % 4);
    std::vector<double> result, threaded;
    if (disk) {
      propagate_conditioned(junctions, inputs, depth, result);
      propagate_conditioned(junctions, inputs, depth, threaded, segpath::testing::TwoThreadFor{});
      // The order of the sums: per segment, its neighbours in increasing id order; bit for
      // bit, with or without a junction table.
      std::vector<ConditionedValues<double>> current(p.n), next(p.n);
      for (std::uint32_t s = 0; s < p.n; ++s) current[s] = detail::conditioned_emission(inputs, s);
      for (int k = 0; k < depth; ++k, std::swap(current, next))
        for (std::uint32_t s = 0; s < p.n; ++s) {
          next[s] = detail::conditioned_emission(inputs, s);
          for (const std::uint32_t sp : junctions.starting_near(s)) {
            if (!(p.geometry[sp] > 0)) continue;
            const double ql = (p.flags[sp] & conditioned_potential) ? p.light_pair(s, sp) : 0.0;
            const auto j = detail::conditioned_coefficients(detail::conditioned_end(inputs, s), p.flags[sp],
                                                            detail::conditioned_forced_weight(inputs, sp),
                                                            p.link(s, sp) * (junctions.kernel() * p.geometry[sp]), ql,
                                                            detail::conditioned_bridge_end(inputs, s));
            detail::apply_junction(j, detail::read_successor(j.code, current[sp].u, current[sp].w), next[s]);
          }
        }
      std::vector<double> tabled;
      const ConditionedMemory memory = propagate_conditioned(junctions, inputs, depth, tabled, SerialFor{}, {}, {}, std::size_t(1) << 30);
      CHECK(memory.junction_table == junctions.junction_count() * sizeof(detail::ConditionedJunction<double>));
      CHECK(memory.lagged == 0);  // no chains
      for (std::uint32_t s = 0; s < p.n; ++s) {
        if (p.backtrack.empty()) CHECK(result[s] == current[s].w[0] + current[s].w[1]);  // (no round trips to take out)
        CHECK(tabled[s] == result[s]);
      }
    } else {
      propagate_conditioned(clustering, inputs, depth, result);
      propagate_conditioned(clustering, inputs, depth, threaded, segpath::testing::TwoThreadFor{});
    }
    if (!disk) {
      // The slot forms of link and light_pair are called with the slots of s and s'.
      struct SlotLink {
        const RandomSides& p;
        const Clustering<double>& clustering;
        int* wrong;
        std::size_t* calls;
        double operator()(std::uint32_t s, std::uint32_t sp, std::uint32_t i, std::uint32_t j) const {
          *wrong += clustering.ending_segments()[i] != s || clustering.starting_segments()[j] != sp;
          ++*calls;
          return p.link(s, sp);
        }
      };
      struct SlotLightPair {
        const RandomSides& p;
        const Clustering<double>& clustering;
        int* wrong;
        double operator()(std::uint32_t s, std::uint32_t sp) const { return p.light_pair(s, sp); }
        double operator()(std::uint32_t s, std::uint32_t sp, std::uint32_t i, std::uint32_t j) const {
          *wrong += clustering.ending_segments()[i] != s || clustering.starting_segments()[j] != sp;
          return p.light_pair(s, sp);
        }
      };
      int wrong = 0;
      std::size_t calls = 0;
      const ConditionedInputs<double, SlotLink, SlotLightPair> slot_inputs{
          p.emitted, p.geometry, p.density, p.light, p.terms, p.light_technique, p.flags, SlotLink{p, clustering, &wrong, &calls},
          SlotLightPair{p, clustering, &wrong}, {}, p.bridge_target_term, p.bridge_density, p.backtrack};
      // The junctions a sweep evaluates: pairs of a cluster with a start of positive G.
      std::size_t junctions_per_sweep = 0;
      for (const Cluster<double>& cl : clustering.clusters())
        for (std::uint32_t j = cl.slot; j < cl.slot + cl.starting_count(); ++j)
          if (const std::uint32_t sp = clustering.starting_segments()[j]; p.geometry[sp] > 0)
            junctions_per_sweep += cl.ending_count() - (clustering.cluster_of_y(sp) == clustering.cluster_of_x(sp) ? 1 : 0);
      // Each round trip's two junctions are built once more (its correction's).
      std::size_t round_trip_junctions = 0;
      for (std::uint32_t a = 0; a < p.n && !p.backtrack.empty(); ++a) {
        const std::uint32_t b = p.backtrack[a];
        const auto joined = [&](std::uint32_t x, std::uint32_t y) { return std::ranges::count(near[x], y) > 0 && p.geometry[y] > 0; };
        if (b < p.n && b != a && !(p.backtrack[b] == a && b < a) && joined(a, b) && joined(b, a)) round_trip_junctions += 2;
      }
      std::vector<double> by_slot;
      CHECK(propagate_conditioned(clustering, slot_inputs, depth, by_slot).junction_table == 0);  // no table by default
      CHECK(calls == junctions_per_sweep * std::size_t(depth) + round_trip_junctions);
      CHECK(wrong == 0);
      CHECK(by_slot == result);
      // A junction table, whole and partial (the first clusters only), gives the same numbers.
      for (const std::size_t budget : {std::size_t(1) << 30, std::size_t(256)}) {
        std::vector<double> tabled;
        calls = 0;
        const std::size_t bytes = propagate_conditioned(clustering, slot_inputs, depth, tabled, SerialFor{}, {}, {}, budget).junction_table;
        CHECK(bytes <= budget);
        if (budget > bytes + (std::size_t(1) << 20)) CHECK(calls == junctions_per_sweep + round_trip_junctions);  // whole: once per junction
        else CHECK(calls <= junctions_per_sweep * std::size_t(depth) + round_trip_junctions);
        CHECK(wrong == 0);
        CHECK(tabled == result);
      }
    }
    for (std::uint32_t s = 0; s < p.n; ++s) {
      const double reference = naive(p, s, depth, near_of, [&](std::uint32_t t) { return kernel[t]; });
      bridged += reference != naive(without_bridges, s, depth, near_of, [&](std::uint32_t t) { return kernel[t]; });
      CHECK(result[s] == Approx(reference).epsilon(1e-12).margin(1e-300));
      CHECK(threaded[s] == result[s]);
      ++compared;
      const double own = p.density[s] > 0 ? p.emitted[s] / p.density[s] : 0.0;
      if (reference != own) ++nontrivial;
      for (const std::uint32_t sp : near[s]) {
        backtracked += p.partners(s, sp) && p.geometry[sp] > 0 && p.geometry[s] > 0 && std::ranges::count(near[sp], s) > 0;
        forced_light += (p.flags[s] & conditioned_light_born) && (p.flags[sp] & conditioned_light_technique) &&
                        p.terms[s] == 1 && p.light_pair(s, sp) > 0 && p.geometry[sp] > 0;
      }
    }
  }
  CHECK(compared > 2000);
  CHECK(nontrivial > compared / 4);
  CHECK(forced_light > 50);  // the forced branch is exercised
  CHECK(self_joined > 100);   // segments with both ends in one cluster, which must not join themselves
  CHECK(bridged > 100);  // segments whose value the bridge terms change
  CHECK(backtracked > 100);  // junctions of round trips, which chains may not go
}

TEST_CASE("path-conditioned propagation rejects inputs of different sizes", "[propagation]") {
  std::vector<Segment<double>> segments(2, Segment<double>{SurfacePoint<double>::on_surface({0, 0, 0}, {0, 0, 1}),
                                                           SurfacePoint<double>::on_surface({0.1, 0, 0}, {0, 0, 1})});
  Clustering<double> clustering;
  clustering.build(VoxelGrid<double>(1.0), segments);
  std::vector<double> two(2, 1.0), one(1, 1.0);
  std::vector<std::uint32_t> terms(2, 1);
  std::vector<std::uint8_t> flags(2, 0);
  auto link = [](std::uint32_t, std::uint32_t) { return 0.5; };
  auto light_pair = [](std::uint32_t, std::uint32_t) { return 0.0; };
  using Inputs = ConditionedInputs<double, decltype(link), decltype(light_pair)>;
  std::vector<double> out;
  const Inputs bad{two, two, two, one, terms, two, flags, link, light_pair};
  CHECK_THROWS_AS(propagate_conditioned(clustering, bad, 2, out), std::invalid_argument);
  const Inputs good{two, two, two, two, terms, two, flags, link, light_pair};
  CHECK_THROWS_AS(propagate_conditioned(clustering, good, 0, out), std::invalid_argument);
  CHECK_NOTHROW(propagate_conditioned(clustering, good, 2, out));
  // Bridges: one target term and one density per segment, or none.
  const Inputs short_bridges{two, two, two, two, terms, two, flags, link, light_pair, {}, one, one};
  CHECK_THROWS_AS(propagate_conditioned(clustering, short_bridges, 2, out), std::invalid_argument);
  const Inputs unpaired{two, two, two, two, terms, two, flags, link, light_pair, {}, two, {}};
  CHECK_THROWS_AS(propagate_conditioned(clustering, unpaired, 2, out), std::invalid_argument);
  const Inputs bridges{two, two, two, two, terms, two, flags, link, light_pair, {}, two, two};
  CHECK_NOTHROW(propagate_conditioned(clustering, bridges, 2, out));
}

TEST_CASE("path-conditioned propagation: factorised clusters give the general sum", "[propagation]") {
  Pcg32 rng(2026, 12);
  int factorised_clusters = 0, self_joined = 0;  // self_joined: both ends in one factorised cluster
  int backtracked = 0;  // round-trip junctions from factorised clusters
  for (int trial = 0; trial < 300; ++trial) {
    RandomSides p = make_sides(rng);
    Clustering<double> clustering;
    clustering.build(VoxelGrid<double>(0.8, Vec3<double>(rng.uniform<double>(), rng.uniform<double>(), 0.5)), p.segments);
    // Every other cluster factorises: link(s, s') = diffuse[s], q_l(s | s') = a constant of s.
    std::vector<std::uint8_t> factorised(clustering.clusters().size(), 0);
    std::vector<double> diffuse(p.n), light_of(p.n);
    for (std::size_t c = 0; c < factorised.size(); ++c) factorised[c] = (c + std::size_t(trial)) % 2;
    std::vector<std::vector<std::uint32_t>> near(p.n);
    for (std::uint32_t s = 0; s < p.n; ++s) {
      diffuse[s] = 0.2 + rng.uniform<double>() * 0.5;
      light_of[s] = rng.uniform<double>() < 0.2 ? 0.0 : rng.uniform<double>();
      const std::uint32_t c = clustering.cluster_of_y(s);
      if (c == no_cluster) continue;
      for (const std::uint32_t sp : clustering.starting_segments(c))
        if (sp != s) near[s].push_back(sp);
      self_joined += factorised[c] && clustering.cluster_of_x(s) == c;
      if (!factorised[c]) continue;
      for (const std::uint32_t sp : clustering.starting_segments(c)) {  // every start, s itself too (the contract)
        p.link_table[s * p.n + sp] = diffuse[s];
        p.light_table[s * p.n + sp] = light_of[s];
      }
      factorised_clusters += s == clustering.ending_segments(c).front();
    }
    const auto near_of = [&](std::uint32_t s) -> const std::vector<std::uint32_t>& { return near[s]; };
    finish_densities(p, rng, near_of);
    if (trial % 2 == 1) p.add_bridges(rng, near_of);
    if (trial % 3 != 0) p.add_backtracks(rng, near_of);
    for (std::uint32_t s = 0; s < p.n; ++s)
      if (const std::uint32_t c = clustering.cluster_of_y(s); c != no_cluster && factorised[c])
        backtracked += std::ranges::count_if(near[s], [&](std::uint32_t sp) {
          return p.partners(s, sp) && p.geometry[sp] > 0 && p.geometry[s] > 0 && std::ranges::count(near[sp], s) > 0;
        });
    const auto inputs = p.inputs();
    const int depth = 1 + int(rng.next_u32() % 4);
    std::vector<double> general, fast;
    propagate_conditioned(clustering, inputs, depth, general);
    propagate_conditioned(clustering, inputs, depth, fast, SerialFor{}, std::span<const std::uint8_t>(factorised),
                          std::span<const double>(diffuse));
    for (std::uint32_t s = 0; s < p.n; ++s) CHECK(fast[s] == Approx(general[s]).epsilon(1e-12).margin(1e-300));
  }
  CHECK(factorised_clusters > 300);
  CHECK(self_joined > 100);  // the sums without a segment's own start are exercised
  CHECK(backtracked > 100);  // and their round trips taken out
}

TEST_CASE("path-conditioned propagation counts a chain's pieces as segments", "[propagation]") {
  Pcg32 rng(2026, 12);
  int compared = 0, cut = 0, backtracked = 0;
  for (int trial = 0; trial < 300; ++trial) {
    RandomSides p = make_sides(rng);
    const bool disk = trial % 2 == 1;
    const Neighbourhoods hood = neighbourhoods(p, disk, rng);
    const auto& near = hood.near;
    const auto& kernel = hood.kernel;
    auto near_of = [&](std::uint32_t s) -> const std::vector<std::uint32_t>& { return near[s]; };
    finish_densities(p, rng, near_of);
    std::vector<std::uint16_t> pieces(p.n);
    for (auto& q : pieces) q = std::uint16_t(rng.uniform<double>() < 0.6 ? 1 : 2 + rng.next_u32() % 3);
    // Round trips through a chain: the part taken out is the one at the budget it was read at.
    if (trial % 4 >= 2) p.add_backtracks(rng, near_of);
    auto inputs = p.inputs();
    inputs.pieces = pieces;
    const int depth = 1 + int(rng.next_u32() % 4);
    std::vector<double> result;
    ConditionedMemory memory;
    std::size_t start_records = 0;
    if (disk) {
      memory = propagate_conditioned(hood.junctions, inputs, depth, result);
      start_records = p.n;
    } else {
      memory = propagate_conditioned(hood.clustering, inputs, depth, result);
      start_records = std::size(hood.clustering.starting_segments());
    }
    CHECK(memory.junction_table == 0);
    // U is kept only for the starts a junction can force (light technique samples with
    // D_lt > 0) and for their ending slots, plus one shared zero in each list; each such start
    // also keeps its source's U index (4 bytes, plus one unused).
    std::size_t forced_starts = 0, forced_slots = 0;
    // The lagged values it reports: W in one ring of p values per ending slot of a chain of
    // p > 1, U in one more for each forced start of p > 1 that reads a slot, each ring with its
    // watch (10 bytes, twice with the growth of its lists), and a watch index per start record
    // and per forced start (plus one).
    std::size_t ring_values = 0, watches = 0;
    for (std::uint32_t s = 0; s < p.n; ++s) {
      const bool starts = disk || (hood.clustering.cluster_of_x(s) != no_cluster);
      const bool ends = (disk ? hood.junctions.ending_slot_of(s) : hood.clustering.ending_slot_of(s)) != no_cluster;
      const bool chain = pieces[s] > 1;
      ring_values += ends && chain ? pieces[s] : 0;
      watches += ends && chain;
      if (!((p.flags[s] & conditioned_light_born) && (p.flags[s] & conditioned_light_technique) && p.light_technique[s] > 0)) continue;
      forced_starts += starts ? 1 : 0;
      forced_slots += starts && ends ? 1 : 0;
      ring_values += starts && ends && chain ? pieces[s] : 0;
      watches += starts && ends && chain;
    }
    const std::size_t rings =
        ring_values * sizeof(std::array<double, 2>) + (std::ranges::max(pieces) > 1 ? (start_records + forced_starts + 1) * 4 : 0);
    CHECK(memory.lagged >= rings + watches * 10);
    CHECK(memory.lagged <= rings + watches * 20);
    CHECK(memory.forced_values == (forced_starts + forced_slots + 2) * sizeof(std::array<double, 2>) + (forced_starts + 1) * 4);
    // The round trips' peak: none without partners; over disks at least the search's index (each
    // ending slot's group); over voxels, whose clusters name each segment's groups, no index of
    // the search's own: the entries and parts only, where round trips change values (below).
    const std::size_t ending_slots = disk ? std::size(hood.junctions.ending_segments()) : std::size(hood.clustering.ending_segments());
    if (p.backtrack.empty()) CHECK(memory.round_trips == 0);
    else if (disk) CHECK(memory.round_trips >= ending_slots * 4);
    RandomSides with_trips = p;
    with_trips.backtrack.clear();
    int trial_backtracked = 0;
    for (std::uint32_t s = 0; s < p.n; ++s) {
      const double reference = naive(p, s, depth, near_of, [&](std::uint32_t q) { return kernel[q]; }, pieces);
      CHECK(result[s] == Approx(reference).epsilon(1e-10).margin(1e-12));
      ++compared;
      cut += reference != naive(p, s, depth, near_of, [&](std::uint32_t q) { return kernel[q]; });
      trial_backtracked += !p.backtrack.empty() && reference != naive(with_trips, s, depth, near_of, [&](std::uint32_t q) { return kernel[q]; }, pieces);
    }
    backtracked += trial_backtracked;
    if (!disk && trial_backtracked > 0) CHECK(memory.round_trips > 0);
  }
  CHECK(compared > 1500);
  CHECK(cut > 300);
  CHECK(backtracked > 10);  // round trips, through chains too, change values
}

TEST_CASE("the compact emission of a slot is conditioned_emission bit for bit, at zero, denormal, infinite and NaN densities",
          "[propagation]") {
  using T = float;
  using S = Rgb<float>;
  const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
  const std::vector<T> densities = {0.f, -0.f, 1.f, 1e-40f, 1e-45f, 3e38f, inf, nan, -1.f, 1e-38f};
  const std::vector<T> emissions = {0.f, 1.f, 1e30f, inf, nan};
  std::size_t differ = 0;
  for (const T d : densities)
    for (const T dl : densities)
      for (const T e : emissions) {
        const std::vector<S> emitted{S(e)};
        const std::vector<T> geometry{1}, density{d}, light_density{dl}, technique_density{0};
        const std::vector<std::uint32_t> terms{0};
        const std::vector<std::uint8_t> flags{0};
        auto link = [](std::uint32_t, std::uint32_t) { return S(0.f); };
        auto light_pair = [](std::uint32_t, std::uint32_t) { return T(0); };
        const ConditionedInputs<S, decltype(link), decltype(light_pair)> in{
            emitted, geometry, density, light_density, terms, technique_density, flags, link, light_pair};
        const ConditionedValues<S> full = detail::conditioned_emission(in, 0), compact = detail::compact_emission(in, 0).values();
        differ += std::memcmp(&full, &compact, sizeof full) != 0 ? 1 : 0;
      }
  CHECK(differ == 0);
}
