// The spatial hash grid (kernels/hash_grid.hpp): exact radius queries, a visiting order that
// depends on nothing but the input, and items stored beside their positions.
#include <segpath/core/rng.hpp>
#include <segpath/kernels/hash_grid.hpp>
#include <segpath/testing/two_threads.hpp>

#include <algorithm>
#include <limits>
#include <optional>
#include <stdexcept>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

TEMPLATE_TEST_CASE("the hash grid finds exactly the points within the radius, in a fixed order", "[kernels]",
                   float, double) {
  using T = TestType;
  Pcg32 rng(7, 1);
  std::vector<Vec3<T>> points(3000);
  for (auto& p : points) p = Vec3<T>(rng.uniform<T>() * 4 - 2, rng.uniform<T>() * 4 - 2, rng.uniform<T>() * T(0.5));
  std::vector<std::uint32_t> items(points.size());
  for (std::uint32_t i = 0; i < items.size(); ++i) items[i] = i;
  HashGrid<T> grid;
  for (const T r : {T(0.05), T(0.3)}) {
    grid.build(items, r, [&](std::uint32_t i) { return points[i]; });
    CHECK(grid.size() == points.size());
    for (int q = 0; q < 300; ++q) {
      const Vec3<T> c(rng.uniform<T>() * 4 - 2, rng.uniform<T>() * 4 - 2, rng.uniform<T>() * T(0.5));
      std::vector<std::uint32_t> found, again, expected;
      grid.for_each_within(c, [&](std::uint32_t i, const Vec3<T>&) { found.push_back(i); });
      grid.for_each_within(c, [&](std::uint32_t i, const Vec3<T>&) { again.push_back(i); });
      for (std::uint32_t i = 0; i < points.size(); ++i)
        if (glm::dot(points[i] - c, points[i] - c) < r * r) expected.push_back(i);
      CHECK(found == again);
      std::sort(found.begin(), found.end());
      CHECK(found == expected);
    }
  }
  // Non-finite items are left out; an empty grid answers nothing.
  points[5] = Vec3<T>(std::numeric_limits<T>::quiet_NaN());
  grid.build(items, T(0.1), [&](std::uint32_t i) { return points[i]; });
  CHECK(grid.size() == points.size() - 1);
  grid.build({}, T(0.1), [&](std::uint32_t i) { return points[i]; });
  int calls = 0;
  grid.for_each_within(Vec3<T>(0), [&](std::uint32_t, const Vec3<T>&) { ++calls; });
  CHECK(calls == 0);
}

namespace {
/// A ParallelFor that runs the indices backwards, so a build whose result depended on the order
/// of its tasks would differ from the serial one.
struct BackwardFor {
  template <class Body>
  void operator()(std::size_t n, Body&& body) const {
    for (std::size_t i = n; i-- > 0;) body(i);
  }
};

struct Payload {
  std::uint32_t source = 0;
  float tag = 0;
};
}  // namespace

TEST_CASE("the hash grid's items and visiting order do not depend on the parallel-for", "[kernels]") {
  using T = float;
  for (const std::size_t n : {std::size_t(1), std::size_t(5), std::size_t(700), std::size_t(20000)}) {
    Pcg32 rng(11, n);
    // Clustered points (many share cells and buckets) and some left out.
    std::vector<std::optional<Vec3<T>>> points(n);
    for (std::size_t i = 0; i < n; ++i) {
      if (i % 7 == 3) continue;
      const T s = i % 2 == 0 ? T(0.05) : T(3);
      points[i] = Vec3<T>(rng.uniform<T>() * s, rng.uniform<T>() * s, rng.uniform<T>() * T(0.1));
    }
    if (n > 5) points[4] = Vec3<T>(std::numeric_limits<T>::infinity(), 0, 0);
    const auto position_of = [&](std::size_t i) { return points[i]; };
    const auto item_of = [&](std::size_t i) { return Payload{std::uint32_t(i), T(i) * T(0.5)}; };
    HashGrid<T, Payload> serial, backward, threads;
    const T r = T(0.04);
    serial.build(n, r, position_of, item_of);
    backward.build(n, r, position_of, item_of, BackwardFor{});
    threads.build(n, r, position_of, item_of, testing::TwoThreadFor{});
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n; ++i) kept += points[i] && is_finite(*points[i]);
    CHECK(serial.size() == kept);
    CHECK(backward.size() == kept);
    CHECK(threads.size() == kept);
    for (int q = 0; q < 200; ++q) {
      const Vec3<T> c = q % 2 == 0 ? Vec3<T>(rng.uniform<T>() * T(0.05), rng.uniform<T>() * T(0.05), T(0.05))
                                   : Vec3<T>(rng.uniform<T>() * 3, rng.uniform<T>() * 3, T(0.05));
      std::vector<std::uint32_t> a, b, t, expected;
      serial.for_each_within(c, [&](const Payload& p, const Vec3<T>& x) {
        CHECK(x == *points[p.source]);  // each item sits at its own source's position
        CHECK(p.tag == T(p.source) * T(0.5));
        a.push_back(p.source);
      });
      backward.for_each_within(c, [&](const Payload& p, const Vec3<T>&) { b.push_back(p.source); });
      threads.for_each_within(c, [&](const Payload& p, const Vec3<T>&) { t.push_back(p.source); });
      CHECK(a == b);
      CHECK(a == t);
      // At most 8 buckets, each visited in source order: at most 7 descents.
      std::size_t descents = 0;
      for (std::size_t i = 1; i < a.size(); ++i) descents += a[i] < a[i - 1];
      CHECK(descents <= 7);
      for (std::size_t i = 0; i < n; ++i)
        if (points[i] && is_finite(*points[i]) && glm::dot(*points[i] - c, *points[i] - c) < r * r)
          expected.push_back(std::uint32_t(i));
      std::sort(a.begin(), a.end());
      CHECK(a == expected);
    }
  }
}

TEST_CASE("a hash grid build that fails leaves an empty grid", "[kernels]") {
  using T = float;
  HashGrid<T> grid;
  std::vector<Vec3<T>> points(10, Vec3<T>(0));
  const auto position_of = [&](std::size_t i) { return std::optional(points[i % points.size()]); };
  const auto item_of = [](std::size_t i) { return std::uint32_t(i); };
  grid.build(points.size(), T(0.1), position_of, item_of);
  CHECK(grid.size() == 10);
  // More sources than the 32-bit bucket arithmetic allows: refused before reading any (a
  // source read at all fails the check quickly with another exception).
  const auto never_read = [](std::size_t) -> std::optional<Vec3<T>> { throw std::runtime_error("a source was read"); };
  CHECK_THROWS_AS(grid.build((std::size_t(1) << 31) + 1, T(0.1), never_read, item_of), std::length_error);
  CHECK(grid.size() == 0);
  // A source that throws half-way: nothing of the earlier build is left to query.
  grid.build(points.size(), T(0.1), position_of, item_of);
  const auto throwing = [&](std::size_t i) -> std::optional<Vec3<T>> {
    if (i == 1500) throw std::runtime_error("source 1500");
    return Vec3<T>(T(i % 7) * T(0.01));
  };
  CHECK_THROWS_AS(grid.build(2000, T(0.1), throwing, item_of), std::runtime_error);
  CHECK(grid.size() == 0);
  // An item that throws (the second pass, after the entries were sized): the same.
  grid.build(points.size(), T(0.1), position_of, item_of);
  const auto throwing_item = [](std::size_t i) -> std::uint32_t {
    if (i == 1500) throw std::runtime_error("item 1500");
    return std::uint32_t(i);
  };
  CHECK_THROWS_AS(grid.build(2000, T(0.1), position_of, throwing_item), std::runtime_error);
  CHECK(grid.size() == 0);
  int calls = 0;
  grid.for_each_within(Vec3<T>(0), [&](std::uint32_t, const Vec3<T>&) { ++calls; });
  CHECK(calls == 0);
}
