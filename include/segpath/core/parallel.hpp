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

/// The chunked loop over [0, n): `blocks` contiguous ranges, one parallel_for task each, body(i)
/// for every i (for flat per-element loops whose bodies are too small to be tasks of their own).
inline constexpr std::size_t default_blocks = 64;

template <class Body, ParallelFor P>
void for_blocks(std::size_t n, const P& parallel_for, const Body& body, std::size_t blocks = default_blocks) {
  parallel_for(blocks, [&](std::size_t b) {
    for (std::size_t i = n * b / blocks, e = n * (b + 1) / blocks; i < e; ++i) body(i);
  });
}

}  // namespace segpath
