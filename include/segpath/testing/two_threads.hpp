// Test kit: a parallel_for on two std::threads (even and odd indices), to check that a result
// does not depend on the thread count (segpath::ParallelFor, core/parallel.hpp).
#pragma once

#include <cstddef>
#include <thread>
#include <utility>

namespace segpath::testing {

/// Runs body(i) for i in [0, n): odd i on a second thread, even i on the caller's, one
/// std::thread per call (not for hot loops).
struct TwoThreadFor {
  template <class Body>
  void operator()(std::size_t n, Body&& body) const {
    std::thread other([&] {
      for (std::size_t i = 1; i < n; i += 2) body(i);
    });
    for (std::size_t i = 0; i < n; i += 2) body(i);
    other.join();
  }
};

}  // namespace segpath::testing
