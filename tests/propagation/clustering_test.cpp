// Clusters as runs of equal voxel keys (the voxel kernel itself: tests/kernels/voxel_test.cpp).
#include <segpath/propagation/clustering.hpp>
#include <segpath/testing/two_threads.hpp>

#include <algorithm>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <thread>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

/// A random pool: positions in offset + [-extent, extent]^3 with any of the six normal bins, a
/// fraction of non-surface ends, and a fraction of ends copied from earlier segments (equal keys).
template <Real T>
std::vector<Segment<T>> random_pool(std::size_t n, T offset, T extent, double non_surface, double duplicate,
                                    std::uint64_t seed) {
  Pcg32 rng(seed, 3);
  std::vector<Segment<T>> segments;
  auto point = [&]() -> SurfacePoint<T> {
    if (rng.uniform<double>() < non_surface)
      return rng.uniform<double>() < 0.5 ? SurfacePoint<T>::at_point({0, 0, 0}) : SurfacePoint<T>::at_infinity({0, 0, 1});
    if (!segments.empty() && rng.uniform<double>() < duplicate) {
      const Segment<T>& s = segments[std::min(segments.size() - 1, std::size_t(rng.uniform<double>() * double(segments.size())))];
      return rng.uniform<double>() < 0.5 ? s.x : s.y;
    }
    auto coordinate = [&] { return offset + extent * (T(2) * rng.uniform<T>() - T(1)); };
    Vec3<T> normal(0);
    normal[int(rng.uniform<double>() * 3) % 3] = rng.uniform<double>() < 0.5 ? T(1) : T(-1);
    return SurfacePoint<T>::on_surface({coordinate(), coordinate(), coordinate()}, normal);
  };
  for (std::size_t i = 0; i < n; ++i) {
    const SurfacePoint<T> x = point();
    segments.push_back({x, point()});
  }
  return segments;
}

/// The refs written out: every valid key, std::sort by (key, end, segment).
template <Real T>
std::vector<EndpointRef> reference_refs(const VoxelGrid<T>& grid, const std::vector<Segment<T>>& segments) {
  std::vector<EndpointRef> refs;
  for (std::uint32_t i = 0; i < segments.size(); ++i) {
    if (const auto k = grid.key(segments[i].x); k.valid) refs.push_back({k.key, i, 0});
    if (const auto k = grid.key(segments[i].y); k.valid) refs.push_back({k.key, i, 1});
  }
  std::sort(refs.begin(), refs.end());
  return refs;
}

/// Clusters of a and b that differ in their ref ranges, first slot or kernel (bit for bit).
template <Real T>
std::size_t cluster_mismatches(const Clustering<T>& a, const Clustering<T>& b) {
  REQUIRE(a.clusters().size() == b.clusters().size());
  std::size_t mismatches = 0;
  for (std::size_t c = 0; c < a.clusters().size(); ++c) {
    const Cluster<T>&p = a.clusters()[c], &q = b.clusters()[c];
    mismatches += !(p.begin == q.begin && p.middle == q.middle && p.end == q.end && p.slot == q.slot && p.kernel == q.kernel);
  }
  return mismatches;
}

/// Everything a clustering exposes, compared exactly (kernels bit for bit).
template <Real T>
void check_same(const Clustering<T>& a, const Clustering<T>& b, std::size_t segments) {
  REQUIRE(a.refs().size() == b.refs().size());
  std::size_t ref_mismatches = 0;
  for (std::size_t r = 0; r < a.refs().size(); ++r) {
    const EndpointRef &p = a.refs()[r], &q = b.refs()[r];
    ref_mismatches += !(p.key == q.key && p.segment == q.segment && p.end == q.end);
  }
  CHECK(ref_mismatches == 0);
  CHECK(cluster_mismatches(a, b) == 0);
  CHECK(std::ranges::equal(a.starting_segments(), b.starting_segments()));
  CHECK(std::ranges::equal(a.ending_segments(), b.ending_segments()));
  std::size_t segment_mismatches = 0;
  for (std::uint32_t s = 0; s < segments; ++s)
    segment_mismatches += !(a.cluster_of_x(s) == b.cluster_of_x(s) && a.cluster_of_y(s) == b.cluster_of_y(s) &&
                            a.ending_slot_of(s) == b.ending_slot_of(s));
  CHECK(segment_mismatches == 0);
}

}  // namespace

TEMPLATE_TEST_CASE("clusters are exactly the runs of equal endpoint keys", "[propagation]", float, double) {
  using T = TestType;
  Pcg32 rng(9, 1);
  std::vector<Segment<T>> segments;
  for (int i = 0; i < 3000; ++i) {
    auto point = [&] {
      const Vec3<T> n = rng.uniform<T>() < T(0.5) ? Vec3<T>(0, 0, 1) : Vec3<T>(0, 1, 0);
      return SurfacePoint<T>::on_surface({rng.uniform<T>() * 3, rng.uniform<T>() * 3, rng.uniform<T>() * 3}, n);
    };
    segments.push_back({point(), point()});
  }
  segments.push_back({SurfacePoint<T>::at_point({1, 1, 1}), segments[0].y});  // a sensor end joins no cluster
  const auto grid = VoxelGrid<T>::jittered(T(0.7), 1, 1);
  Clustering<T> clustering;
  clustering.keep_refs(true);
  clustering.build(grid, segments);

  // Reference: group endpoints by key with a map.
  std::map<VoxelKey, std::pair<int, int>> expected;  // key -> (starting, ending)
  for (const auto& s : segments) {
    if (auto k = grid.key(s.x); k.valid) ++expected[k.key].first;
    if (auto k = grid.key(s.y); k.valid) ++expected[k.key].second;
  }
  REQUIRE(clustering.clusters().size() == expected.size());
  std::size_t total = 0;
  for (const auto& c : clustering.clusters()) {
    const VoxelKey key = clustering.refs()[c.begin].key;
    CHECK(int(c.starting_count()) == expected[key].first);
    CHECK(int(c.ending_count()) == expected[key].second);
    CHECK(c.kernel > T(0));
    for (std::uint32_t r = c.begin; r < c.end; ++r) CHECK(clustering.refs()[r].key == key);
    total += c.end - c.begin;
  }
  CHECK(total == clustering.refs().size());
  const auto last = static_cast<std::uint32_t>(segments.size() - 1);
  CHECK(clustering.cluster_of_x(last) == no_cluster);
  CHECK(clustering.cluster_of_y(last) == clustering.cluster_of_y(0));
  // An axis-aligned normal in the cell: the kernel is 1 / h^2 up to the mean-normal tilt.
  CHECK(clustering.bytes_per_segment() > 0);
}

TEMPLATE_TEST_CASE("a surface end beyond the grid's 32-bit cells is refused, not left out of every cluster",
                   "[propagation]", float, double) {
  // At voxel size 1e-9 a point at x = 2 lies 2e9 cells out (the keys stop at 2^30): it joined
  // no cluster, so the chains through it were lost and BDPF and MVF rendered box 1 dark (direct
  // light only at 1e-30) without a word. Sensor and infinite ends join no cluster by design.
  using T = TestType;
  const SurfacePoint<T> near = SurfacePoint<T>::on_surface({T(0.5), T(0.5), T(0.5)}, {0, 0, 1});
  const SurfacePoint<T> far = SurfacePoint<T>::on_surface({T(2), T(0.5), T(0.5)}, {0, 0, 1});
  const std::vector<Segment<T>> fine = {{SurfacePoint<T>::at_point({0, 0, 0}), near},
                                        {near, SurfacePoint<T>::at_infinity({0, 0, 1})}};
  Clustering<T> clustering;
  CHECK_NOTHROW(clustering.build(VoxelGrid<T>(T(1e-9)), std::span<const Segment<T>>(fine)));
  const std::vector<Segment<T>> beyond = {{near, far}};
  CHECK_THROWS_WITH(clustering.build(VoxelGrid<T>(T(1e-9)), std::span<const Segment<T>>(beyond)),
                    Catch::Contains("1 segment ends lie more than 2^30 voxels from the origin at voxel size 1e-09"));
  CHECK_NOTHROW(clustering.build(VoxelGrid<T>(T(1e-8)), std::span<const Segment<T>>(beyond)));
}

TEMPLATE_TEST_CASE("slots number each end's refs in cluster order", "[propagation]", float, double) {
  using T = TestType;
  Pcg32 rng(31, 4);
  std::vector<Segment<T>> segments;
  for (int i = 0; i < 2000; ++i) {
    auto point = [&] {
      if (rng.uniform<T>() < T(0.05)) return SurfacePoint<T>::at_infinity({0, 0, 1});  // in no cluster
      return SurfacePoint<T>::on_surface({rng.uniform<T>() * 3, rng.uniform<T>() * 3, T(0.5)}, {0, 0, 1});
    };
    segments.push_back({point(), point()});
  }
  Clustering<T> clustering;
  clustering.keep_refs(true);
  clustering.build(VoxelGrid<T>(T(0.4)), segments);
  const auto refs = clustering.refs();
  std::size_t starting = 0, ending = 0;
  std::vector<int> seen(segments.size(), 0);
  for (const auto& c : clustering.clusters()) {
    CHECK(c.slot == starting);
    CHECK(c.ending_slot(c.middle) == ending);
    for (std::uint32_t r = c.begin; r < c.middle; ++r) CHECK(clustering.starting_segments()[c.starting_slot(r)] == refs[r].segment);
    for (std::uint32_t r = c.middle; r < c.end; ++r) {
      CHECK(clustering.ending_segments()[c.ending_slot(r)] == refs[r].segment);
      CHECK(clustering.ending_slot_of(refs[r].segment) == c.ending_slot(r));
      ++seen[refs[r].segment];
    }
    starting += c.starting_count();
    ending += c.ending_count();
  }
  CHECK(clustering.starting_slot_count() == starting);
  CHECK(clustering.ending_slot_count() == ending);
  REQUIRE(ending < segments.size());  // some segments end in no cluster
  for (std::uint32_t s = 0; s < segments.size(); ++s) {
    CHECK(seen[s] <= 1);
    CHECK((clustering.ending_slot_of(s) == no_cluster) == (seen[s] == 0));
    CHECK((clustering.ending_slot_of(s) == no_cluster) == (clustering.cluster_of_y(s) == no_cluster));
  }
  // A cluster's segments by slot are its refs' segments, in ref order.
  for (std::size_t c = 0; c < clustering.clusters().size(); ++c) {
    const Cluster<T>& cl = clustering.clusters()[c];
    const auto starts = clustering.starting_segments(c), ends = clustering.ending_segments(c);
    REQUIRE(starts.size() == cl.starting_count());
    REQUIRE(ends.size() == cl.ending_count());
    for (std::uint32_t r = cl.begin; r < cl.middle; ++r) CHECK(starts[r - cl.begin] == refs[r].segment);
    for (std::uint32_t r = cl.middle; r < cl.end; ++r) CHECK(ends[r - cl.middle] == refs[r].segment);
  }
  // By default the refs are released after build and nothing else changes.
  Clustering<T> lean;
  lean.build(VoxelGrid<T>(T(0.4)), segments);
  CHECK(lean.refs().empty());
  const std::size_t kept_refs = clustering.refs().size() * sizeof(EndpointRef) / segments.size();
  CHECK(lean.bytes_per_segment() + kept_refs <= clustering.bytes_per_segment());
  CHECK(lean.ending_slot_count() == clustering.ending_slot_count());
  CHECK(std::ranges::equal(lean.starting_segments(), clustering.starting_segments()));
  CHECK(std::ranges::equal(lean.ending_segments(), clustering.ending_segments()));
  // The build's peak: at least what it keeps, and when the sort's codes are gathered its three
  // lookups, every end's ref and the valid refs' 8-byte codes.
  REQUIRE(lean.last_sort() == EndpointSort::radix);
  const std::size_t n = segments.size(), valid_refs = lean.starting_slot_count() + lean.ending_slot_count();
  const std::size_t gathering = 3 * n * sizeof(std::uint32_t) + 2 * n * sizeof(EndpointRef) + valid_refs * sizeof(std::uint64_t);
  CHECK(lean.build_peak_bytes_per_segment() >= lean.bytes_per_segment());
  CHECK(lean.build_peak_bytes_per_segment() >= gathering / n);
}

TEMPLATE_TEST_CASE("radix-sorted clusters equal std::sort's, with 1 or 2 threads", "[propagation]", float, double) {
  using T = TestType;
  struct Case {
    const char* name;
    std::size_t n;
    T offset, extent, cell;
    double non_surface, duplicate;
    EndpointSort sort;
  };
  // Code bits: 3 * ceil(log2(range / cell)) + 4; the segment goes in the code's low bits when the
  // sum with log2(n) fits in 64 bits, beside it otherwise; beyond 64 code bits, std::sort. Above
  // 2 * radix_sort_chunk refs the sort runs in chunks (core/radix_sort.hpp).
  const Case cases[] = {
      {"negative coordinates, 11-bit digits, two sort chunks", 80000, T(-7), T(3), T(0.05), 0.1, 0.2, EndpointSort::radix},
      {"8-bit digits, many duplicates", 3000, T(0), T(1), T(0.25), 0.05, 0.6, EndpointSort::radix},
      {"one voxel: only the normal bin and the end vary", 2000, T(0.75), T(0.1), T(1), 0.1, 0.0, EndpointSort::radix},
      {"codes beside the segments (52 + 17 bits), two sort chunks", 80000, T(0), T(32000), T(1), 0.1, 0.3, EndpointSort::radix},
      {"huge ranges: the std::sort fallback", 5000, T(0), T(4e8), T(1), 0.1, 0.3, EndpointSort::comparison},
      {"no surface ends", 100, T(0), T(1), T(0.1), 1.0, 0.0, EndpointSort::radix},
      {"empty pool", 0, T(0), T(1), T(0.1), 0.0, 0.0, EndpointSort::radix},
  };
  for (const Case& k : cases) {
    SECTION(k.name) {
      const auto segments = random_pool<T>(k.n, k.offset, k.extent, k.non_surface, k.duplicate, 11 + k.n);
      const VoxelGrid<T> grid(k.cell, Vec3<T>(T(0.3), T(0.6), T(0.1)));
      Clustering<T> serial, threaded, comparison;
      serial.keep_refs(true);
      threaded.keep_refs(true);
      comparison.keep_refs(true);
      serial.build(grid, segments);
      threaded.build(grid, std::span<const Segment<T>>(segments), [](const SurfacePoint<T>& p) { return p.position; },
                     segpath::testing::TwoThreadFor{});
      comparison.force_comparison_sort(true);
      comparison.build(grid, segments);
      CHECK(serial.last_sort() == k.sort);
      CHECK(threaded.last_sort() == k.sort);
      CHECK(comparison.last_sort() == EndpointSort::comparison);
      if (k.cell == T(1) && k.extent < T(1)) CHECK(serial.clusters().size() <= 6);

      const auto expected = reference_refs(grid, segments);
      REQUIRE(serial.refs().size() == expected.size());
      std::size_t mismatches = 0;
      for (std::size_t r = 0; r < expected.size(); ++r) {
        const EndpointRef &p = serial.refs()[r], &q = expected[r];
        mismatches += !(p.key == q.key && p.segment == q.segment && p.end == q.end);
      }
      CHECK(mismatches == 0);
      check_same(serial, comparison, segments.size());
      check_same(serial, threaded, segments.size());
      // A rebuild reuses the buffers and gives the same result.
      threaded.build(grid, segments);
      check_same(serial, threaded, segments.size());

      // The order within a key is exercised: some cluster has two refs of the same end.
      if (k.duplicate > 0) {
        bool shared = false;
        for (const auto& c : serial.clusters()) shared = shared || c.starting_count() > 1 || c.ending_count() > 1;
        CHECK(shared);
      }
    }
  }
}

TEST_CASE("the radix order is checked: an order without the end tie-break is rejected", "[propagation]") {
  const auto segments = random_pool<double>(3000, 0.0, 1.0, 0.05, 0.6, 5);
  const VoxelGrid<double> grid(0.25);
  Clustering<double> clustering;
  clustering.keep_refs(true);
  clustering.build(grid, segments);
  // Sorting by key alone, stably, keeps generation order (x and y ends interleaved): not the
  // clustering's order, which puts every cluster's starting refs first.
  auto wrong = reference_refs(grid, segments);
  std::sort(wrong.begin(), wrong.end(), [](const EndpointRef& a, const EndpointRef& b) {
    return a.key != b.key ? a.key < b.key : a.segment < b.segment;
  });
  std::size_t mismatches = 0;
  for (std::size_t r = 0; r < wrong.size(); ++r)
    mismatches += !(clustering.refs()[r].segment == wrong[r].segment && clustering.refs()[r].end == wrong[r].end);
  CHECK(mismatches > 0);
}

TEMPLATE_TEST_CASE("renumbering renames the segments and keeps every cluster and slot", "[propagation]", float, double) {
  using T = TestType;
  const auto segments = random_pool<T>(4000, T(2), T(1.5), 0.1, 0.3, 17);
  const auto grid = VoxelGrid<T>::jittered(T(0.4), 2, 3);
  Clustering<T> before, after;
  before.keep_refs(true);
  after.keep_refs(true);
  before.build(grid, segments);
  after.build(grid, segments);
  // A random permutation (Fisher-Yates).
  const auto n = std::uint32_t(segments.size());
  std::vector<std::uint32_t> new_of_old(n);
  for (std::uint32_t s = 0; s < n; ++s) new_of_old[s] = s;
  Pcg32 rng(5, 2);
  for (std::uint32_t s = n - 1; s > 0; --s) std::swap(new_of_old[s], new_of_old[std::min(s, std::uint32_t(rng.uniform<double>() * (s + 1)))]);
  after.renumber(new_of_old, testing::TwoThreadFor{});

  CHECK(cluster_mismatches(before, after) == 0);
  // Slot j of either end names the renamed segment of the same slot before.
  std::size_t slot_mismatches = 0;
  for (std::size_t j = 0; j < before.starting_segments().size(); ++j)
    slot_mismatches += after.starting_segments()[j] != new_of_old[before.starting_segments()[j]];
  for (std::size_t i = 0; i < before.ending_segments().size(); ++i)
    slot_mismatches += after.ending_segments()[i] != new_of_old[before.ending_segments()[i]];
  CHECK(slot_mismatches == 0);
  std::size_t ref_mismatches = 0;
  for (std::size_t r = 0; r < before.refs().size(); ++r)
    ref_mismatches += !(after.refs()[r].key == before.refs()[r].key && after.refs()[r].end == before.refs()[r].end &&
                        after.refs()[r].segment == new_of_old[before.refs()[r].segment]);
  CHECK(ref_mismatches == 0);
  // Each segment's lookups move with it.
  std::size_t segment_mismatches = 0, unclustered_y = 0;
  for (std::uint32_t s = 0; s < n; ++s) {
    const std::uint32_t t = new_of_old[s];
    segment_mismatches += !(after.cluster_of_x(t) == before.cluster_of_x(s) && after.cluster_of_y(t) == before.cluster_of_y(s) &&
                            after.ending_slot_of(t) == before.ending_slot_of(s));
    unclustered_y += before.cluster_of_y(s) == no_cluster;
  }
  CHECK(segment_mismatches == 0);
  CHECK(unclustered_y > 100);  // the pool has ends in no cluster (10 % non-surface)
  // Renaming back restores the clustering exactly.
  std::vector<std::uint32_t> old_of_new(n);
  for (std::uint32_t s = 0; s < n; ++s) old_of_new[new_of_old[s]] = s;
  after.renumber(old_of_new);
  check_same(before, after, n);
  CHECK_THROWS_AS(after.renumber(std::vector<std::uint32_t>(n - 1)), std::invalid_argument);
  std::vector<std::uint32_t> twice = old_of_new, beyond = old_of_new;
  twice[7] = twice[8];
  beyond[7] = n;
  CHECK_THROWS_AS(after.renumber(twice), std::invalid_argument);
  CHECK_THROWS_AS(after.renumber(beyond), std::invalid_argument);
  check_same(before, after, n);  // a rejected renaming changes nothing
}
