// A segment as a technique draws it, before pooling (Record), and the list a path generator
// fills with them (RecordList); pool.hpp's append copies the lists into the pool.
#pragma once

#include "segpath/core/block_list.hpp"
#include "segpath/core/segment.hpp"
#include "segpath/core/spectrum.hpp"

#include <cstdint>

namespace segpath::filtering {

inline constexpr std::uint32_t no_parent = 0xffffffffu;

/// A segment as a technique produces it, before pooling.
template <Real T, Spectrum S>
struct Record {
  Segment<T> segment;
  Vec3<T> first_direction, last_direction;
  S chain;
  T geometry = 0, sensor_weight = 0;
  /// Only for a kept chain (kept_chain): its MMIS denominator, N_L times its first segment's
  /// density; every other segment's is computed from the pool (densities.hpp).
  T density = 0;
  std::uint32_t pixel = 0;
  std::uint32_t parent = no_parent;  ///< index in the same generator's record list
  std::uint16_t flags = 0;
  std::uint16_t pieces = 1;  ///< Pool::pieces
  bool next_event = false;
};

/// One generator's records before pooling, in blocks that never move (core/block_list.hpp):
/// no copies as the list grows and no outgrown buffers left as holes in the heap that the pool
/// and the propagation's large arrays cannot reuse (docs/figures.md, session 27). Blocks of 512
/// records (~75 KB in float): 64 chunks' lists of both sides hold at most ~10 MB they do not
/// fill (4096 held ~77 MB, the most of a 128 x 128 render's peak: session 31).
template <Real T, Spectrum S>
using RecordList = BlockList<Record<T, S>, 512>;

}  // namespace segpath::filtering
