// The two-thread parallel_for of the test kit visits every index exactly once, on two threads.
#include <segpath/core/parallel.hpp>
#include <segpath/testing/two_threads.hpp>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "support/catch.hpp"

static_assert(segpath::ParallelFor<segpath::testing::TwoThreadFor>);

TEST_CASE("TwoThreadFor visits every index once, on two threads", "[testing]") {
  for (const std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(2), std::size_t(1001)}) {
    std::vector<std::atomic<int>> visits(n);
    std::mutex mutex;
    std::set<std::thread::id> threads;
    segpath::testing::TwoThreadFor{}(n, [&](std::size_t i) {
      visits[i].fetch_add(1);
      const std::lock_guard<std::mutex> lock(mutex);
      threads.insert(std::this_thread::get_id());
    });
    for (std::size_t i = 0; i < n; ++i) CHECK(visits[i].load() == 1);
    CHECK(threads.size() == std::min<std::size_t>(n, 2));
  }
}
