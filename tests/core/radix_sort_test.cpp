// radix_sort: the stable order of std::stable_sort, on one thread or two, whatever the chunks.
#include <segpath/core/radix_sort.hpp>
#include <segpath/testing/two_threads.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "support/catch.hpp"

namespace {

using namespace segpath;

/// A key and where it was: stability is visible as the order of `index` within equal keys.
struct Item {
  std::uint64_t key;
  std::uint32_t index;
};

/// n items whose keys have `distinct` values (few: many ties) spread over bits [lo, lo + bits),
/// with random bits outside that range, which the sort must ignore.
std::vector<Item> random_items(std::size_t n, unsigned lo, unsigned bits, std::uint64_t distinct, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const std::uint64_t field = bits >= 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << bits) - 1;
  std::vector<std::uint64_t> values(distinct);
  for (auto& v : values) v = rng() & field;
  std::vector<Item> items(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t noise = rng() & ~(field << lo);
    items[i] = {values[rng() % distinct] << lo | noise, std::uint32_t(i)};
  }
  return items;
}

template <class P>
std::vector<Item> radix_sorted(std::vector<Item> items, unsigned lo, unsigned bits, const P& parallel_for) {
  std::vector<Item> scratch(items.size());
  std::vector<std::uint32_t> counts;
  const auto sorted = radix_sort(std::span<Item>(items), std::span<Item>(scratch), lo, bits,
                                 [](const Item& e) { return e.key; }, counts, parallel_for);
  return {sorted.begin(), sorted.end()};
}

bool same(const std::vector<Item>& a, const std::vector<Item>& b) {
  return std::ranges::equal(a, b, [](const Item& x, const Item& y) { return x.key == y.key && x.index == y.index; });
}

}  // namespace

TEST_CASE("radix_sort gives std::stable_sort's order on one thread and on two", "[core]") {
  struct Case {
    const char* name;
    std::size_t n;
    unsigned lo, bits;
    std::uint64_t distinct;
  };
  // 8-bit digits below 2^16 elements, 11-bit above; one chunk below 2 * radix_sort_chunk.
  const Case cases[] = {
      {"empty", 0, 0, 20, 5},
      {"one element", 1, 3, 20, 5},
      {"two elements", 2, 0, 20, 2},
      {"8-bit digits, many ties", 1000, 5, 20, 37},
      {"11-bit digits, one chunk", 100000, 7, 40, 100000},
      {"three chunks, a digit of its own width", 3 * radix_sort_chunk + 5, 0, 25, 5000},
      {"five chunks, many ties", 5 * radix_sort_chunk + 11, 13, 33, 300},
      {"all 64 bits", 4 * radix_sort_chunk, 0, 64, 1u << 20},
      {"one value: every pass skipped", 3 * radix_sort_chunk, 2, 30, 1},
  };
  for (const Case& k : cases) {
    SECTION(k.name) {
      const auto items = random_items(k.n, k.lo, k.bits, k.distinct, 17 + k.n);
      const std::uint64_t field = k.bits >= 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << k.bits) - 1;
      auto expected = items;
      std::stable_sort(expected.begin(), expected.end(),
                       [&](const Item& a, const Item& b) { return (a.key >> k.lo & field) < (b.key >> k.lo & field); });
      CHECK(same(radix_sorted(items, k.lo, k.bits, SerialFor{}), expected));
      CHECK(same(radix_sorted(items, k.lo, k.bits, segpath::testing::TwoThreadFor{}), expected));
    }
  }
}

TEST_CASE("radix_sort ignores the bits outside its range and sorts nothing for zero bits", "[core]") {
  // Keys that differ only above the sorted bits keep their order; with bits = 0 the input is
  // returned as it is.
  std::vector<Item> items(3 * radix_sort_chunk);
  for (std::size_t i = 0; i < items.size(); ++i) items[i] = {(std::uint64_t(items.size() - i) << 20) | (i % 7), std::uint32_t(i)};
  auto expected = items;
  std::stable_sort(expected.begin(), expected.end(), [](const Item& a, const Item& b) { return (a.key & 0xfffff) < (b.key & 0xfffff); });
  CHECK(same(radix_sorted(items, 0, 20, segpath::testing::TwoThreadFor{}), expected));
  CHECK(same(radix_sorted(items, 0, 0, SerialFor{}), items));
}
