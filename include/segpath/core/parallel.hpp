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

/// The number of chunks of at most `size` (> 0) items that [0, n) takes.
[[nodiscard]] constexpr std::size_t chunk_count(std::size_t n, std::size_t size) noexcept { return (n + size - 1) / size; }

/// Splits [0, n) into `chunks` contiguous ranges of near-equal size and calls body(begin, end)
/// once per range, through `parallel_for` (one task per range; empty ranges are skipped).
template <class Body, ParallelFor P>
void for_chunks(std::size_t n, std::size_t chunks, const P& parallel_for, const Body& body) {
  if (n == 0 || chunks == 0) return;
  parallel_for(chunks, [&](std::size_t c) {
    const std::size_t begin = n * c / chunks, end = n * (c + 1) / chunks;
    if (begin < end) body(begin, end);
  });
}

/// The number of tasks for_blocks() splits a flat loop into.
inline constexpr std::size_t parallel_blocks = 64;

/// body(i) for every i in [0, n), in parallel_blocks contiguous blocks: for flat loops whose
/// iterations are too cheap to be tasks of their own.
template <class Body, ParallelFor P>
void for_blocks(std::size_t n, const P& parallel_for, const Body& body) {
  for_chunks(n, parallel_blocks, parallel_for, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) body(i);
  });
}

}  // namespace segpath
