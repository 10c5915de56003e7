// Parallel loops are the caller's choice: algorithms take a ParallelFor callable, so a
// renderer can hand in its own thread pool (oneTBB, OpenMP, ...). Results never depend on
// it: loop bodies write disjoint outputs and reduce in a fixed order.
#pragma once

#include <concepts>
#include <cstddef>

namespace segpath {

/// pf(n, body) calls body(i) once for every i in [0, n), in any order and on any threads.
template <class P>
concept ParallelFor = requires(const P& pf, void (*body)(std::size_t)) { pf(std::size_t{}, body); };

/// The serial ParallelFor.
struct SerialFor {
  template <class Body>
  void operator()(std::size_t n, Body&& body) const {
    for (std::size_t i = 0; i < n; ++i) body(i);
  }
};

}  // namespace segpath
