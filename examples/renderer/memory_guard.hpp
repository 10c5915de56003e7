// segpath-render's memory guard (issue 14): a render's peak memory estimated before it starts,
// from a small pilot render, and checked against --memory-limit or what the machine has; and the
// process's own resident sizes that the estimate starts from and --stats reports.
#pragma once

#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "integrators.hpp"
#include "options.hpp"
#include "tbb_parallel.hpp"

namespace renderer {

/// "12.3 kB", "12.3 MB" or "2.29 GB".
inline std::string memory_size(std::uint64_t bytes) {
  char text[32];
  if (bytes < 1000000ull)
    std::snprintf(text, sizeof text, "%.1f kB", double(bytes) * 1e-3);
  else if (bytes < 1000000000ull)
    std::snprintf(text, sizeof text, "%.1f MB", double(bytes) * 1e-6);
  else
    std::snprintf(text, sizeof text, "%.2f GB", double(bytes) * 1e-9);
  return text;
}

/// Bytes of memory the machine has available (MemAvailable of /proc/meminfo); 0 if unknown.
inline std::uint64_t available_bytes() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  std::uint64_t kib = 0;
  std::string unit;
  while (meminfo >> key >> kib >> unit)
    if (key == "MemAvailable:") return kib * 1024;
  return 0;
}

/// Bytes this process has resident now (the second field of /proc/self/statm); 0 if unknown.
inline std::uint64_t resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t size = 0, resident = 0;
  if (!(statm >> size >> resident)) return 0;
  const long page = ::sysconf(_SC_PAGESIZE);
  return page > 0 ? resident * std::uint64_t(page) : 0;
}

/// This process's peak resident size so far (VmHWM of /proc/self/status), in bytes; 0 if unknown.
inline std::uint64_t peak_resident_bytes() {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "VmHWM:") {
      std::uint64_t kib = 0;
      return status >> kib ? kib * 1024 : 0;
    }
    status.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
  }
  return 0;
}

/// The estimate's factor on what LT, BDPT and the VCM family keep in proportion to their light
/// paths, at its size (light_path_bytes): the heap around the lists and the vectors' spare 1/8
/// (resize_for_overwrite). Measured as (peak - PT's peak) / the scaled light_path_bytes at
/// 1.02-1.05 (docs/figures.md, session 31).
inline constexpr double light_path_slack = 1.05;

/// The memory estimate's pilot render: at most 64 x 64 pixels, fewer (down to 32 x 32) where a
/// large --beta would give it more than pilot_light_paths light paths, and at most
/// pilot_most_beta light paths a pixel (beyond that it lowers its beta and scales what the light
/// paths keep back up), so that the pilot itself stays small (docs/figures.md, session 53).
inline constexpr double pilot_most_pixels = 64.0 * 64, pilot_least_pixels = 32.0 * 32,
                        pilot_most_beta = 64;
inline constexpr double pilot_light_paths = pilot_least_pixels * pilot_most_beta;

/// A render's estimated peak memory, in bytes: the transfer cache of the filtering methods apart.
struct PeakEstimate {
  double rest = 0;   ///< bytes besides the transfer cache
  double cache = 0;  ///< the transfer cache's bytes (filtering methods)
  double pool = 0;   ///< in rest: one pass's pool (filtering methods; --passes divides it)
  double light_paths =
      0;  ///< in rest: LT's splats, BDPT's and the VCM family's light subpaths (--beta scales them)
  double process =
      0;  ///< in rest: what the process has resident before the render (scene, BVH, libraries)
  /// In bytes, saturated: an absurd --beta may estimate more than a std::uint64_t holds.
  [[nodiscard]] std::uint64_t total() const noexcept {
    return std::uint64_t(std::min(rest + cache, 0x1p63));
  }
};

/// A renderer method whose iteration keeps paths in proportion to the image: the filtering
/// methods' pool (their FilteringStats), BDPT's and the VCM family's light subpaths, or LT's
/// splats.
template <class M>
concept KeepsPaths = requires(M& m) {
  m.last_stats();
}
|| requires(M& m) { m.method().light_path_bytes(); };

/// The peak memory a render of `scene` will need, estimated before it starts: what the process
/// has resident now (the scene loaded), and a few images of the full size that every method
/// keeps. The rest is measured by one iteration of a pilot render of
/// at most 64 x 64 pixels (aspect kept; same scene, method and options) and scaled by the
/// pixels: LT's splats, BDPT's and the VCM family's light subpaths (their scratch), and the
/// filtering methods' pool of every segment of an iteration's pass (--passes; the pilot draws one),
/// the pair table's share included. For those, the pilot's voxel is as many of its pixel footprints
/// as the render's is of its own, so that its clusters hold as many segments and pairs as the
/// render's (an automatic voxel is that already; a --radius is scaled). Plus the transfer cache
/// up to its budget, scaled linearly (a pass's pool has 1 / passes of the pairs or fewer).
/// docs/figures.md compares the estimate with the peak resident size.
inline PeakEstimate estimated_peak(const Options& o, const MethodOptions& mo,
                                   const RenderScene& scene, const Method& render_method,
                                   double held_image_bytes) {
  const double pixels = double(o.width) * double(o.height);
  PeakEstimate estimate;
  double& bytes = estimate.rest;
  estimate.process = double(resident_bytes());  // before the pilot allocates anything
  // The accumulator (double RGB), the method's image, the output image; a resumed checkpoint's
  // sum, already resident, becomes the accumulator.
  bytes = estimate.process + std::max(0.0, 64.0 * pixels - held_image_bytes);
  if (!std::visit([](const auto& m) { return KeepsPaths<std::remove_cvref_t<decltype(m)>>; },
                  render_method))
    return estimate;
  // At most 64 x 64 pixels, the render's aspect kept (one side may shrink to 1 pixel), and
  // fewer where a large --beta would give it more than pilot_light_paths light paths: at the
  // same beta and voxel in footprints, a smaller pilot keeps the render's density of segments.
  Options pilot = o;
  const double pilot_pixels =
      std::clamp(pilot_light_paths / mo.beta.value_or(1.0), pilot_least_pixels, pilot_most_pixels);
  const double shrink = std::min(1.0, std::sqrt(pilot_pixels / pixels));
  pilot.width = std::max<std::uint32_t>(1, std::uint32_t(std::lround(o.width * shrink)));
  pilot.height = std::max<std::uint32_t>(1, std::uint32_t(std::lround(o.height * shrink)));
  const RenderScene pilot_scene = load_scene(pilot);
  MethodOptions quiet = mo;
  quiet.print_stats = false;
  quiet.passes = 1;  // (the pilot's pixels may be fewer than the passes)
  // A pixel footprint is a distance times the side of a pixel's solid angle, which scales as
  // 1 / sqrt(the camera's inverse pixel area): the pilot's footprint over the render's.
  const double footprints = std::sqrt(double(scene.sensor().inverse_pixel_area()) /
                                      double(pilot_scene.sensor().inverse_pixel_area()));
  if (quiet.radius)
    *quiet.radius = std::min(*quiet.radius * footprints, double(std::numeric_limits<float>::max()));
  // Beyond pilot_most_beta the pilot's beta is lowered, and what its light paths keep is
  // scaled back by light_scale (a lower bound: denser clusters hold more pairs a segment).
  double light_scale = 1;
  if (quiet.beta && *quiet.beta > pilot_most_beta) {
    light_scale = *quiet.beta / pilot_most_beta;
    quiet.beta = pilot_most_beta;
  }
  auto method = make_method(o.method, quiet);
  Stats stats;
  std::optional<segpath::FilteringStats> f;
  double pilot_light_path_bytes = 0;
  std::visit(
      [&](auto& m) {
        if constexpr (KeepsPaths<std::remove_cvref_t<decltype(m)>>) {
          m.iterate(pilot_scene, stats, TbbFor{});
          if constexpr (requires { m.last_stats(); })
            f = m.last_stats();
          else {
            pilot_light_path_bytes = double(m.method().light_path_bytes());
            estimate.light_paths = double(m.method().fixed_scratch_bytes());
          }
        }
      },
      *method);
  const double scale = pixels / (double(pilot.width) * double(pilot.height));
  // LT, BDPT and the VCM family: the light subpaths' ends, photon grid and splats, in proportion
  // to the light paths (--beta x pixels), with a factor for the heap around them (measured:
  // docs/figures.md, session 31), besides their fixed scratch.
  estimate.light_paths += light_path_slack * pilot_light_path_bytes * scale * light_scale;
  bytes += estimate.light_paths;
  if (!f) return estimate;
  // The pool of one pass, and 10 % for the heap's holes around it (docs/figures.md, session 27),
  // and the records' unfilled blocks, as many as the pilot's whatever the size. Light segments
  // grow by light_scale besides.
  const double segments =
      (double(f->segments) + (light_scale - 1) * double(f->light_segments)) * scale;
  estimate.pool = 1.1 * segments * double(f->bytes_per_segment) / double(mo.passes) +
                  double(f->record_slack_bytes);
  bytes += estimate.pool;
  const double cache_budget = mo.transfer_cache_mib
                                  ? double(*mo.transfer_cache_mib) * (1 << 20)
                                  : double(segpath::FilteringOptions<float>{}.transfer_cache_bytes);
  // The pair table grows with the segments, the light segments by light_scale.
  const double cache_growth =
      f->segments > 0 ? 1.0 + (light_scale - 1) * double(f->light_segments) / double(f->segments)
                      : 1.0;
  estimate.cache = std::min(
      cache_budget, double(f->transfer_cache_bytes) * scale * cache_growth / double(mo.passes));
  return estimate;
}

/// Fits the render into --memory-limit, or else into the memory the machine has available: the
/// estimate (estimated_peak) against the limit. Where the rest fits but the transfer cache does
/// not, the cache gets what the limit leaves and `method` is rebuilt with it
/// (mo.transfer_cache_mib); a render that still does not fit throws, naming the estimate and
/// the options that lower it. `held_image_bytes`: a resumed checkpoint's sum, already resident.
/// `root` prints the cache's limit and, with --stats, the estimate.
inline void fit_in_memory(const Options& o, MethodOptions& mo, const RenderScene& scene,
                          std::optional<Method>& method, double held_image_bytes, bool root) {
  tbb::global_control pilot_threads(tbb::global_control::max_allowed_parallelism, o.threads);
  const PeakEstimate peak = estimated_peak(o, mo, scene, *method, held_image_bytes);
  std::uint64_t estimate = peak.total();
  // In double: a tiny --memory-limit must not round to 0 ("unknown"), a huge one not overflow.
  // The estimate counts the process as it is now; the machine lets it grow by what is available.
  const std::uint64_t available = available_bytes();
  const double limit = o.memory_limit_gb ? *o.memory_limit_gb * 1e9
                       : available       ? double(available) + peak.process
                                         : 0.0;
  // Segment filtering has a transfer cache and passes; --beta scales the light paths where a method
  // reads it.
  const bool filtering = std::visit(
      [](const auto& m) { return std::decay_t<decltype(m)>::filtering_mode.has_value(); }, *method);
  const bool has_light_paths =
      resolved_settings(o.method, mo).value_or(ResolvedSettings{}).beta.has_value();
  const char* const limit_name =
      o.memory_limit_gb ? "--memory-limit" : "the memory available to this process";
  if (limit > 0 && peak.process >= limit)
    throw std::runtime_error("this process holds " + memory_size(std::uint64_t(peak.process)) +
                             " before it renders, more than " + limit_name + " (" +
                             memory_size(std::uint64_t(std::min(limit, 1e19))) + ")");
  // The transfer cache only buys speed: unless --transfer-cache fixes it, it gets what the
  // limit leaves (whole MiB), and only the rest of the render can be refused.
  if (filtering && !o.transfer_cache_mib && limit > 0 && double(estimate) > limit &&
      peak.rest < limit) {
    mo.transfer_cache_mib = std::size_t((limit - peak.rest) / double(1 << 20));
    estimate = std::uint64_t(peak.rest + double(*mo.transfer_cache_mib) * double(1 << 20));
    method = make_method(o.method, mo);
    if (root)
      std::fprintf(stderr,
                   "segpath-render: the transfer cache is limited to %zu MiB to keep the render "
                   "within %s (%s)\n",
                   *mo.transfer_cache_mib, limit_name,
                   memory_size(std::uint64_t(std::min(limit, 1e19))).c_str());
  }
  if (limit > 0 && double(estimate) > limit) {
    // The fewest passes whose pool fits beside the rest (process, images) and a fixed
    // --transfer-cache, with 10 % to spare (the estimate of a render in more passes is not
    // exactly proportional).
    const double besides_pool = peak.rest - peak.pool,
                 room = limit - besides_pool - (o.transfer_cache_mib ? peak.cache : 0);
    // Named only where the scene allows that many (check_passes would refuse it again).
    const double passes = room > 0 ? std::floor(1.1 * peak.pool * double(mo.passes) / room) + 1 : 0;
    const double allowed = std::visit(
        [&](const auto& m) -> double {
          if constexpr (requires { m.max_passes(scene, mo); })
            return double(std::min<std::uint64_t>(m.max_passes(scene, mo), 65536));
          else
            return 0;
        },
        *method);
    std::vector<std::string> lower;
    if (filtering && peak.rest >= limit && passes > double(mo.passes) && passes <= allowed)
      lower.push_back("--passes " + std::to_string(std::uint64_t(passes)));
    if (filtering && peak.rest < limit) lower.push_back("--transfer-cache");
    if (has_light_paths) lower.push_back("--beta");
    std::string options;
    for (const std::string& option : lower) options += option + ", ";
    if (!options.empty()) options.replace(options.size() - 2, 2, " or ");
    throw std::runtime_error("this render needs about " + memory_size(estimate) + ", more than " +
                             limit_name + " (" + memory_size(std::uint64_t(std::min(limit, 1e19))) +
                             "); lower it with " + options + "--width/--height");
  }
  if (o.stats && root)
    std::fprintf(stderr, "segpath-render: estimated peak memory %s (transfer cache %s)\n",
                 memory_size(estimate).c_str(),
                 memory_size(estimate - std::min(estimate, std::uint64_t(peak.rest))).c_str());
}

}  // namespace renderer
