// A segment as a technique draws it, before pooling (Record), and the list a path generator
// fills with them (RecordList); pool.hpp's append copies the lists into the pool.
#pragma once

#include "segpath/core/block_list.hpp"
#include "segpath/core/segment.hpp"
#include "segpath/core/spectrum.hpp"

#include <cstdint>

namespace segpath::filtering {

inline constexpr std::uint32_t no_parent = 0xffffffffu;

/// What a pooled segment is (Pool::flags).
enum PoolFlag : std::uint16_t {
  sensor_segment = 1,       ///< s_1 of a camera path
  camera_born = 2,          ///< drawn by the camera side
  chain_segment = 4,        ///< contains delta vertices: (area x, solid angle x) measure
  camera_technique = 8,     ///< a camera successor draw was attempted from it at its path's first visit
  light_technique = 16,     ///< a light predecessor draw was attempted from it at its path's first visit
  light_start = 32,         ///< drawn by the light-start sampler
  delta_light = 64,         ///< its light end is a Dirac (point light, sun): only light sampling draws it
  bridge_segment = 128,     ///< drawn by the bridge technique
  transmission_chain = 256, ///< a chain through a delta transmission
  extra_technique = 512,    ///< drawn by a technique of the user's list (FilteringTechnique)
  kept_density = 1024,      ///< a chain only its light start draws (kept_chain): its D is the draw's, Record::density
  /// A light predecessor (camera successor) drawn at its path's repeat visit of a voxel
  /// (Context::visit_grid): no technique in any denominator drew it, so it joins no chain
  /// (G = 0); it still tries a draw of its own (paths.hpp).
  repeat_visit_born = 2048,
  /// A camera technique sample past max_length whose draw's roulette is
  /// TechniqueSet::camera_tail_continuation, not camera_continuation (set only where they differ).
  camera_tail = 4096,
};

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

/// What a RecordList keeps of a record besides its end points.
template <Real T, Spectrum S>
struct RecordFields {
  Vec3<T> first_direction, last_direction;
  S chain;
  T geometry = 0, sensor_weight = 0, density = 0;
  std::uint32_t pixel = 0;
  std::uint32_t parent = no_parent;
  std::uint16_t flags = 0;
  std::uint16_t pieces = 1;
  bool next_event = false;
};

/// One generator's records before pooling, in blocks that never move (core/block_list.hpp):
/// no copies as the list grows and no outgrown buffers left as holes in the heap that the pool
/// and the propagation's large arrays cannot reuse (docs/figures.md, session 27). Blocks of 512
/// records (~35 KB in float) and 512 end points (~25 KB): 64 chunks' lists of both sides hold at
/// most ~8 MB they do not fill (4096-record blocks held ~77 MB, the most of a 128 x 128 render's
/// peak: session 31).
///
/// A record drawn from a parent keeps only the end its own draw found: a camera successor and a
/// next-event segment start at their parent's y, a light predecessor ends at its parent's x
/// (paths.hpp), so a path's shared vertices are held once, and restored by unpack (the drawing's
/// peak, records and pool together, is ~35 bytes per segment lower: docs/figures.md, session 37).
template <Real T, Spectrum S>
class RecordList {
 public:
  void push_back(const Record<T, S>& r) {
    fields_.push_back(RecordFields<T, S>{r.first_direction, r.last_direction, r.chain, r.geometry, r.sensor_weight, r.density,
                                         r.pixel, r.parent, r.flags, r.pieces, r.next_event});
    if (r.parent == no_parent) {
      ends_.push_back(r.segment.x);
      ends_.push_back(r.segment.y);
    } else {
      ends_.push_back(starts_at_parent(r.flags) ? r.segment.y : r.segment.x);
    }
  }
  [[nodiscard]] std::size_t size() const noexcept { return fields_.size(); }
  /// The records whose flags have every bit of `flag`.
  [[nodiscard]] std::size_t count(std::uint16_t flag) const noexcept {
    std::size_t n = 0;
    for (std::size_t k = 0; k < fields_.size(); ++k) n += (fields_[k].flags & flag) == flag ? 1 : 0;
    return n;
  }
  /// Bytes of the blocks held, and of those the records do not fill.
  [[nodiscard]] std::size_t capacity_bytes() const noexcept { return fields_.capacity_bytes() + ends_.capacity_bytes(); }
  [[nodiscard]] std::size_t unfilled_bytes() const noexcept {
    return capacity_bytes() - fields_.size() * sizeof(RecordFields<T, S>) - ends_.size() * sizeof(SurfacePoint<T>);
  }

  /// f(fields, x, y) for every record in order, with both its ends: an end the record does not
  /// hold is read from `segment_of(parent)`, the segment its parent (an earlier record) became.
  template <class SegmentOf, class F>
  void unpack(const SegmentOf& segment_of, F&& f) const {
    std::size_t e = 0;
    for (std::size_t k = 0; k < fields_.size(); ++k) {
      const RecordFields<T, S>& r = fields_[k];
      if (r.parent == no_parent) {
        f(r, ends_[e], ends_[e + 1]);
        e += 2;
      } else if (starts_at_parent(r.flags)) {
        f(r, segment_of(r.parent).y, ends_[e++]);
      } else {
        f(r, ends_[e++], segment_of(r.parent).x);
      }
    }
  }

 private:
  /// A camera-born record with a parent starts where its parent ends; a light-born one ends
  /// where its parent starts.
  [[nodiscard]] static bool starts_at_parent(std::uint16_t flags) noexcept { return (flags & camera_born) != 0; }

  BlockList<RecordFields<T, S>, 512> fields_;
  BlockList<SurfacePoint<T>, 512> ends_;
};

}  // namespace segpath::filtering
