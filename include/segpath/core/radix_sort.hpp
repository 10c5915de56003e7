// A stable LSD radix sort of integer keys, in parallel over contiguous chunks of the input:
// per pass, each chunk counts its digits, the offsets are laid out digit by digit and chunk by
// chunk within a digit, and each chunk scatters its elements in order. The result is the
// unique stable order, whatever ParallelFor runs the chunks.
#pragma once

#include "segpath/core/parallel.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace segpath {

/// Elements per chunk of radix_sort (at most radix_sort_max_chunks chunks; fewer elements than
/// two chunks' worth are sorted as one).
inline constexpr std::size_t radix_sort_chunk = std::size_t(1) << 16;
inline constexpr std::size_t radix_sort_max_chunks = 64;

/// Sorts `data` stably by bits [lo, lo + bits) of word(e) (lo + bits <= 64, else
/// std::invalid_argument), ping-ponging with `scratch` (at least data.size() elements); digits
/// of at most 11 bits, passes whose digit is the same for every element skipped. `counts` is the
/// digit counters' storage, reused across calls. At most 2^32 - 1 elements (else
/// std::length_error). Returns the span (of data or scratch) that holds the sorted sequence.
///
/// Each pass counts its digit afresh, chunk by chunk: one read per pass more than a serial sort
/// that counts every digit at once. In the clustering on two threads the whole sort still took
/// less time than that serial one; counting every digit in one read, and again only after a
/// pass that moved the elements, was slower (docs/figures.md, session 43).
template <class E, class Word, ParallelFor P = SerialFor>
std::span<E> radix_sort(std::span<E> data, std::span<E> scratch, unsigned lo, unsigned bits, const Word& word,
                        std::vector<std::uint32_t>& counts, const P& parallel_for = {}) {
  const std::size_t n = data.size();
  if (lo > 64 || bits > 64 - lo)
    throw std::invalid_argument("segpath::radix_sort: bits [" + std::to_string(lo) + ", " + std::to_string(lo + bits) +
                                ") are not within a 64-bit word");
  if (n > std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("segpath::radix_sort: " + std::to_string(n) + " elements, more than 32-bit offsets count");
  if (bits == 0 || n < 2) return data;
  const unsigned max_width = n < (std::size_t(1) << 16) ? 8 : 11;
  const unsigned passes = (bits + max_width - 1) / max_width;
  const unsigned width = (bits + passes - 1) / passes;
  const std::size_t radix = std::size_t(1) << width;
  const std::size_t chunks = std::clamp<std::size_t>(n / radix_sort_chunk, 1, radix_sort_max_chunks);
  counts.resize(chunks * radix);
  auto chunk_range = [&](std::size_t c) { return std::pair{n * c / chunks, n * (c + 1) / chunks}; };
  E* src = data.data();
  E* dst = scratch.data();
  for (unsigned p = 0; p < passes; ++p) {
    const unsigned shift = lo + p * width;
    // The last digit may be narrower: bits above lo + bits take no part in the order.
    const std::uint64_t mask = (std::uint64_t(1) << std::min(width, bits - p * width)) - 1;
    // counts[c * radix + d]: how many elements of chunk c have digit d ...
    parallel_for(chunks, [&](std::size_t c) {
      std::uint32_t* count = counts.data() + c * radix;
      std::fill(count, count + radix, 0u);
      const auto [begin, end] = chunk_range(c);
      for (std::size_t i = begin; i < end; ++i) ++count[(word(src[i]) >> shift) & mask];
    });
    // ... then where chunk c writes its first element of digit d.
    std::uint32_t offset = 0;
    bool constant = false;
    for (std::size_t d = 0; d < radix && !constant; ++d) {
      const std::uint32_t digit_begin = offset;
      for (std::size_t c = 0; c < chunks; ++c) offset += std::exchange(counts[c * radix + d], offset);
      constant = offset - digit_begin == n;
    }
    if (constant) continue;
    parallel_for(chunks, [&](std::size_t c) {
      std::uint32_t* next = counts.data() + c * radix;
      const auto [begin, end] = chunk_range(c);
      for (std::size_t i = begin; i < end; ++i) dst[next[(word(src[i]) >> shift) & mask]++] = src[i];
    });
    std::swap(src, dst);
  }
  return {src, n};
}

}  // namespace segpath
