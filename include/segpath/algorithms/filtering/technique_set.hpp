// The technique set of segment filtering as data (SPEC 1.6): which of the library's samplers
// draw into the pool, and how many samples each draws per iteration. MVF, PhF and BDPF are
// three sets (technique_set); every stage reads the set, never the method's name. A user's
// own samplers join through FilteringTechnique (techniques.hpp).
#pragma once

#include "segpath/algorithms/filtering/options.hpp"

namespace segpath::filtering {

/// FilteringOptions::camera_continuation where it is automatic: 0.7 for BDPF, whose light paths
/// carry much of what deep camera segments would (at equal time it is 0.64-0.78x the relMSE of no
/// roulette on the four Cornell boxes), 1 (no roulette) for MVF, whose relMSE it raised on three
/// boxes of four (docs/figures.md, session 36).
[[nodiscard]] constexpr double automatic_camera_continuation(FilteringMode mode) noexcept {
  return mode == FilteringMode::bdpf ? 0.7 : 1.0;
}

/// TechniqueSet::camera_tail_continuation without a roulette below max_length: past it a path
/// draws one more segment on average.
inline constexpr double camera_tail_roulette = 0.5;

struct TechniqueSet {
  /// Sensor start (N29): one sensor segment per pixel (every method has it: the gather needs it).
  bool sensor_start = true;
  /// Approximate successors (N31, N33) from every camera technique point: camera paths.
  bool camera_successors = false;
  /// c_c: the probability that a camera path draws a successor at a non-delta vertex (Russian
  /// roulette at every depth); a camera successor's density carries it.
  double camera_continuation = 1;
  /// The camera roulette past max_length: camera paths have no depth limit, and from the end of
  /// their max_length-th segment on they continue with this probability, c_c where c_c < 1,
  /// else 1/2 (the technique samples flagged camera_tail). A path that stopped there would leave
  /// the chains through its last segment no technique sample in the next cluster
  /// (docs/filtering.md, "Known limits": the camera paths' depth limit).
  double camera_tail_continuation = 1;
  /// Light-end bridges (N34, approximate): from every camera technique point, one segment to a
  /// light point drawn by the emitter.
  bool next_event = false;
  /// Light start (N30): light_paths_per_pixel x #pixels light paths; 0: none.
  double light_paths_per_pixel = 0;
  /// Approximate predecessors (N32, N33) from every light technique point: light paths.
  bool light_predecessors = false;
  /// c: the probability that a light path draws a predecessor at a non-delta vertex (Russian
  /// roulette at every depth, no depth limit); a light predecessor's density carries it.
  double light_continuation = 0;
  /// Bridges (N34) from every camera technique point to a light-born start.
  bool bridges = false;
};

/// The technique set of the options' method: MVF camera paths (and next-event segments), PhF
/// sensor segments and light paths, BDPF both (and bridges).
template <Real T>
[[nodiscard]] constexpr TechniqueSet technique_set(const FilteringOptions<T>& o) noexcept {
  TechniqueSet set;
  const bool camera = o.mode != FilteringMode::phf, light = o.mode != FilteringMode::mvf;
  set.camera_successors = camera;
  set.camera_continuation = !camera                          ? 0.0
                            : o.camera_continuation >= T(0) ? double(o.camera_continuation)
                                                            : automatic_camera_continuation(o.mode);
  set.camera_tail_continuation = set.camera_continuation < 1.0 ? set.camera_continuation : camera_tail_roulette;
  set.next_event = camera && o.next_event;
  set.light_paths_per_pixel = light ? double(o.light_path_ratio) : 0.0;
  set.light_predecessors = light;
  set.light_continuation = !light                      ? 0.0
                           : o.light_continuation >= T(0) ? double(o.light_continuation)
                                                          : double(o.max_length - 2) / double(o.max_length - 1);
  set.bridges = o.mode == FilteringMode::bdpf && o.bridges;
  return set;
}

}  // namespace segpath::filtering
