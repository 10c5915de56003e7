// IndexRange: the integers [begin, end) as a sized random-access range (what the junction
// supports and the unconditional MMIS families hand out as their slot and technique lists).
#include <segpath/core/index_range.hpp>

#include <algorithm>
#include <cstdint>
#include <ranges>
#include <vector>

#include "support/catch.hpp"

using segpath::IndexRange;

TEST_CASE("IndexRange lists [begin, end) in order, indexes and sizes like iota", "[core]") {
  const IndexRange<std::uint32_t> r(3, 7);
  std::vector<std::uint32_t> seen(r.begin(), r.end());
  CHECK(seen == std::vector<std::uint32_t>{3, 4, 5, 6});
  CHECK(r.size() == 4);
  CHECK(std::ranges::size(r) == 4);
  CHECK(r[2] == 5);
  CHECK(r.begin()[3] == 6);
  CHECK(r.end() - r.begin() == 4);
  CHECK(*(r.begin() + 2) == 5);
  CHECK(std::ranges::find(r, 6u) - r.begin() == 3);
  CHECK(IndexRange<std::size_t>(5, 2).empty());  // an inverted range is empty, never wraps
  CHECK(IndexRange<std::size_t>().size() == 0);
}
