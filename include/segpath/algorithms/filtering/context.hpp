// The state of one filtering iteration that every stage reads or fills: the scene, the options,
// the iteration's random stream, the pool and the counters (instead of long argument lists).
#pragma once

#include "segpath/algorithms/filtering/options.hpp"
#include "segpath/algorithms/filtering/pool.hpp"
#include "segpath/algorithms/filtering/technique_set.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/format.hpp"
#include "segpath/core/poisson.hpp"
#include "segpath/core/rng.hpp"
#include "segpath/kernels/voxel.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace segpath::filtering {

/// N_L: light paths per iteration, beta x #pixels (none for MVF), rounded; saturated at the
/// largest std::uint64_t (check_passes refuses far fewer).
template <LightSampledScene Scn>
[[nodiscard]] std::uint64_t light_path_count(const Scn& scene, const TechniqueSet& techniques) noexcept {
  const double n = std::round(techniques.light_paths_per_pixel * double(scene.sensor().pixel_count()));
  return n < 0x1p64 ? std::uint64_t(n) : std::numeric_limits<std::uint64_t>::max();
}

/// The most light paths one pass may draw: a pass's pool indexes its segments in 32 bits
/// (no_parent is the largest index), and a light path may pool one segment or more.
inline constexpr std::uint64_t max_light_paths_per_pass = no_parent - 1;

/// Pass `pass`'s share of an iteration's `total` draws in `passes` passes (FilteringOptions::
/// pixel_passes): total / passes, and one more for the first total mod passes passes.
[[nodiscard]] constexpr std::uint64_t pass_share(std::uint64_t total, std::uint32_t pass, std::uint32_t passes) noexcept {
  return total / passes + (pass < total % passes ? 1 : 0);
}

/// The most pixel passes (FilteringOptions::pixel_passes) `scene` allows: one pixel each and,
/// where the method draws light paths, at least one light path each (a pass without light paths
/// would miss every path only a light start draws: a point light's caustics, all of PhF).
template <LightSampledScene Scn, Real T>
[[nodiscard]] std::uint64_t max_passes(const Scn& scene, const FilteringOptions<T>& options) noexcept {
  const std::uint64_t pixels = scene.sensor().pixel_count();
  const TechniqueSet techniques = technique_set(options);
  return techniques.light_paths_per_pixel > 0 ? std::min(pixels, light_path_count(scene, techniques)) : pixels;
}

/// Throws std::invalid_argument, naming the bound, where FilteringOptions::pixel_passes exceeds
/// max_passes(scene, options), or where a pass would draw more than max_light_paths_per_pass
/// light paths (beta x #pixels / passes).
template <LightSampledScene Scn, Real T>
void check_passes(const Scn& scene, const FilteringOptions<T>& options) {
  const std::uint64_t pixels = scene.sensor().pixel_count(), passes = options.pixel_passes;
  if (const std::uint64_t light_paths = light_path_count(scene, technique_set(options));
      pass_share(light_paths, 0, std::uint32_t(passes)) > max_light_paths_per_pass)
    throw std::invalid_argument("segpath::SegmentFiltering: beta x #pixels = " + std::to_string(light_paths) +
                                " light paths an iteration in " + std::to_string(passes) + " pixel pass(es), more than a pass's pool "
                                "can index (" + std::to_string(max_light_paths_per_pass) + " a pass): lower beta or use more passes");
  if (passes <= max_passes(scene, options)) return;
  if (const TechniqueSet techniques = technique_set(options); techniques.light_paths_per_pixel > 0 && light_path_count(scene, techniques) == 0)
    throw std::invalid_argument("segpath::SegmentFiltering: beta " + format_number(techniques.light_paths_per_pixel) + " x " +
                                std::to_string(pixels) + " pixels rounds to no light path an iteration: use beta >= 1 / #pixels = " +
                                format_number(1.0 / double(pixels)));
  if (passes > pixels)
    throw std::invalid_argument("segpath::SegmentFiltering: " + std::to_string(passes) + " pixel passes for " +
                                std::to_string(pixels) + " pixels: use at most one pass per pixel");
  const std::uint64_t light_paths = light_path_count(scene, technique_set(options));
  throw std::invalid_argument("segpath::SegmentFiltering: " + std::to_string(passes) + " pixel passes for " +
                              std::to_string(light_paths) + " light paths an iteration leave passes without light paths: "
                              "use at most " + std::to_string(light_paths) + " passes, or raise beta");
}

template <LightSampledScene Scn>
struct Context {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  const Scn& scene;
  const FilteringOptions<T>& options;
  /// The random stream of the iteration (iteration index + 1: the streams of the images
  /// recorded in tests/renderer/golden).
  std::uint64_t stream = 1;
  /// Which of the library's techniques draw (technique_set(options) unless a caller says otherwise).
  TechniqueSet techniques = technique_set(options);
  Pool<T, S> pool{};
  FilteringStats stats{};
  /// Where set (render_pass on the voxel support: the iteration's own grid), a light path's
  /// predecessor draw and a camera path's successor draw (with its next-event draw) are
  /// technique samples only at the path's first visit of a voxel of this grid, keyed by the
  /// scene's canonical position as the clustering keys; at a repeat visit the draw still
  /// continues the path, but what it draws is repeat_visit_born and joins no chain. Counted at
  /// every visit, a path's own later visits in the cluster of one of its segments raised that
  /// segment's D exactly when the segment had been drawn, so BDPF was O(1 / N_L) dark
  /// (docs/filtering.md, "Known limits").
  std::optional<VoxelGrid<T>> visit_grid{};
  /// The same rule on the disk support (render_pass: the iteration's disk radius r): a draw is
  /// a technique sample only where no earlier technique sample of its path lies within 2 r
  /// (canonical positions, as DiskJunctions measures), so no disk of radius r, around whatever
  /// segment end, holds two technique samples of one path, as no voxel does. 0: every visit
  /// counts.
  T visit_radius = 0;
  /// Per pooled segment, sum_u N_u p_u(s) over the user's techniques (empty without any).
  std::vector<T> extra_density{};

  /// The pass of the iteration this pool is drawn for (FilteringOptions::pixel_passes): its
  /// pixels are pass, pass + passes, pass + 2 passes, ...
  std::uint32_t pass = 0, passes = 1;

  /// The pixels of this pass, and the i-th of them.
  [[nodiscard]] std::uint32_t pixels() const noexcept {
    const std::uint64_t all = scene.sensor().pixel_count();
    return all > pass ? std::uint32_t((all - pass + passes - 1) / passes) : 0;
  }
  [[nodiscard]] std::uint32_t pixel(std::uint32_t i) const noexcept { return pass + i * passes; }
  /// The random-stream index of this pass's i-th draw of an unconditional technique (light
  /// paths, the user's techniques, bridges): the passes of an iteration draw disjoint streams.
  [[nodiscard]] std::uint64_t draw_index(std::uint64_t i) const noexcept { return i * passes + pass; }
  /// N_L: light paths of this pass, its share of the iteration's beta x #pixels (pass_share).
  [[nodiscard]] std::uint64_t light_paths() const noexcept {
    return pass_share(light_path_count(scene, techniques), pass, passes);
  }
  /// The light paths this pass draws: with FilteringOptions::poisson_light_paths a Poisson
  /// count of mean light_paths() (from a stream of its own for the iteration and pass), else
  /// light_paths() itself. The densities count light_paths() either way.
  [[nodiscard]] std::uint64_t drawn_light_paths() const {
    const std::uint64_t mean = light_paths();
    if (!options.poisson_light_paths || mean == 0) return mean;
    Pcg32 rng = Pcg32::for_sample(options.seed ^ 0x706f6973736f6eULL /* "poisson" */, pass, stream);
    return sample_poisson(double(mean), rng);
  }
};

}  // namespace segpath::filtering
