// The options of segpath's BDPT / PPM / BPM / VCM implementation (algorithms/vcm.hpp): the
// mode (which techniques an iteration uses), path length, MIS heuristic, merge radius schedule,
// light subpath count, Russian roulette and seed.
#pragma once

#include "segpath/weights/mis.hpp"

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace segpath {

/// Which techniques an iteration uses (SmallVCM's modes):
///  - bdpt: every connection (s, t): camera paths reaching emitters, next-event bridges, bridges
///    between subpath ends, light subpaths bridged to the sensor (t = 1);
///  - ppm: camera paths go through delta scattering to their first non-delta end and gather
///    the light-subpath ends (photons) there with the disk kernel, unweighted (a material with
///    both kinds of lobe: see VertexConnectionMerging's assumptions); light subpaths carry no
///    MIS state;
///  - bpm: gathering at every non-delta camera end, MIS over those merging techniques;
///  - vcm: the union of bdpt's and bpm's techniques under one MIS (UPS).
enum class VcmMode : std::uint8_t { bdpt, ppm, bpm, vcm };

[[nodiscard]] constexpr const char* to_string(VcmMode m) noexcept {
  switch (m) {
    case VcmMode::bdpt: return "bdpt";
    case VcmMode::ppm: return "ppm";
    case VcmMode::bpm: return "bpm";
    case VcmMode::vcm: return "vcm";
  }
  return "unknown";
}

/// The automatic initial merge radius of a mode in average pixel footprints
/// (sensors/pixel_footprint.hpp); sweeps over SmallVCM's four boxes at 10 s in docs/figures.md
/// ("The VCM family's default radius"). VCM: 1.25, below SmallVCM's VCM on every box, where 2
/// (the best geometric mean) lost box 2 by 1.2x: a point light's caustics want small radii, the
/// sun's (box 0) large ones. PPM and BPM, which merge everywhere: 2, as their noise at 1.25 was
/// 1.1-2.3x (boxes 0 and 2, the two radii only). BDPT has no merge radius (0).
[[nodiscard]] constexpr double radius_in_footprints(VcmMode mode) noexcept {
  switch (mode) {
    case VcmMode::vcm: return 1.25;
    case VcmMode::ppm:
    case VcmMode::bpm: return 2.0;
    case VcmMode::bdpt: return 0.0;
  }
  return 0.0;
}

struct VcmOptions {
  VcmMode mode = VcmMode::vcm;
  std::size_t max_length = 10;  ///< segments per path, the sensor segment included (>= 1)
  MisHeuristic heuristic = MisHeuristic::power;
  /// Disk-kernel radius of iteration 0 in scene units; 0 (the default): radius_in_footprints(mode)
  /// average pixel footprints of the scene's sensor (kernel_schedule).
  double initial_radius = 0;
  double alpha = 0.75;           ///< radius schedule r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1), in (0, 1)
  double light_path_factor = 1;  ///< light subpaths per iteration = round(factor * pixels), >= 1
  /// Russian roulette (core/roulette.hpp) after every scattering of a subpath from this many
  /// segments on (0: never). From 1 (SmallVCM's schedule: every scattering) the MIS densities
  /// carry its continuation probabilities, as SmallVCM's do; from a later length the weights
  /// leave it out. Either way they are a partition of unity over the techniques, so the
  /// estimate is unchanged in expectation.
  std::size_t roulette_from = 0;
  std::uint64_t seed = 0;
};

}  // namespace segpath
