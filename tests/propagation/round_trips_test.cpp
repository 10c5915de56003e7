// The round trips' pair search (propagation/round_trips.hpp): over a support that names each
// segment's groups (Clustering) it finds, without an index of its own, the same pairs in the
// same order as the indexed search that any other single-start support gets.
#include <segpath/propagation/clustering.hpp>
#include <segpath/propagation/round_trips.hpp>

#include <array>
#include <cstdint>
#include <vector>

#include "support/catch.hpp"
#include "support/random_backtracks.hpp"

using namespace segpath;

namespace {

/// A Clustering seen as a support that does not name its segments' groups.
struct UnnamedGroups {
  using Scalar = double;
  static constexpr bool factorisable = false;
  static constexpr bool single_start = true;
  const Clustering<double>* clustering;
  [[nodiscard]] std::size_t group_count() const { return clustering->group_count(); }
  [[nodiscard]] std::size_t segment_count() const { return clustering->segment_count(); }
  [[nodiscard]] SlotRange ending_slots(std::size_t g) const { return clustering->ending_slots(g); }
  [[nodiscard]] SlotRange starting_slots(std::size_t g) const { return clustering->starting_slots(g); }
  [[nodiscard]] double kernel(std::size_t g) const { return clustering->kernel(g); }
  [[nodiscard]] auto ending_segments() const { return clustering->ending_segments(); }
  [[nodiscard]] auto starting_segments() const { return clustering->starting_segments(); }
  [[nodiscard]] std::uint32_t ending_slot_of(std::uint32_t s) const { return clustering->ending_slot_of(s); }
};
static_assert(JunctionSupport<UnnamedGroups> && !detail::NamesSegmentGroups<UnnamedGroups>);
static_assert(detail::NamesSegmentGroups<Clustering<double>>);

using Visit = std::array<std::uint32_t, 6>;  // g_a, i_a, j_b, g_b, i_b, j_a

}  // namespace

TEST_CASE("the round-trip search finds the same pairs, in the same order, with and without an index", "[propagation]") {
  Pcg32 rng(55, 3);
  std::size_t pairs = 0, refused_by_joins = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const std::size_t n = 4 + rng.next_u32() % 13;
    std::vector<Segment<double>> segments;
    auto point = [&] {
      if (rng.uniform<double>() < 0.08) return SurfacePoint<double>::at_point({0, 0, -5});  // no cluster
      return SurfacePoint<double>::on_surface({rng.uniform<double>() * 2, rng.uniform<double>() * 2, 0.5}, {0, 0, 1});
    };
    for (std::size_t i = 0; i < n; ++i) segments.push_back({point(), point()});
    Clustering<double> clustering;
    clustering.build(VoxelGrid<double>(1.0, Vec3<double>(rng.uniform<double>(), rng.uniform<double>(), 0.5)), segments);
    const std::vector<std::uint32_t> backtrack = trial % 8 == 0 ? std::vector<std::uint32_t>{} : testing::random_backtracks(rng, clustering, n);
    // Some junctions do not join (zero G w, a start read from its own slot).
    const std::uint64_t salt = rng.next_u32();
    auto joins = [&](std::uint32_t i, std::uint32_t j) { return (i * 7919u + j * 104729u + salt) % 5 != 0; };
    std::vector<Visit> named, indexed, unjoined;
    auto recorder = [](std::vector<Visit>& into) {
      return [&into](std::size_t ga, std::uint32_t ia, std::uint32_t jb, std::size_t gb, std::uint32_t ib, std::uint32_t ja) {
        into.push_back({std::uint32_t(ga), ia, jb, std::uint32_t(gb), ib, ja});
      };
    };
    const std::size_t named_bytes = detail::for_each_round_trip(clustering, backtrack, joins, recorder(named));
    const UnnamedGroups unnamed{&clustering};
    const std::size_t indexed_bytes = detail::for_each_round_trip(unnamed, backtrack, joins, recorder(indexed));
    CHECK(named == indexed);
    CHECK(named_bytes == 0);
    if (backtrack.empty()) CHECK(indexed_bytes == 0);
    else CHECK(indexed_bytes >= (std::size(clustering.ending_segments()) + n) * sizeof(std::uint32_t));
    // Every pair found is a true round trip: a ends where b starts and b ends where a starts,
    // both junctions join, and each pair comes once.
    for (const Visit& v : named) {
      const std::uint32_t a = clustering.ending_segments()[v[1]], b = clustering.ending_segments()[v[4]];
      CHECK(clustering.starting_segments()[v[2]] == b);
      CHECK(clustering.starting_segments()[v[5]] == a);
      CHECK(v[0] == clustering.cluster_of_y(a));
      CHECK(v[3] == clustering.cluster_of_y(b));
      CHECK((backtrack[a] == b || backtrack[b] == a));
      CHECK(joins(v[1], v[2]));
      CHECK(joins(v[4], v[5]));
    }
    pairs += named.size();
    detail::for_each_round_trip(clustering, backtrack, [](std::uint32_t, std::uint32_t) { return true; }, recorder(unjoined));
    refused_by_joins += unjoined.size() - named.size();
  }
  CHECK(pairs > 100);
  CHECK(refused_by_joins > 20);
}
