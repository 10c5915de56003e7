// The JunctionSupport concept (propagation/junction_support.hpp): both supports model it, a
// minimal user type (the archetype) is enough for both propagations, and a type that lacks or
// mistypes any one member is rejected by the detail:: requirement that names it. Then the slot
// views of Clustering and DiskJunctions, and the PairTable over them.
#include <segpath/propagation/clustering.hpp>
#include <segpath/propagation/disk_junctions.hpp>
#include <segpath/propagation/junction_support.hpp>
#include <segpath/propagation/pair_table.hpp>
#include <segpath/propagation/path_conditioned.hpp>
#include <segpath/propagation/propagate.hpp>
#include <segpath/testing/two_threads.hpp>

#include <cstdint>
#include <list>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

// ---------------------------------------------------------------------------------------
// The archetype: the documented members and nothing else, groups listed explicitly.

template <bool Factorisable, bool SingleStart = true>
struct ListSupport {
  using Scalar = double;
  static constexpr bool factorisable = Factorisable;
  static constexpr bool single_start = SingleStart;
  std::vector<SlotRange> ending, starting;  // per group
  std::vector<double> kernels;               // per group
  std::vector<std::uint32_t> ending_segment, starting_segment, slot_of;
  std::size_t segments = 0;

  [[nodiscard]] std::size_t group_count() const noexcept { return kernels.size(); }
  [[nodiscard]] std::size_t segment_count() const noexcept { return segments; }
  [[nodiscard]] SlotRange ending_slots(std::size_t g) const noexcept { return ending[g]; }
  [[nodiscard]] SlotRange starting_slots(std::size_t g) const noexcept { return starting[g]; }
  [[nodiscard]] double kernel(std::size_t g) const noexcept { return kernels[g]; }
  [[nodiscard]] const std::vector<std::uint32_t>& ending_segments() const noexcept { return ending_segment; }
  [[nodiscard]] const std::vector<std::uint32_t>& starting_segments() const noexcept { return starting_segment; }
  [[nodiscard]] std::uint32_t ending_slot_of(std::uint32_t s) const noexcept { return slot_of[s]; }
};

/// The archetype holding the same groups as `support`.
template <bool Factorisable, bool SingleStart, JunctionSupport J>
ListSupport<Factorisable, SingleStart> copy_of(const J& support) {
  ListSupport<Factorisable, SingleStart> list;
  for (std::size_t g = 0; g < support.group_count(); ++g) {
    list.ending.push_back(support.ending_slots(g));
    list.starting.push_back(support.starting_slots(g));
    list.kernels.push_back(support.kernel(g));
  }
  for (const std::uint32_t s : support.ending_segments()) list.ending_segment.push_back(s);
  for (const std::uint32_t s : support.starting_segments()) list.starting_segment.push_back(s);
  list.segments = support.segment_count();
  for (std::uint32_t s = 0; s < list.segments; ++s) list.slot_of.push_back(support.ending_slot_of(s));
  return list;
}

static_assert(JunctionSupport<Clustering<float>> && JunctionSupport<Clustering<double>>);
static_assert(JunctionSupport<DiskJunctions<float>> && JunctionSupport<DiskJunctions<double>>);
static_assert(Clustering<double>::factorisable && !DiskJunctions<double>::factorisable);
static_assert(Clustering<double>::single_start && !DiskJunctions<double>::single_start);
static_assert(JunctionSupport<ListSupport<false>> && JunctionSupport<ListSupport<true, false>>);
static_assert(!JunctionSupport<int> && !JunctionSupport<std::vector<std::uint32_t>>);

// ---------------------------------------------------------------------------------------
// Negative models: each leaves out or mistypes one member.

template <class... Parts>
struct Model : Parts... {};
struct Unrelated {};

template <class X>
struct ScalarIs {
  using Scalar = X;
};
struct Factorisable {
  static constexpr bool factorisable = false;
};
struct FactorisableNotConstant {
  static inline bool factorisable = false;
};
struct SingleStart {
  static constexpr bool single_start = true;
};
struct SingleStartUnrelated {
  static constexpr Unrelated single_start{};
};
struct Counts {
  std::size_t group_count() const noexcept;
  std::size_t segment_count() const noexcept;
};
struct NoSegmentCount {
  std::size_t group_count() const noexcept;
};
struct Slots {
  SlotRange ending_slots(std::size_t) const noexcept;
  SlotRange starting_slots(std::size_t) const noexcept;
};
struct NoStartingSlots {
  SlotRange ending_slots(std::size_t) const noexcept;
};
struct EndingSlotsMistyped {
  std::uint32_t ending_slots(std::size_t) const noexcept;
  SlotRange starting_slots(std::size_t) const noexcept;
};
struct Kernel {
  double kernel(std::size_t) const noexcept;
};
struct KernelUnrelated {
  Unrelated kernel(std::size_t) const noexcept;
};
struct Segments {
  std::span<const std::uint32_t> ending_segments() const noexcept;
  std::span<const std::uint32_t> starting_segments() const noexcept;
};
struct NoEndingSegments {
  std::span<const std::uint32_t> starting_segments() const noexcept;
};
struct StartingSegmentsList {  // not random access
  std::span<const std::uint32_t> ending_segments() const noexcept;
  const std::list<std::uint32_t>& starting_segments() const noexcept;
};
struct SlotOf {
  std::uint32_t ending_slot_of(std::uint32_t) const noexcept;
};
struct SlotOfUnrelated {
  Unrelated ending_slot_of(std::uint32_t) const noexcept;
};

template <class J>
constexpr int failures = !detail::HasSupportScalar<J> + !detail::HasFactorisable<J> + !detail::HasSingleStart<J> + !detail::HasGroups<J> +
                         !detail::HasGroupKernel<J> + !detail::HasSlotSegments<J> + !detail::HasEndingSlotOf<J>;

using Ok = Model<ScalarIs<double>, Factorisable, SingleStart, Counts, Slots, Kernel, Segments, SlotOf>;
static_assert(JunctionSupport<Ok> && failures<Ok> == 0);

using NoScalar = Model<Factorisable, SingleStart, Counts, Slots, Kernel, Segments, SlotOf>;
static_assert(!JunctionSupport<NoScalar> && !detail::HasSupportScalar<NoScalar> && !detail::HasGroupKernel<NoScalar>);
using IntScalar = Model<ScalarIs<int>, Factorisable, SingleStart, Counts, Slots, Kernel, Segments, SlotOf>;
static_assert(!JunctionSupport<IntScalar> && !detail::HasSupportScalar<IntScalar>);

using NoFactorisable = Model<ScalarIs<double>, SingleStart, Counts, Slots, Kernel, Segments, SlotOf>;
static_assert(!JunctionSupport<NoFactorisable> && !detail::HasFactorisable<NoFactorisable> && failures<NoFactorisable> == 1);
using RuntimeFactorisable = Model<ScalarIs<double>, FactorisableNotConstant, SingleStart, Counts, Slots, Kernel, Segments, SlotOf>;
static_assert(!JunctionSupport<RuntimeFactorisable> && !detail::HasFactorisable<RuntimeFactorisable> &&
              failures<RuntimeFactorisable> == 1);

using NoSingleStart = Model<ScalarIs<double>, Factorisable, Counts, Slots, Kernel, Segments, SlotOf>;
static_assert(!JunctionSupport<NoSingleStart> && !detail::HasSingleStart<NoSingleStart> && failures<NoSingleStart> == 1);
using SingleStartMistyped = Model<ScalarIs<double>, Factorisable, SingleStartUnrelated, Counts, Slots, Kernel, Segments, SlotOf>;
static_assert(!JunctionSupport<SingleStartMistyped> && !detail::HasSingleStart<SingleStartMistyped> &&
              failures<SingleStartMistyped> == 1);

using NoCounts = Model<ScalarIs<double>, Factorisable, SingleStart, NoSegmentCount, Slots, Kernel, Segments, SlotOf>;
static_assert(!JunctionSupport<NoCounts> && !detail::HasGroups<NoCounts> && failures<NoCounts> == 1);
using NoStarting = Model<ScalarIs<double>, Factorisable, SingleStart, Counts, NoStartingSlots, Kernel, Segments, SlotOf>;
static_assert(!JunctionSupport<NoStarting> && !detail::HasGroups<NoStarting> && failures<NoStarting> == 1);
using EndingMistyped = Model<ScalarIs<double>, Factorisable, SingleStart, Counts, EndingSlotsMistyped, Kernel, Segments, SlotOf>;
static_assert(!JunctionSupport<EndingMistyped> && !detail::HasGroups<EndingMistyped> && failures<EndingMistyped> == 1);

using NoKernel = Model<ScalarIs<double>, Factorisable, SingleStart, Counts, Slots, Segments, SlotOf>;
static_assert(!JunctionSupport<NoKernel> && !detail::HasGroupKernel<NoKernel> && failures<NoKernel> == 1);
using KernelMistyped = Model<ScalarIs<double>, Factorisable, SingleStart, Counts, Slots, KernelUnrelated, Segments, SlotOf>;
static_assert(!JunctionSupport<KernelMistyped> && !detail::HasGroupKernel<KernelMistyped> && failures<KernelMistyped> == 1);

using NoEnding = Model<ScalarIs<double>, Factorisable, SingleStart, Counts, Slots, Kernel, NoEndingSegments, SlotOf>;
static_assert(!JunctionSupport<NoEnding> && !detail::HasSlotSegments<NoEnding> && failures<NoEnding> == 1);
using ListStarting = Model<ScalarIs<double>, Factorisable, SingleStart, Counts, Slots, Kernel, StartingSegmentsList, SlotOf>;
static_assert(!JunctionSupport<ListStarting> && !detail::HasSlotSegments<ListStarting> && failures<ListStarting> == 1);

using NoSlotOf = Model<ScalarIs<double>, Factorisable, SingleStart, Counts, Slots, Kernel, Segments>;
static_assert(!JunctionSupport<NoSlotOf> && !detail::HasEndingSlotOf<NoSlotOf> && failures<NoSlotOf> == 1);
using SlotOfMistyped = Model<ScalarIs<double>, Factorisable, SingleStart, Counts, Slots, Kernel, Segments, SlotOfUnrelated>;
static_assert(!JunctionSupport<SlotOfMistyped> && !detail::HasEndingSlotOf<SlotOfMistyped> && failures<SlotOfMistyped> == 1);

// ---------------------------------------------------------------------------------------

std::vector<Segment<double>> random_segments(Pcg32& rng, std::size_t n) {
  auto point = [&] {
    if (rng.uniform<double>() < 0.08) return SurfacePoint<double>::at_point({0, 0, -5});
    return SurfacePoint<double>::on_surface({rng.uniform<double>() * 2, rng.uniform<double>() * 2, 0.5}, {0, 0, 1});
  };
  std::vector<Segment<double>> segments;
  for (std::size_t i = 0; i < n; ++i) segments.push_back({point(), point()});
  return segments;
}

/// The semantic requirements: slot ranges in group order, ending_slot_of inverts
/// ending_segments, every segment has at most one ending slot.
template <JunctionSupport J>
void check_slot_view(const J& support) {
  std::uint32_t next_ending = 0;
  std::vector<int> endings(support.segment_count(), 0);
  for (std::size_t g = 0; g < support.group_count(); ++g) {
    const SlotRange e = support.ending_slots(g);
    CHECK(e.begin == next_ending);
    next_ending = e.end;
    for (std::uint32_t i = e.begin; i < e.end; ++i) {
      const std::uint32_t s = support.ending_segments()[i];
      CHECK(support.ending_slot_of(s) == i);
      ++endings[s];
    }
    const SlotRange st = support.starting_slots(g);
    CHECK(st.end <= std::ranges::size(support.starting_segments()));
  }
  CHECK(next_ending == std::ranges::size(support.ending_segments()));
  for (std::uint32_t s = 0; s < support.segment_count(); ++s) {
    CHECK(endings[s] <= 1);
    if (endings[s] == 0) CHECK(support.ending_slot_of(s) == no_cluster);
  }
}

}  // namespace

TEST_CASE("Clustering and DiskJunctions present consistent slot views", "[propagation][concepts]") {
  Pcg32 rng(41, 3);
  for (int trial = 0; trial < 100; ++trial) {
    const auto segments = random_segments(rng, 4 + rng.next_u32() % 20);
    Clustering<double> clustering;
    clustering.build(VoxelGrid<double>(1.0), segments);
    check_slot_view(clustering);
    for (std::size_t c = 0; c < clustering.group_count(); ++c) {
      const Cluster<double>& cl = clustering.clusters()[c];
      CHECK(clustering.starting_slots(c) == SlotRange{cl.slot, cl.slot + cl.starting_count()});
      CHECK(clustering.ending_slots(c).size() == cl.ending_count());
      CHECK(clustering.kernel(c) == cl.kernel);
    }
    DiskJunctions<double> junctions;
    junctions.build(0.7, std::span<const Segment<double>>(segments));
    check_slot_view(junctions);
    CHECK(junctions.group_count() == segments.size());
    for (std::uint32_t s = 0; s < segments.size(); ++s) {
      // Group s: ending slot s, starting slots its neighbour list, in increasing id order.
      CHECK(junctions.ending_slots(s) == SlotRange{s, s + 1});
      const SlotRange st = junctions.starting_slots(s);
      const auto near = junctions.starting_near(s);
      REQUIRE(st.size() == near.size());
      for (std::uint32_t j = st.begin; j < st.end; ++j) CHECK(junctions.starting_segments()[j] == near[j - st.begin]);
      CHECK(junctions.kernel(s) == junctions.kernel());
    }
  }
}

TEST_CASE("both propagations run on the archetype and give the support's numbers bit for bit", "[propagation][concepts]") {
  Pcg32 rng(43, 5);
  for (int trial = 0; trial < 100; ++trial) {
    const std::size_t n = 4 + rng.next_u32() % 12;
    const auto segments = random_segments(rng, n);
    std::vector<double> emitted, geometry, density, light, light_technique, link(n * n), light_table(n * n);
    std::vector<std::uint32_t> terms;
    std::vector<std::uint8_t> flags;
    for (std::size_t i = 0; i < n; ++i) {
      emitted.push_back(rng.uniform<double>() < 0.5 ? 0.0 : rng.uniform<double>() * 3);
      geometry.push_back(rng.uniform<double>() < 0.1 ? 0.0 : rng.uniform<double>());
      density.push_back(0.5 + rng.uniform<double>());
      light.push_back(rng.uniform<double>() < 0.5 ? 0.0 : 0.4 * rng.uniform<double>());
      light_technique.push_back(light.back() * rng.uniform<double>());
      terms.push_back(light.back() > 0 ? 1 + rng.next_u32() % 3 : 0);
      flags.push_back(std::uint8_t(rng.next_u32() % 8));
    }
    for (auto& l : link) l = rng.uniform<double>() * 0.8;
    for (auto& q : light_table) q = rng.uniform<double>() < 0.3 ? 0.0 : rng.uniform<double>();
    auto link_of = [&](std::uint32_t s, std::uint32_t sp) { return link[s * n + sp]; };
    auto light_of = [&](std::uint32_t s, std::uint32_t sp) { return light_table[s * n + sp]; };
    const ConditionedInputs<double, decltype(link_of), decltype(light_of)> conditioned{
        emitted, geometry, density, light, terms, light_technique, flags, link_of, light_of};
    const int depth = 1 + int(rng.next_u32() % 4);
    // The archetype with the support's groups, its starts kept per slot or per segment.
    auto compare = [&]<bool SingleStart, class J>(const J& support) {
      const auto list = copy_of<J::factorisable, SingleStart>(support);
      std::vector<double> a, b, scratch;
      propagate(PropagationInputs<double, decltype(link_of), J>{support, emitted, geometry, link_of}, depth, a, scratch);
      propagate(PropagationInputs<double, decltype(link_of), decltype(list)>{list, emitted, geometry, link_of}, depth, b, scratch,
                segpath::testing::TwoThreadFor{});
      CHECK(a == b);
      propagate_conditioned(support, conditioned, depth, a);
      propagate_conditioned(list, conditioned, depth, b, segpath::testing::TwoThreadFor{}, {}, {}, 1u << 20);
      CHECK(a == b);
    };
    Clustering<double> clustering;
    clustering.build(VoxelGrid<double>(1.0), segments);
    compare.template operator()<true>(clustering);
    compare.template operator()<false>(clustering);
    DiskJunctions<double> junctions;
    junctions.build(0.7, std::span<const Segment<double>>(segments));
    compare.template operator()<true>(junctions);
    compare.template operator()<false>(junctions);
  }
}

TEST_CASE("a pair table holds the groups that fit its budget, in group order, and skips marked ones", "[propagation]") {
  ListSupport<true> support;
  // Groups of 2 x 3, 1 x 4, 2 x 1 and 3 x 3 pairs.
  support.ending = {{0, 2}, {2, 3}, {3, 5}, {5, 8}};
  support.starting = {{0, 3}, {3, 7}, {7, 8}, {8, 11}};
  support.kernels = {1, 1, 1, 1};
  support.ending_segment = {0, 1, 2, 3, 4, 5, 6, 7};
  support.starting_segment = {0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2};
  support.slot_of = {0, 1, 2, 3, 4, 5, 6, 7};
  support.segments = 8;
  auto pair = [](std::size_t g, std::uint32_t i, std::uint32_t j) { return int(1000 * g + 10 * i + j); };
  PairTable<int> table;
  table.build(support, 0, {}, pair);
  CHECK(table.size() == 0);
  CHECK(table.find(0, 0) == nullptr);
  // 6 + 4 pairs fit 11 ints; then neither 2 (12 > 11) nor 9 does.
  table.build(support, 11 * sizeof(int), {}, pair);
  CHECK(table.size() == 10);
  REQUIRE(table.find(1, 2) != nullptr);
  CHECK(*table.find(1, 2) == 12);
  CHECK(*table.find(2, 6) == 1026);
  CHECK(table.row(2, 3)[1] == 1024);
  CHECK(table.find(3, 7) == nullptr);
  CHECK(table.find(5, 8) == nullptr);
  // Skipping the first group leaves room for the next ones: 4 + 2 + 9 > 11, so 4 + 2.
  const std::vector<std::uint8_t> skip{1, 0, 0, 0};
  table.build(support, 11 * sizeof(int), skip, pair, segpath::testing::TwoThreadFor{});
  CHECK(table.size() == 6);
  CHECK(table.find(0, 0) == nullptr);
  CHECK(*table.find(4, 7) == 2047);
  CHECK(table.value_bytes() == 6 * sizeof(int));
}

TEST_CASE("a pair table holds its values in blocks of whole groups, found across every block", "[propagation]") {
  // Groups of 1000 x 600 pairs fill blocks of block_bytes (1 Mi ints) one at a time; one of
  // 1100 x 1000 pairs is larger than a block and has one of its own.
  constexpr std::uint32_t per_block = PairTable<int>::block_bytes / sizeof(int);
  const std::vector<std::pair<std::uint32_t, std::uint32_t>> shape{{1000, 600}, {1000, 600}, {1100, 1000}, {1000, 600}, {3, 2}};
  ListSupport<true> support;
  std::uint32_t ends = 0, starts = 0;
  for (const auto& [e, st] : shape) {
    support.ending.push_back({ends, ends + e});
    support.starting.push_back({starts, starts + st});
    support.kernels.push_back(1);
    ends += e, starts += st;
  }
  REQUIRE(std::size_t(1100) * 1000 > per_block);
  REQUIRE(std::size_t(2) * 1000 * 600 > per_block);
  for (std::uint32_t i = 0; i < ends; ++i) support.ending_segment.push_back(i), support.slot_of.push_back(i);
  for (std::uint32_t j = 0; j < starts; ++j) support.starting_segment.push_back(j % ends);
  support.segments = ends;
  auto pair = [](std::size_t g, std::uint32_t i, std::uint32_t j) { return int(g << 28 | std::size_t(i) << 12 | j); };
  PairTable<int> table;
  table.build(support, std::size_t(1) << 30, {}, pair, segpath::testing::TwoThreadFor{});
  // [600k], [600k], [1.1M], [600k + 6]: the last group joins the block before it.
  CHECK(table.block_count() == 4);
  std::size_t pairs = 0, wrong = 0;
  for (std::size_t g = 0; g < shape.size(); ++g)
    for (std::uint32_t i = support.ending[g].begin; i < support.ending[g].end; ++i) {
      const int* row = table.row(i, support.starting[g].begin);
      for (std::uint32_t j = support.starting[g].begin; j < support.starting[g].end; ++j, ++pairs) {
        const int* found = table.find(i, j);
        wrong += found == nullptr || *found != pair(g, i, j) || found != row + (j - support.starting[g].begin);
      }
    }
  CHECK(pairs == table.size());
  CHECK(wrong == 0);
}
