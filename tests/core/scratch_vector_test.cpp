// reserve_without_copy and resize_for_overwrite: scratch vectors that grow without holding the
// old buffer and the new one at once.
#include <segpath/core/scratch_vector.hpp>

#include <algorithm>
#include <cstddef>
#include <memory>
#include <vector>

#include "support/catch.hpp"

namespace {
/// Counts the bytes allocated and not yet freed, and their maximum.
struct Ledger {
  std::size_t live = 0, most = 0;
};
template <class T>
struct CountingAllocator {
  using value_type = T;
  Ledger* ledger;
  explicit CountingAllocator(Ledger* l) noexcept : ledger(l) {}
  template <class U>
  CountingAllocator(const CountingAllocator<U>& other) noexcept : ledger(other.ledger) {}  // NOLINT: rebinding
  T* allocate(std::size_t n) {
    ledger->live += n * sizeof(T);
    ledger->most = std::max(ledger->most, ledger->live);
    return std::allocator<T>{}.allocate(n);
  }
  void deallocate(T* p, std::size_t n) noexcept {
    ledger->live -= n * sizeof(T);
    std::allocator<T>{}.deallocate(p, n);
  }
  template <class U>
  bool operator==(const CountingAllocator<U>& other) const noexcept { return ledger == other.ledger; }
};
}  // namespace

TEST_CASE("resize_for_overwrite frees the old buffer before it allocates the new one", "[core]") {
  Ledger ledger;
  std::vector<int, CountingAllocator<int>> v(1000, 7, CountingAllocator<int>(&ledger));
  ledger.most = ledger.live;
  REQUIRE(ledger.live == 1000 * sizeof(int));
  segpath::resize_for_overwrite(v, 1100);
  CHECK(v.size() == 1100);
  CHECK(v.capacity() >= 1100 + 1100 / 8);  // room for the next iterations
  CHECK(ledger.most == ledger.live);        // never the old 1000 and the new buffer at once
  CHECK(ledger.live < 2 * 1000 * sizeof(int));  // not resize()'s doubling
  // resize() itself, for contrast, holds both:
  Ledger other;
  std::vector<int, CountingAllocator<int>> w(1000, 7, CountingAllocator<int>(&other));
  w.resize(1100);
  CHECK(other.most >= (1000 + 1100) * sizeof(int));
}

TEST_CASE("resize_for_overwrite keeps a large enough buffer", "[core]") {
  std::vector<int> v;
  segpath::resize_for_overwrite(v, 800);
  CHECK(v.size() == 800);
  const int* buffer = v.data();
  const std::size_t capacity = v.capacity();
  CHECK(capacity >= 900);
  segpath::resize_for_overwrite(v, 850);  // within the spare: no new buffer
  CHECK(v.size() == 850);
  CHECK(v.data() == buffer);
  segpath::resize_for_overwrite(v, 10);  // smaller: the buffer is kept for the next iteration
  CHECK(v.size() == 10);
  CHECK(v.capacity() == capacity);
  CHECK(v.data() == buffer);
  segpath::reserve_without_copy(v, 5);  // nothing to do
  CHECK(v.size() == 10);
  segpath::reserve_without_copy(v, 2 * capacity);  // grows, and leaves it empty
  CHECK(v.empty());
  CHECK(v.capacity() >= 2 * capacity + 2 * capacity / 8);
}
