// segpath-render's command line: its options, their checks (CLI11) and the library options they
// set. Parsing prints nothing and never exits, so a test or a fuzzer can call it
// (tests/fuzz/options_fuzzer.cpp).
#pragma once

#include "cornell.hpp"
#include "integrators.hpp"

// OBJ scenes need the loader (another file of this example) and tinyobjloader (CMake defines
// SEGPATH_RENDER_TINYOBJLOADER where it found it).
#if defined(SEGPATH_RENDER_TINYOBJLOADER) && __has_include("obj_scene.hpp")
#include "obj_scene.hpp"
#define SEGPATH_RENDER_HAS_OBJ 1
#else
#define SEGPATH_RENDER_HAS_OBJ 0
#endif

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace renderer {

struct Options {
  std::string scene = "cornell1";
  std::string method = "pt";
  std::uint64_t spp = 16;
  std::optional<double> time;
  unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  std::uint64_t seed = 1;
  std::uint32_t width = 512, height = 512;
  std::size_t max_length = cornell_max_length;
  std::optional<double> radius;
  std::optional<double> alpha, beta, camera_continuation;
  std::optional<std::size_t> roulette_from;
  std::string support = "voxel";
  bool bridges = false;
  bool next_event = segpath::FilteringOptions<float>{}.next_event;
  std::string weighting = segpath::to_string(segpath::FilteringOptions<float>{}.weighting);
  bool stats = false;
  std::optional<std::size_t> transfer_cache_mib;
  std::uint32_t passes = 1;
  std::optional<double> memory_limit_gb;
  std::vector<std::string> out;
  std::optional<std::string> reference;
  std::optional<std::string> checkpoint, resume;
  double checkpoint_every = 60;  ///< seconds between checkpoints (0: after every iteration round)
  // OBJ scenes only: a look-at camera ("x,y,z" vectors).
  std::string camera_position = "0,0,0", camera_target = "0,1,0", camera_up = "0,0,1";
  float fov = 45;
  /// Every option given on the command line, by its first long name ("--fov", "--next-event"
  /// for --no-next-event too): the warnings about options a scene or method ignores read it.
  std::vector<std::string> given;
};

inline bool ends_with_obj(const std::string& s) {
  if (s.size() < 4) return false;
  std::string ext = s.substr(s.size() - 4);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".obj";
}

inline std::string joined(const std::vector<std::string>& names, const char* separator) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : separator) + n;
  return s;
}

/// A finite number above `least` (or from `least` on, where `inclusive`); the message names the
/// bound as `bound` ("> 0"). CLI::PositiveNumber accepts "inf".
inline CLI::Validator finite_number(double least, bool inclusive, const std::string& bound) {
  return CLI::Validator(
      [=](std::string& s) -> std::string {
        double v = 0;
        if (!CLI::detail::lexical_cast(s, v) || !std::isfinite(v) || !(inclusive ? v >= least : v > least))
          return "must be a finite number " + bound + ", got " + s;
        return {};
      },
      "POSITIVE");
}

/// A positive finite number.
inline const CLI::Validator positive_finite = finite_number(0, false, "> 0");

/// A kernel size: a positive number in the renderer's float (a smaller one would round to 0,
/// which the filtering methods read as "automatic").
inline const CLI::Validator kernel_size = [] {
  const double least = std::numeric_limits<float>::min();
  char text[32];
  std::snprintf(text, sizeof text, ">= %g", least);
  return finite_number(least, true, text);
}();

inline const CLI::Validator unsigned_integer(
    [](std::string& s) -> std::string {
      if (s.empty() || s.size() > 20 || s.find_first_not_of("0123456789") != std::string::npos)
        return "must be an integer >= 0, got " + s;
      return {};
    },
    "");

inline const CLI::Validator open_unit_interval(
    [](std::string& s) -> std::string {
      double v = 0;
      if (!CLI::detail::lexical_cast(s, v) || !(v > 0 && v < 1)) return "must lie in (0, 1), got " + s;
      return {};
    },
    "IN (0,1)");

inline const CLI::Validator half_open_unit_interval(
    [](std::string& s) -> std::string {
      double v = 0;
      if (!CLI::detail::lexical_cast(s, v) || !(v > 0 && v <= 1)) return "must lie in (0, 1], got " + s;
      return {};
    },
    "IN (0,1]");

/// The command line's outcome: options to render with, or an exit code and the text to print
/// (--help: on stdout, code 0; a parse error: on stderr, code 2).
struct CommandLine {
  std::optional<Options> options;
  int exit_code = 0;
  std::string message;
};

/// Parses segpath-render's command line (argv[0] is the program name).
inline CommandLine parse_command_line(int argc, const char* const* argv) {
  Options o;
  CLI::App app("segpath-render: renders a scene with one of segpath's methods and writes EXR/PFM/PNG images.",
               "segpath-render");
  const std::string methods = joined(method_names(), ", ");
  app.add_option("--scene", o.scene, "cornell0, cornell1, cornell2, cornell3 (SmallVCM's boxes) or PATH.obj")
      ->capture_default_str();
  app.add_option("--method", o.method, "rendering method: " + methods)->capture_default_str();
  auto* spp = app.add_option("--spp", o.spp, "iterations (samples per pixel) to render")
                  ->check(unsigned_integer)->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 32))
                  ->capture_default_str();
  app.add_option("--time", o.time, "render until SECONDS of wall time are spent instead of --spp (equal-time runs)")
      ->check(positive_finite)
      ->excludes(spp);
  app.add_option("--threads", o.threads, "worker threads (default: hardware concurrency)")
      ->check(unsigned_integer)->check(CLI::Range(1u, 1024u))
      ->capture_default_str();
  app.add_option("--seed", o.seed, "random seed (an integer >= 0)")->check(unsigned_integer)->capture_default_str();
  app.add_option("--width", o.width, "image width in pixels")->check(unsigned_integer)->check(CLI::Range(1u, 16384u))->capture_default_str();
  app.add_option("--height", o.height, "image height in pixels")->check(unsigned_integer)->check(CLI::Range(1u, 16384u))->capture_default_str();
  app.add_option("--max-length", o.max_length, "segments per path, the camera segment included")
      ->check(unsigned_integer)->check(CLI::Range(std::size_t(1), std::size_t(1000)))
      ->capture_default_str();
  app.add_option("--radius", o.radius,
                 "initial kernel radius (ppm/bpm/vcm; bdpt merges nothing) or voxel size (mvf/phf/bdpf), > 0; default: 1.25x "
                 "(vcm), 2x (ppm/bpm) or 4x (filtering) the average pixel footprint; a kernel spanning the scene's bounding-box "
                 "diagonal is refused, a tenth of it warned about; vcm refuses a radius whose MIS weights would leave float's "
                 "range and names the range that works")
      ->check(kernel_size);
  app.add_option("--alpha", o.alpha, "progressive kernel shrinking, in (0, 1); default 0.75 (vcm family), 0.67 (filtering)")
      ->check(open_unit_interval);
  app.add_option("--beta", o.beta, "light paths per camera path, > 0; default 1")
      ->check(positive_finite);
  app.add_option("--roulette-from", o.roulette_from,
                 "pt/lt/bdpt/ppm/bpm/vcm: Russian roulette after every scattering from this path length (segments) on, "
                 "0: never; default 3 (pt), 1 (bdpt, ppm, bpm, vcm: SmallVCM's), 0 (lt)")
      ->check(unsigned_integer)->check(CLI::Range(std::size_t(0), std::size_t(1000)));
  app.add_option("--camera-continuation", o.camera_continuation,
                 "mvf/bdpf: probability that a camera path continues at a non-delta vertex (Russian roulette at "
                 "every depth), in (0, 1]; default 0.7 (bdpf), 1 (mvf: no roulette; past --max-length segments 1/2)")
      ->check(half_open_unit_interval);
  app.add_option("--support", o.support, "mvf/phf/bdpf: kernel support of the junctions, voxel (the paper's) or disk")
      ->check(CLI::IsMember({"voxel", "disk"}))
      ->capture_default_str();
  app.add_flag("--bridges", o.bridges, "bdpf: also join camera and light paths by bridge segments");
  app.add_flag("--next-event,!--no-next-event", o.next_event,
               "mvf/bdpf: also draw a segment to a light point from every camera path vertex (default: on)");
  app.add_option("--weighting", o.weighting,
                 "bdpf: chain weighting, path (path-conditioned, unbiased) or paper (prod 1 / D, biased)")
      ->check(CLI::IsMember({"path", "paper"}))
      ->capture_default_str();
  app.add_option("--transfer-cache", o.transfer_cache_mib,
                 "mvf/phf/bdpf: MiB of pair transfers cached per iteration (0: none, every sweep evaluates them); "
                 "default 1024, or what --memory-limit leaves")
      ->check(CLI::Range(std::size_t(0), std::size_t(1) << 20));
  app.add_option("--passes", o.passes,
                 "mvf/phf/bdpf: draw each iteration's pool in this many passes over interleaved pixels, "
                 "each with its share of the light paths (memory / passes)")
      ->check(CLI::Range(1u, 1u << 16))
      ->capture_default_str();
  app.add_option("--memory-limit", o.memory_limit_gb,
                 "GB of memory the render may use; a render estimated to need more stops before it starts, "
                 "after the default transfer cache of mvf/phf/bdpf has shrunk to what it leaves (default: the memory available)")
      ->check(positive_finite);
  app.add_flag("--stats", o.stats,
               "print the estimated peak memory and, at the end, the peak resident size on stderr; mvf/phf/bdpf: "
               "also each iteration's segments, clusters, pair evaluations and stage times");
#if SEGPATH_RENDER_HAS_OBJ
  app.add_option("--camera-position", o.camera_position, "OBJ scenes: camera position x,y,z")->capture_default_str();
  app.add_option("--camera-target", o.camera_target, "OBJ scenes: point the camera looks at, x,y,z")->capture_default_str();
  app.add_option("--camera-up", o.camera_up, "OBJ scenes: up direction x,y,z")->capture_default_str();
  app.add_option("--fov", o.fov, "OBJ scenes: vertical field of view in degrees, in (0, 180)")
      ->check(positive_finite)
      ->capture_default_str();
#endif
  app.add_option("--out", o.out, "output image, .exr (float RGB), .pfm or .png (clamped, sRGB); repeatable");
  app.add_option("--reference", o.reference,
                 "reference image (.pfm or .exr): prints RMSE and relMSE, relMSE = mean over pixels and channels of "
                 "(x - r)^2 / (r^2 + 1e-2)");
  auto* checkpoint = app.add_option("--checkpoint", o.checkpoint,
                                    "write the render's state to FILE every --checkpoint-every seconds and at the end "
                                    "(atomically: FILE is always a complete checkpoint)");
  app.add_option("--checkpoint-every", o.checkpoint_every, "seconds between checkpoints; 0: after every iteration (round)")
      ->check(CLI::Range(0.0, 1e9))
      ->needs(checkpoint)
      ->capture_default_str();
  app.add_option("--resume", o.resume,
                 "continue the render saved in FILE (a --checkpoint of a render with the same options) up to --spp "
                 "iterations in all, or for --time more seconds");
  app.footer(
      "Prints one summary line on stdout: method, scene, resolution, samples per pixel (iterations), threads, wall time, "
      "samples and rays (intersect + visible calls) per second, image mean, dropped samples by reason, and with "
      "--reference the RMSE and relMSE (mean over pixels and channels of (x - r)^2 / (r^2 + 1e-2)).\n");
  try {
    app.parse(argc, argv);
    for (const CLI::Option* option : app.get_options())
      if (option->count() > 0) o.given.push_back(option->get_name());
  } catch (const CLI::CallForHelp&) {
    return {std::nullopt, 0, app.help()};
  } catch (const CLI::ParseError& e) {
    return {std::nullopt, 2, std::string("segpath-render: ") + e.what() + " (see --help)\n"};
  } catch (const std::out_of_range&) {
    // CLI11's own conversions may throw the standard library's errors: a flag's value too large
    // for an integer (--no-next-event=8888888888888888888888, found by fuzz/options_fuzzer.cpp)
    // ends in std::stoll's std::out_of_range.
    return {std::nullopt, 2, "segpath-render: a number on the command line is out of range (see --help)\n"};
  } catch (const std::exception& e) {
    return {std::nullopt, 2, std::string("segpath-render: cannot read the command line: ") + e.what() + " (see --help)\n"};
  }
  return {std::move(o), 0, {}};
}

/// A warning where camera options were given for a built-in scene, which has its own camera.
[[nodiscard]] inline std::optional<std::string> ignored_camera_options(const Options& o) {
  if (ends_with_obj(o.scene)) return std::nullopt;
  std::vector<std::string> camera;
  for (const auto& name : o.given)
    if (name == "--camera-position" || name == "--camera-target" || name == "--camera-up" || name == "--fov") camera.push_back(name);
  if (camera.empty()) return std::nullopt;
  return o.scene + " has a camera of its own and ignores " + joined(camera, ", ") + " (the camera of OBJ scenes)";
}

/// The scene --scene names, at the image size, with the OBJ camera options.
inline RenderScene load_scene(const Options& o) {
  for (int box = 0; box < 4; ++box)
    if (o.scene == "cornell" + std::to_string(box)) return make_cornell(box, o.width, o.height);
  if (ends_with_obj(o.scene)) {
#if SEGPATH_RENDER_HAS_OBJ
    if (!std::filesystem::is_regular_file(o.scene)) throw std::runtime_error("--scene " + o.scene + ": no such file");
    ObjCamera camera;
    camera.position = parse_vec3(o.camera_position);
    camera.target = parse_vec3(o.camera_target);
    camera.up = parse_vec3(o.camera_up);
    camera.fov_y_degrees = o.fov;
    return load_obj_scene(o.scene, camera, o.width, o.height);
#else
    throw std::runtime_error("--scene " + o.scene + ": this build has no OBJ loader (examples/renderer/obj_scene.hpp)");
#endif
  }
  throw std::runtime_error("--scene " + o.scene + ": unknown scene (use cornell0, cornell1, cornell2, cornell3 or a .obj file)");
}

/// The library options the command line sets (the method's own defaults where it is silent).
inline MethodOptions method_options(const Options& o) {
  MethodOptions mo;
  mo.seed = o.seed;
  mo.max_length = o.max_length;
  mo.radius = o.radius;
  mo.alpha = o.alpha;
  mo.beta = o.beta;
  mo.camera_continuation = o.camera_continuation;
  mo.roulette_from = o.roulette_from;
  mo.support = o.support == "disk" ? segpath::FilteringSupport::disk : segpath::FilteringSupport::voxel;
  mo.bridges = o.bridges;
  mo.next_event = o.next_event;
  mo.weighting = o.weighting == "paper" ? segpath::FilteringWeighting::paper : segpath::FilteringWeighting::path_conditioned;
  mo.print_stats = o.stats;
  mo.transfer_cache_mib = o.transfer_cache_mib;
  mo.passes = o.passes;
  return mo;
}

/// A warning where options of other methods were given (--radius: kernel_check.hpp): those of
/// method_specific_options that `method` does not read.
[[nodiscard]] inline std::optional<std::string> ignored_method_options(const Options& o, const Method& method) {
  const ResolvedSettings settings = resolved_settings(o.method, method_options(o)).value_or(ResolvedSettings{});
  const auto mode = std::visit([](const auto& m) { return std::decay_t<decltype(m)>::filtering_mode; }, method);
  std::vector<std::string> ignored;
  for (const auto& name : o.given)
    for (const MethodSpecificOption& option : method_specific_options)
      if (name == option.name && !option.read_by(settings, mode))
        ignored.push_back(name == "--next-event" ? "--[no-]next-event" : name);
  if (ignored.empty()) return std::nullopt;
  return o.method + " ignores " + joined(ignored, ", ") + " (options of other methods)";
}

/// The options that decide a render's image for a given iteration count, as "key=value" lines
/// in a fixed order: ranks of one render must agree on them, and a checkpoint resumes only a
/// render with the same ones. (Threads, outputs, --stats, memory and cache options only change
/// how the image is computed.)
inline std::string image_options(const Options& o) {
  std::string text;
  const auto line = [&](const char* key, const std::string& value) { text += std::string(key) + "=" + value + "\n"; };
  const auto number = [](double v) {
    char s[40];
    std::snprintf(s, sizeof s, "%.17g", v);
    return std::string(s);
  };
  const auto optional = [&](const std::optional<double>& v) { return v ? number(*v) : std::string("default"); };
  // A resolved value in its shortest exact form: as a float where it is one (the filtering
  // methods run in float: --alpha 0.67 and their default 0.67f read "0.67"), else as a double.
  const auto resolved_number = [&](const std::optional<double>& v) {
    if (!v) return std::string("default");
    char s[40];
    const float f = float(*v);
    const auto end = double(f) == *v ? std::to_chars(s, s + sizeof s, f).ptr : std::to_chars(s, s + sizeof s, *v).ptr;
    return std::string(s, end);
  };
  line("scene", o.scene);
  line("method", o.method);
  line("seed", std::to_string(o.seed));
  line("width", std::to_string(o.width));
  line("height", std::to_string(o.height));
  line("max-length", std::to_string(o.max_length));
  // Each setting as the method runs with it (ResolvedSettings): a checkpoint written under other
  // defaults is refused rather than resumed with other settings. An automatic kernel depends on
  // the scene: it is recorded by its footprints. Settings the method does not use are recorded
  // as given.
  const ResolvedSettings r = resolved_settings(o.method, method_options(o)).value_or(ResolvedSettings{});
  line("radius", o.radius ? number(*o.radius)
                 : r.kernel_in_footprints ? "default (" + number(*r.kernel_in_footprints) + " footprints)"
                                          : std::string("default"));
  line("alpha", r.alpha ? resolved_number(r.alpha) : optional(o.alpha));
  line("beta", r.beta ? resolved_number(r.beta) : optional(o.beta));
  line("camera-continuation", r.camera_continuation ? resolved_number(r.camera_continuation) : optional(o.camera_continuation));
  const std::optional<std::size_t> roulette_from = r.roulette_from ? r.roulette_from : o.roulette_from;
  line("roulette-from", roulette_from ? std::to_string(*roulette_from) : std::string("default"));
  line("support", o.support);
  line("bridges", o.bridges ? "on" : "off");
  line("next-event", o.next_event ? "on" : "off");
  line("weighting", o.weighting);
  if (ends_with_obj(o.scene)) {
    line("camera-position", o.camera_position);
    line("camera-target", o.camera_target);
    line("camera-up", o.camera_up);
    line("fov", number(o.fov));
  }
  if (o.passes != 1) line("passes", std::to_string(o.passes));  // last: absent from checkpoints of one pass
  return text;
}

}  // namespace renderer
