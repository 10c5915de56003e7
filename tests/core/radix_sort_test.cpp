// radix_sort: the stable order of std::stable_sort, on one thread or two, whatever the chunks.
#include <segpath/core/radix_sort.hpp>
#include <segpath/testing/two_threads.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <random>
#include <span>
#include <stdexcept>
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

/// Runs the chunks last to first: a result that depended on their order would show it.
struct ReverseFor {
  template <class Body>
  void operator()(std::size_t n, Body&& body) const {
    for (std::size_t i = n; i-- > 0;) body(i);
  }
};

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
      {"one chunk, four 10-bit digits", 100000, 7, 40, 100000},
      {"three chunks, the last digit narrower", 3 * radix_sort_chunk + 5, 0, 25, 5000},
      {"five chunks, many ties", 5 * radix_sort_chunk + 11, 13, 33, 300},
      {"all 64 bits", 4 * radix_sort_chunk, 0, 64, 1u << 20},
      {"up to the word's top bit (the clustering's codes)", 3 * radix_sort_chunk, 20, 44, 70000},
      {"one value: every digit constant", 3 * radix_sort_chunk, 2, 30, 1},
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
      CHECK(same(radix_sorted(items, k.lo, k.bits, ReverseFor{}), expected));
    }
  }
}

TEST_CASE("radix_sort orders by its bits only, with constant digits before and after a moving one", "[core]") {
  // 21 bits in two passes of 11: the last digit is 10 bits wide, and key bit 21 (above the
  // range) varies, so an unmasked last digit would order by it.
  std::vector<Item> items(3 * radix_sort_chunk);
  for (std::size_t i = 0; i < items.size(); ++i)
    items[i] = {(std::uint64_t(items.size() - i) << 21) | (i * 2654435761u % (1u << 21)), std::uint32_t(i)};
  auto by_low_21 = [](const Item& a, const Item& b) { return (a.key & 0x1fffff) < (b.key & 0x1fffff); };
  auto expected = items;
  std::stable_sort(expected.begin(), expected.end(), by_low_21);
  CHECK(same(radix_sorted(items, 0, 21, segpath::testing::TwoThreadFor{}), expected));
  CHECK(same(radix_sorted(items, 0, 21, SerialFor{}), expected));
  // Keys (i % 7) << 11 over 33 bits (three 11-bit digits): the first digit is constant, before
  // the pass that moves the elements, and so is the third, after it. (Whether a constant pass
  // is skipped does not show in the order; only that the order stays right.)
  for (std::size_t i = 0; i < items.size(); ++i) items[i] = {std::uint64_t(i % 7) << 11, std::uint32_t(i)};
  expected = items;
  std::stable_sort(expected.begin(), expected.end(), [](const Item& a, const Item& b) { return a.key < b.key; });
  CHECK(same(radix_sorted(items, 0, 33, segpath::testing::TwoThreadFor{}), expected));
  CHECK(same(radix_sorted(items, 0, 33, ReverseFor{}), expected));
  // Zero bits: the input as it is.
  CHECK(same(radix_sorted(items, 0, 0, SerialFor{}), items));
}

TEST_CASE("radix_sort refuses bits beyond a 64-bit word", "[core]") {
  std::vector<Item> items(4), scratch(4);
  std::vector<std::uint32_t> counts;
  const auto key = [](const Item& e) { return e.key; };
  CHECK_THROWS_AS(radix_sort(std::span<Item>(items), std::span<Item>(scratch), 20, 45, key, counts), std::invalid_argument);
  CHECK_THROWS_AS(radix_sort(std::span<Item>(items), std::span<Item>(scratch), 65, 0, key, counts), std::invalid_argument);
  CHECK_NOTHROW(radix_sort(std::span<Item>(items), std::span<Item>(scratch), 20, 44, key, counts));
}
