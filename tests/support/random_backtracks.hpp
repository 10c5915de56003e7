// Random backtrack partners for the propagation tests (PropagationInputs::backtrack,
// ConditionedInputs::backtrack): the round trips propagation/round_trips.hpp takes out.
#pragma once

#include <segpath/propagation/clustering.hpp>
#include <segpath/propagation/junction_support.hpp>
#include <segpath/core/rng.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace segpath::testing {

/// Per segment s of n, a partner: most often a segment joined both ways with s (a start near
/// y_s near whose y s starts), so that chains can go round trips between them; sometimes a
/// start near y_s only, a segment anywhere (no round trip), none, or each other's partner.
/// `near(s)` gives the segments starting near y_s; s itself may be among them (a partner of
/// its own is never a round trip).
template <class Near>
std::vector<std::uint32_t> random_backtracks(Pcg32& rng, const Near& near, std::size_t n) {
  std::vector<std::uint32_t> backtrack(n, no_cluster);
  for (std::uint32_t s = 0; s < n; ++s) {
    const double u = rng.uniform<double>();
    std::vector<std::uint32_t> both;
    for (const std::uint32_t b : near(s))
      if (std::ranges::count(near(b), s) > 0) both.push_back(b);
    const auto& starts = near(s);
    if (u < 0.6 && !both.empty()) backtrack[s] = both[rng.next_u32() % both.size()];
    else if (u < 0.7 && !starts.empty()) backtrack[s] = starts[rng.next_u32() % starts.size()];
    else if (u < 0.8) backtrack[s] = rng.next_u32() % std::uint32_t(n);
    if (backtrack[s] < n && rng.uniform<double>() < 0.2) backtrack[backtrack[s]] = s;  // each other's
  }
  return backtrack;
}

/// The same over a clustering: the segments starting in the cluster where s ends.
template <class T>
std::vector<std::uint32_t> random_backtracks(Pcg32& rng, const Clustering<T>& clustering, std::size_t n) {
  auto near = [&](std::uint32_t s) -> std::vector<std::uint32_t> {
    const std::uint32_t c = clustering.cluster_of_y(s);
    if (c == no_cluster) return {};
    std::vector<std::uint32_t> starts;
    for (const std::uint32_t sp : clustering.starting_segments(c))
      if (sp != s) starts.push_back(sp);
    return starts;
  };
  return random_backtracks(rng, near, n);
}

}  // namespace segpath::testing
