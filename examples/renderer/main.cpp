// segpath-render: renders the four SmallVCM Cornell boxes (or an OBJ scene) with one of
// segpath's methods, for a number of iterations or a time budget, and writes EXR/PFM/PNG
// images; optionally reports RMSE and relMSE against a reference. `segpath-render --help`.
#include "cornell.hpp"
#include "image_io.hpp"
#include "integrators.hpp"
#include "options.hpp"
#include "tbb_parallel.hpp"

#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <cstdlib>
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

using renderer::Options;
using renderer::joined;
using renderer::ends_with_obj;

/// Checks up front that every output can be written (known extension, existing directory),
/// so a long render is not lost at the end.
void check_outputs(const Options& o) {
  for (const auto& path : o.out) {
    if (!renderer::writable_format(path))
      throw std::runtime_error("--out " + path + ": unknown image format (use .exr, .pfm or .png)");
    std::filesystem::path parent = std::filesystem::path(path).parent_path();
    if (parent.empty()) parent = ".";
    std::error_code ec;
    if (!std::filesystem::is_directory(parent, ec))
      throw std::runtime_error("--out " + path + ": directory " + parent.string() + " does not exist");
    if (::access(parent.c_str(), W_OK) != 0)
      throw std::runtime_error("--out " + path + ": directory " + parent.string() + " is not writable");
  }
}

renderer::RenderScene load_scene(const Options& o) {
  for (int box = 0; box < 4; ++box)
    if (o.scene == "cornell" + std::to_string(box)) return renderer::make_cornell(box, o.width, o.height);
  if (ends_with_obj(o.scene)) {
#if SEGPATH_RENDER_HAS_OBJ
    if (!std::filesystem::is_regular_file(o.scene)) throw std::runtime_error("--scene " + o.scene + ": no such file");
    renderer::ObjCamera camera;
    camera.position = renderer::parse_vec3(o.camera_position);
    camera.target = renderer::parse_vec3(o.camera_target);
    camera.up = renderer::parse_vec3(o.camera_up);
    camera.fov_y_degrees = o.fov;
    return renderer::load_obj_scene(o.scene, camera, o.width, o.height);
#else
    throw std::runtime_error("--scene " + o.scene + ": this build has no OBJ loader (examples/renderer/obj_scene.hpp)");
#endif
  }
  throw std::runtime_error("--scene " + o.scene + ": unknown scene (use cornell0, cornell1, cornell2, cornell3 or a .obj file)");
}

/// "12.3 kB", "12.3 MB" or "2.29 GB".
std::string memory_size(std::uint64_t bytes) {
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
std::uint64_t available_bytes() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  std::uint64_t kib = 0;
  std::string unit;
  while (meminfo >> key >> kib >> unit)
    if (key == "MemAvailable:") return kib * 1024;
  return 0;
}

/// The peak memory a render will need, estimated before it starts. Every method keeps a few
/// images of the full size; the filtering methods also pool every segment of an iteration, whose
/// number per pixel one iteration of a pilot render 64 pixels wide (same scene, method and
/// options) measures, plus their transfer cache up to its budget (scaled linearly: with a fixed
/// --radius the full render's clusters are fuller and the cache nearer its budget). Measured against the peak
/// resident size of BDPF on the four boxes and PhF on box 1 it is 0.94-1.11x (docs/figures.md).
std::uint64_t estimated_peak_bytes(const Options& o, const renderer::MethodOptions& mo) {
  const double pixels = double(o.width) * double(o.height);
  double bytes = 64.0 * pixels;  // accumulator (double RGB), the method's image, the output image
  if (o.method != "mvf" && o.method != "phf" && o.method != "bdpf") return std::uint64_t(bytes);
  // At most 64 x 64 pixels, the render's aspect kept (one side may shrink to 1 pixel).
  Options pilot = o;
  const double shrink = std::min(1.0, 64.0 / std::sqrt(pixels));
  pilot.width = std::max<std::uint32_t>(1, std::uint32_t(std::lround(o.width * shrink)));
  pilot.height = std::max<std::uint32_t>(1, std::uint32_t(std::lround(o.height * shrink)));
  const renderer::RenderScene scene = load_scene(pilot);
  renderer::MethodOptions quiet = mo;
  quiet.print_stats = false;
  auto method = renderer::make_method(o.method, quiet);
  renderer::Stats stats;
  std::optional<segpath::FilteringStats> f;
  std::visit(
      [&](auto& m) {
        if constexpr (requires { m.last_stats(); }) {
          m.iterate(scene, stats, renderer::TbbFor{});
          f = m.last_stats();
        }
      },
      *method);
  if (!f) return std::uint64_t(bytes);
  const double scale = pixels / (double(pilot.width) * double(pilot.height));
  // The pool, with the growth of its per-chunk record lists (measured: ~1.1x the pool).
  bytes += 1.1 * double(f->segments) * scale * double(f->bytes_per_segment);
  const double cache_budget = mo.transfer_cache_mib ? double(*mo.transfer_cache_mib) * (1 << 20)
                                                    : double(segpath::FilteringOptions<float>{}.transfer_cache_bytes);
  bytes += std::min(cache_budget, double(f->transfer_cache_bytes) * scale);
  return std::uint64_t(bytes);
}


/// A progress bar with ETA on stderr, only when stderr is a terminal, redrawn at most ten
/// times per second.
class Progress {
 public:
  Progress() : enabled_(::isatty(STDERR_FILENO) == 1) {}
  void update(double fraction, double elapsed) {
    if (!enabled_) return;
    const auto now = Clock::now();
    if (drawn_ && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    drawn_ = true;
    fraction = std::clamp(fraction, 0.0, 1.0);
    constexpr int width = 40;
    const int filled = int(fraction * width);
    std::string bar(std::size_t(filled), '#');
    bar.resize(width, '.');
    const double eta = fraction > 0 ? elapsed * (1 - fraction) / fraction : 0;
    std::fprintf(stderr, "\r[%s] %5.1f%%  elapsed %.1f s  ETA %.1f s ", bar.c_str(), 100 * fraction, elapsed, eta);
    std::fflush(stderr);
  }
  void finish() {
    if (enabled_ && drawn_) std::fprintf(stderr, "\r%80s\r", "");
  }

 private:
  bool enabled_;
  bool drawn_ = false;
  Clock::time_point last_{};
};

int run(const Options& o) {
  check_outputs(o);
  std::optional<examples::Image> reference;
  if (o.reference) {
    if (!renderer::readable_format(*o.reference))
      throw std::runtime_error("--reference " + *o.reference + ": use a .pfm or .exr image");
    reference = renderer::read_image(*o.reference);
    if (reference->width != int(o.width) || reference->height != int(o.height))
      throw std::runtime_error("--reference " + *o.reference + " is " + std::to_string(reference->width) + "x" +
                               std::to_string(reference->height) + ", the render is " + std::to_string(o.width) + "x" +
                               std::to_string(o.height));
  }
  const renderer::MethodOptions mo = renderer::method_options(o);
  auto method = renderer::make_method(o.method, mo);
  if (!method) throw std::runtime_error("--method " + o.method + ": unknown method (use " + joined(renderer::method_names(), ", ") + ")");
  const renderer::RenderScene scene = load_scene(o);
  {
    tbb::global_control pilot_threads(tbb::global_control::max_allowed_parallelism, o.threads);
    const std::uint64_t estimate = estimated_peak_bytes(o, mo);
    // In double: a tiny --memory-limit must not round to 0 ("unknown"), a huge one not overflow.
    const double limit = o.memory_limit_gb ? *o.memory_limit_gb * 1e9 : double(available_bytes());
    const bool filtering = o.method == "mvf" || o.method == "phf" || o.method == "bdpf";
    if (limit > 0 && double(estimate) > limit)
      throw std::runtime_error("this render needs about " + memory_size(estimate) + ", more than " +
                               (o.memory_limit_gb ? "--memory-limit" : "the memory available") + " (" + memory_size(std::uint64_t(std::min(limit, 1e19))) +
                               "); lower it with " + (filtering ? "--transfer-cache, --beta or " : "") + "--width/--height");
    if (o.stats) std::fprintf(stderr, "segpath-render: estimated peak memory %s\n", memory_size(estimate).c_str());
  }
  if (const auto family = renderer::unsampled_family(o.method, scene))
    std::fprintf(stderr, "segpath-render: warning: %s\n", family->c_str());

  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, o.threads);
  tbb::task_arena arena(int(o.threads));
  renderer::Stats stats;
  std::uint64_t iterations = 0;
  Progress progress;
  const auto start = Clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  arena.execute([&] {
    std::visit(
        [&](auto& m) {
          for (;;) {
            if (o.time ? (iterations > 0 && elapsed() >= *o.time) : iterations >= o.spp) break;
            m.iterate(scene, stats, renderer::TbbFor{});
            ++iterations;
            progress.update(o.time ? elapsed() / *o.time : double(iterations) / double(o.spp), elapsed());
          }
        },
        *method);
  });
  const double seconds = elapsed();
  progress.finish();

  // The image: sum / iterations (the sum in double, each iteration's non-finite pixels already
  // dropped); a pixel that does not fit a float is zeroed and counted.
  const renderer::Accumulator& sum = std::visit([](const auto& m) -> const renderer::Accumulator& { return m.sum(); }, *method);
  examples::Image image(int(o.width), int(o.height));
  for (std::uint32_t p = 0; p < sum.pixel_count(); ++p) {
    const auto v = sum[p] / double(iterations);
    const segpath::Rgb<float> f(float(v.r), float(v.g), float(v.b));
    if (segpath::is_finite(f)) {
      image.pixels[p] = f;
    } else {
      image.pixels[p] = segpath::Rgb<float>(0.0f);
      stats.dropped.add(segpath::DropReason::non_finite);
    }
  }
  for (const auto& path : o.out) renderer::write_image(image, path);

  std::string dropped;
  for (std::size_t r = 0; r < segpath::drop_reason_count; ++r)
    dropped += std::string(r ? ", " : "") + segpath::to_string(segpath::DropReason(r)) + " " +
               std::to_string(stats.dropped.counts[r]);
  std::printf("segpath-render: %s %s %ux%u, %llu spp (%llu iterations), %u threads, %.2f s, %.3f M samples/s, %.3f M rays/s, mean %.4f, dropped %llu (%s)",
              std::string(renderer::method_name(*method)).c_str(), scene.name().c_str(), o.width, o.height,
              static_cast<unsigned long long>(iterations), static_cast<unsigned long long>(iterations), o.threads, seconds,
              double(stats.paths) / seconds * 1e-6, double(stats.rays) / seconds * 1e-6, image.mean(),
              static_cast<unsigned long long>(stats.dropped.total()), dropped.c_str());
  if (reference) {
    const auto e = renderer::compare(image, *reference);
    std::printf(", RMSE %.6g, relMSE %.6g", e.rmse, e.relmse);
  }
  std::printf("\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // The filtering methods touch GBs of fresh memory in their first iteration; in 2 MiB pages
  // (glibc's malloc with transparent huge pages, a tunable read at start-up only) that costs a
  // tenth of the page faults: BDPF's first iteration on box 0 10.0 s -> 6.9 s (docs/figures.md).
  // Set once and start again; a GLIBC_TUNABLES of the user's is left alone.
  if (std::getenv("GLIBC_TUNABLES") == nullptr && setenv("GLIBC_TUNABLES", "glibc.malloc.hugetlb=1", 0) == 0)
    execv("/proc/self/exe", argv);  // returns only if it failed: go on without huge pages
  // The filtering methods build pools of a few hundred MB per iteration: keep freed blocks in
  // the heap (glibc would return them with munmap and the kernel zero every page again).
  mallopt(M_MMAP_THRESHOLD, 1 << 30);
  mallopt(M_TRIM_THRESHOLD, -1);
  const renderer::CommandLine command_line = renderer::parse_command_line(argc, argv);
  if (!command_line.options) {
    std::fputs(command_line.message.c_str(), command_line.exit_code == 0 ? stdout : stderr);
    return command_line.exit_code;
  }
  const Options& o = *command_line.options;
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "segpath-render: error: %s\n", e.what());
    return 1;
  }
}
