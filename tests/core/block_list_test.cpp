// BlockList: elements in blocks that never move (filtering's path records, VCM's light ends).
#include <segpath/core/block_list.hpp>

#include <cstddef>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

#include "support/catch.hpp"

using segpath::BlockList;

namespace {
struct Item {
  std::size_t index = 0;
  double value = 0;
};
}  // namespace

TEST_CASE("BlockList keeps every element, in order, across its blocks", "[core]") {
  using List = BlockList<Item, 8>;
  const std::size_t n = 2 * List::block_size + 3;
  List list;
  for (std::size_t i = 0; i < n; ++i) list.push_back({i, double(i) + 0.5});
  REQUIRE(list.size() == n);
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < n; ++i) wrong += list[i].index != i || list[i].value != double(i) + 0.5;
  CHECK(wrong == 0);
  std::vector<Item> flat(n + 1, Item{99, -1});
  CHECK(list.copy_to(flat.begin()) == flat.begin() + std::ptrdiff_t(n));
  wrong = 0;
  for (std::size_t i = 0; i < n; ++i) wrong += flat[i].index != i || flat[i].value != double(i) + 0.5;
  CHECK(wrong == 0);
  CHECK(flat[n].index == 99);  // nothing past the last element is written
  const List copy = list;  // a deep copy: the original's later writes do not reach it
  list[0].index = 42;
  CHECK(copy.size() == n);
  CHECK(copy[0].index == 0);
  CHECK(copy[n - 1].index == n - 1);
  List assigned;
  assigned.push_back({5, 5});
  assigned = copy;
  CHECK(assigned.size() == n);
  CHECK(assigned[List::block_size + 1].index == List::block_size + 1);
  list[0].index = 0;
  List moved = std::move(list);
  CHECK(list.size() == 0);  // NOLINT(bugprone-use-after-move): a moved-from list is empty
  CHECK(list.capacity_bytes() == 0);  // NOLINT(bugprone-use-after-move)
  CHECK(moved.size() == n);
  CHECK(moved[n - 1].index == n - 1);
  moved[List::block_size].index = 7;  // a write lands where a read finds it
  CHECK(std::as_const(moved)[List::block_size].index == 7);
}

TEST_CASE("BlockList: clear keeps the blocks for the next fill, release frees them", "[core]") {
  using List = BlockList<Item, 4>;
  List list;
  CHECK(list.capacity_bytes() == 0);
  for (std::size_t i = 0; i < 9; ++i) list.push_back({i, 0});
  const std::size_t held = 3 * List::block_size * sizeof(Item);
  CHECK(list.capacity_bytes() == held);
  list.clear();
  CHECK(list.empty());
  CHECK(list.capacity_bytes() == held);
  for (std::size_t i = 0; i < 12; ++i) list.push_back({100 + i, 0});  // refills the kept blocks
  CHECK(list.capacity_bytes() == held);
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < 12; ++i) wrong += list[i].index != 100 + i;
  CHECK(wrong == 0);
  list.push_back({112, 0});  // one past the kept blocks: one more block
  CHECK(list.capacity_bytes() == held + List::block_size * sizeof(Item));
  CHECK(list[12].index == 112);
  list.release();
  CHECK(list.empty());
  CHECK(list.capacity_bytes() == 0);
}

TEST_CASE("BlockList ends the lifetimes of elements that own memory", "[core]") {
  // Leaks and double frees show in the sanitizer build (LeakSanitizer, AddressSanitizer).
  BlockList<std::shared_ptr<int>, 2> list;
  const auto shared = std::make_shared<int>(5);
  for (int i = 0; i < 5; ++i) list.push_back(shared);
  CHECK(shared.use_count() == 6);
  list.clear();
  CHECK(shared.use_count() == 1);
  for (int i = 0; i < 3; ++i) list.push_back(shared);
  CHECK(shared.use_count() == 4);
  {
    BlockList<std::shared_ptr<int>, 2> other = std::move(list);
    CHECK(shared.use_count() == 4);
  }
  CHECK(shared.use_count() == 1);
}

namespace {
/// Holds a shared count and throws from its copy when a countdown reaches zero.
struct Fragile {
  static inline int copies_left = -1;  // -1: never throw
  std::shared_ptr<int> shared;
  explicit Fragile(std::shared_ptr<int> s) : shared(std::move(s)) {}
  Fragile(const Fragile& other) : shared(other.shared) {
    if (copies_left > 0 && --copies_left == 0) throw std::runtime_error("copy failed");
  }
  Fragile& operator=(const Fragile&) = default;
  ~Fragile() = default;
};
}  // namespace

TEST_CASE("BlockList: a copy that throws leaves no element behind, an assignment that throws no change", "[core]") {
  const auto shared = std::make_shared<int>(1);
  BlockList<Fragile, 2> list;
  for (int i = 0; i < 5; ++i) list.push_back(Fragile(shared));
  REQUIRE(shared.use_count() == 6);
  Fragile::copies_left = 4;  // the fourth copy throws
  using FragileList = BlockList<Fragile, 2>;
  CHECK_THROWS_AS(FragileList(list), std::runtime_error);
  CHECK(shared.use_count() == 6);  // the three copies made were destroyed
  FragileList target;
  target.push_back(Fragile(shared));
  Fragile::copies_left = 3;
  CHECK_THROWS_AS(target = list, std::runtime_error);
  Fragile::copies_left = -1;
  CHECK(target.size() == 1);
  CHECK(shared.use_count() == 7);
  target = list;
  CHECK(target.size() == 5);
  CHECK(shared.use_count() == 11);
}
