// Accumulation images for iteration-based algorithms (BDPT, photon mapping, VCM, the
// filtering methods), and deterministic splatting: contributions that land on arbitrary
// pixels (light-side connections) are recorded per fixed work chunk and applied in chunk
// order, so an image never depends on the thread count.
#pragma once

#include "segpath/core/block_list.hpp"
#include "segpath/core/drop.hpp"
#include "segpath/core/spectrum.hpp"

#include <cstdint>
#include <span>
#include <stdexcept>
#include <algorithm>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace segpath {

template <Spectrum S>
class Framebuffer {
 public:
  /// Throws std::invalid_argument for a side of 0, or 2^32 pixels or more (pixel indices are
  /// 32-bit), before allocating anything.
  Framebuffer(std::uint32_t width, std::uint32_t height)
      : width_(width), height_(height), pixels_(checked_pixel_count(width, height), S(spectrum_scalar_t<S>(0))) {}
  [[nodiscard]] std::uint32_t width() const noexcept { return width_; }
  [[nodiscard]] std::uint32_t height() const noexcept { return height_; }
  [[nodiscard]] std::uint32_t pixel_count() const noexcept { return std::uint32_t(pixels_.size()); }
  [[nodiscard]] const S& operator[](std::uint32_t pixel) const noexcept { return pixels_[pixel]; }
  [[nodiscard]] S& operator[](std::uint32_t pixel) noexcept { return pixels_[pixel]; }
  [[nodiscard]] std::span<const S> pixels() const noexcept { return pixels_; }
  [[nodiscard]] std::span<S> pixels() noexcept { return pixels_; }
  void add(std::uint32_t pixel, const S& value) noexcept { pixels_[pixel] += value; }
  void clear() noexcept { std::fill(pixels_.begin(), pixels_.end(), S(spectrum_scalar_t<S>(0))); }
  Framebuffer& operator+=(const Framebuffer& other) {
    if (other.pixels_.size() != pixels_.size()) throw std::invalid_argument("segpath::Framebuffer: size mismatch");
    for (std::size_t i = 0; i < pixels_.size(); ++i) pixels_[i] += other.pixels_[i];
    return *this;
  }

 private:
  static std::size_t checked_pixel_count(std::uint32_t width, std::uint32_t height) {
    if (width == 0 || height == 0) throw std::invalid_argument("segpath::Framebuffer: width and height must be >= 1");
    if (std::uint64_t(width) * height > std::numeric_limits<std::uint32_t>::max())
      throw std::invalid_argument("segpath::Framebuffer: " + std::to_string(width) + " x " + std::to_string(height) +
                                  " pixels are more than 32-bit pixel indices address");
    return std::size_t(width) * height;
  }

  std::uint32_t width_, height_;
  std::vector<S> pixels_;
};

/// One work chunk's recorded splats, in blocks that never move (16 KB for an RGB float
/// spectrum): no doubling as a chunk records, no outgrown buffers left in the heap.
template <Spectrum S>
using SplatList = BlockList<std::pair<std::uint32_t, S>, 1024>;

/// A ContributionSink for one work chunk: finite values are recorded, the rest counted.
template <Spectrum S>
struct ChunkSink {
  SplatList<S>* splats;
  DropCounters* drops;
  void add(std::uint32_t pixel, const S& value) {
    if (is_finite(value)) splats->push_back({pixel, value});
    else drops->add(DropReason::non_finite);
  }
  void drop(DropReason r) noexcept { drops->add(r); }
};

/// Records splats of `chunks` work chunks (a number fixed by the algorithm, never by the
/// thread count) and applies them chunk by chunk, in recording order within each chunk.
template <Spectrum S>
class SplatRecorder {
 public:
  explicit SplatRecorder(std::size_t chunks) : splats_(chunks), drops_(chunks) {}
  [[nodiscard]] std::size_t chunks() const noexcept { return splats_.size(); }
  /// Bytes of the splats the last apply() added (unused capacity not counted): what an
  /// iteration's recording held at its largest.
  [[nodiscard]] std::size_t applied_bytes() const noexcept { return applied_bytes_; }
  /// Forgets what was recorded and not applied (an iteration that threw), keeping the blocks.
  void clear() noexcept {
    for (auto& list : splats_) list.clear();
    for (auto& d : drops_) d = {};
  }
  /// The sink of one chunk; use it from one thread at a time.
  [[nodiscard]] ChunkSink<S> sink(std::size_t chunk) noexcept { return {&splats_[chunk], &drops_[chunk]}; }
  /// Adds every recorded splat to `image` in chunk order, merges the drop counts, and
  /// clears the recorder for the next iteration.
  void apply(Framebuffer<S>& image, DropCounters& drops) {
    applied_bytes_ = 0;
    for (std::size_t c = 0; c < splats_.size(); ++c) {
      const SplatList<S>& list = splats_[c];
      applied_bytes_ += list.size() * sizeof(typename SplatList<S>::value_type);
      for (std::size_t i = 0; i < list.size(); ++i) image.add(list[i].first, list[i].second);
      splats_[c].clear();
      drops += drops_[c];
      drops_[c] = {};
    }
  }

 private:
  std::vector<SplatList<S>> splats_;
  std::vector<DropCounters> drops_;
  std::size_t applied_bytes_ = 0;
};

}  // namespace segpath
