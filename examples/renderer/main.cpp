// segpath-render: renders the four SmallVCM Cornell boxes (or an OBJ scene) with one of
// segpath's methods, for a number of iterations or a time budget, and writes EXR/PFM/PNG
// images; optionally reports RMSE and relMSE against a reference. `segpath-render --help`.
//
// Started by mpirun (a build with MPI), its ranks split the iterations: in each round rank r
// renders iteration next + r with its own threads and sends the image to rank 0, which adds the
// round's images in iteration order, so the image is bit for bit the one-process image for any
// rank and thread count. With --checkpoint, rank 0 saves the sum and the next iteration index
// (checkpoint.hpp); --resume continues it to the same final image.
#include "checkpoint.hpp"
#include "cornell.hpp"
#include "image_io.hpp"
#include "integrators.hpp"
#include "memory_guard.hpp"
#include "options.hpp"
#include "ranks.hpp"
#include "tbb_parallel.hpp"

#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <cstdlib>
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <span>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

using renderer::Options;
using renderer::joined;
using renderer::ends_with_obj;

/// Checks that `path`'s directory exists and is writable (`option` names it in the error).
void check_directory(const std::string& option, const std::string& path) {
  std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (parent.empty()) parent = ".";
  std::error_code ec;
  if (!std::filesystem::is_directory(parent, ec))
    throw std::runtime_error(option + " " + path + ": directory " + parent.string() + " does not exist");
  if (::access(parent.c_str(), W_OK) != 0)
    throw std::runtime_error(option + " " + path + ": directory " + parent.string() + " is not writable");
}

/// Checks up front that every output can be written (known extension, existing directory),
/// so a long render is not lost at the end.
void check_outputs(const Options& o) {
  for (const auto& path : o.out) {
    if (!renderer::writable_format(path))
      throw std::runtime_error("--out " + path + ": unknown image format (use .exr, .pfm or .png)");
    check_directory("--out", path);
  }
  if (o.checkpoint) check_directory("--checkpoint", *o.checkpoint);
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

/// Runs one stage of the set-up on every rank. When it throws on any rank, every rank learns it
/// and returns false together (none waits for another forever): rank 0 prints its error, or
/// when rank 0 succeeded, each failing rank prints its own. `stage` must make no MPI call.
template <class Stage>
bool on_every_rank(const renderer::Ranks& ranks, Stage&& stage) {
  std::optional<std::string> error;
  try {
    stage();
  } catch (const std::exception& e) {
    error = e.what();
  }
  if (ranks.all(!error)) return true;
  const bool root_failed = ranks.broadcast(ranks.root() && error) != 0;
  if (error && (ranks.root() || !root_failed)) {
    const std::string who = ranks.root() ? "" : " (rank " + std::to_string(ranks.rank()) + ")";
    std::fprintf(stderr, "segpath-render%s: error: %s\n", who.c_str(), error->c_str());
  }
  return false;
}

/// A stage's error (on_every_rank prints it).
[[noreturn]] void fail(const std::string& message) { throw std::runtime_error(message); }

/// --radius against the scene, as the chosen method reads it (renderer::check_kernel).
renderer::KernelCheck kernel_check(const renderer::Options& o, const renderer::Method& method, const renderer::RenderScene& scene) {
  const renderer::RadiusUse use = std::visit([](const auto& m) { return std::decay_t<decltype(m)>::radius_use; }, method);
  return renderer::check_kernel(o.method, use, *o.radius, renderer::scene_diagonal(scene));
}

/// Stats as the counters sent between ranks: paths, rays, then the drops by reason.
constexpr std::size_t stats_words = 2 + segpath::drop_reason_count;
std::array<std::uint64_t, stats_words> stats_words_of(const renderer::Stats& s) {
  std::array<std::uint64_t, stats_words> w{s.paths, s.rays};
  std::copy(s.dropped.counts.begin(), s.dropped.counts.end(), w.begin() + 2);
  return w;
}
renderer::Stats stats_of(const std::array<std::uint64_t, stats_words>& w) {
  renderer::Stats s;
  s.paths = w[0];
  s.rays = w[1];
  std::copy(w.begin() + 2, w.end(), s.dropped.counts.begin());
  return s;
}

/// The signal that asked the render to stop (SIGINT, SIGTERM, SIGUSR1), 0 while none did. The
/// render stops after the current round, writes its checkpoint and images and exits with
/// 128 + the signal; a second signal ends it at once. (mpirun forwards SIGUSR1 to the ranks;
/// on SIGINT and SIGTERM it kills them after a few seconds.)
std::atomic<int> stop_signal{0};
static_assert(std::atomic<int>::is_always_lock_free);  // so that a signal handler may store it

void request_stop(int signal) {
  stop_signal.store(signal);
  std::signal(signal, SIG_DFL);
}

void stop_on_signals() {
  for (const int s : {SIGINT, SIGTERM, SIGUSR1}) std::signal(s, request_stop);
}

/// Where rank 0's time for the other ranks' iterations goes (--stats): waiting for a rank to
/// finish its iteration, receiving its image, adding it to the sum.
struct Reduction {
  std::uint64_t iterations = 0;
  double waiting = 0, receiving = 0, adding = 0;
  void add(Clock::time_point wait, Clock::time_point receive, Clock::time_point add, Clock::time_point end) {
    ++iterations;
    waiting += std::chrono::duration<double>(receive - wait).count();
    receiving += std::chrono::duration<double>(add - receive).count();
    adding += std::chrono::duration<double>(end - add).count();
  }
};

int run(const Options& o, const renderer::Ranks& ranks) {
  const bool root = ranks.root();
  // An OBJ scene is also identified by its bytes: ranks on other machines, or a resume after the
  // file changed, must not mix scenes (its .mtl files are not read here).
  std::string image_options = renderer::image_options(o);
  if (ends_with_obj(o.scene)) {
    std::ifstream obj(o.scene, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(obj)), std::istreambuf_iterator<char>());
    char line[48];
    std::snprintf(line, sizeof line, "scene-content=%016llx\n",
                  static_cast<unsigned long long>(renderer::detail::fnv1a(bytes)));
    image_options += line;
  }

  // Every rank must render the same image: compare a hash of the options that decide it.
  {
    char count[48];
    std::snprintf(count, sizeof count, o.time ? "time=%.17g\n" : "spp=%.0f\n", o.time ? *o.time : double(o.spp));
    const std::string options = image_options + count;
    const int other = ranks.first_differing(renderer::detail::fnv1a(options));
    const std::string theirs = other < 0 ? std::string() : ranks.text_of(other, options);
    if (!on_every_rank(ranks, [&] {
          if (other >= 0 && root)
            fail("rank " + std::to_string(other) + " was started with other options than rank 0 (" +
                 renderer::first_difference(options, theirs, "rank 0", "rank " + std::to_string(other)) +
                 "); start every rank with the same command line");
          if (other >= 0) fail("");
        }))
      return 1;
  }

  // Rank 0's inputs and outputs: the images it will write, the reference, the checkpoint.
  std::optional<examples::Image> reference;
  std::optional<renderer::Checkpoint> resumed;
  if (!on_every_rank(ranks, [&] {
        if (!root) return;
        check_outputs(o);
        if (o.reference) {
          if (!renderer::readable_format(*o.reference))
            fail("--reference " + *o.reference + ": use a .pfm or .exr image");
          reference = renderer::read_image(*o.reference);
          if (reference->width != int(o.width) || reference->height != int(o.height))
            fail("--reference " + *o.reference + " is " + std::to_string(reference->width) + "x" +
                 std::to_string(reference->height) + ", the render is " + std::to_string(o.width) + "x" +
                 std::to_string(o.height));
          // Checked here, not after the render (renderer::compare refuses it too).
          if (std::ranges::any_of(reference->pixels, [](const auto& p) { return !segpath::is_finite(p); }))
            fail("--reference " + *o.reference + " contains NaN or infinite values: a reference must be finite");
        }
        if (o.resume) {
          resumed = renderer::read_checkpoint(*o.resume);
          if (const std::string d = renderer::first_difference(resumed->options, image_options, "the checkpoint", "this render");
              !d.empty())
            fail("--resume " + *o.resume + ": written by a render with other options (" + d + ")");
          if (resumed->sum.width() != o.width || resumed->sum.height() != o.height)
            fail("--resume " + *o.resume + ": the checkpoint is corrupt (a " + std::to_string(resumed->sum.width()) + " x " +
                 std::to_string(resumed->sum.height()) + " sum for a " + std::to_string(o.width) + " x " +
                 std::to_string(o.height) + " render)");
          if (!o.time && resumed->iterations > o.spp)
            fail("--resume " + *o.resume + ": it holds " + std::to_string(resumed->iterations) +
                 " iterations, more than --spp " + std::to_string(o.spp));
        }
      }))
    return 1;
  const std::uint64_t first = ranks.broadcast(resumed ? resumed->iterations : 0);
  const std::uint64_t size = std::uint64_t(ranks.size());

  // Every rank's own set-up: its scene, its method and the memory its machine has.
  renderer::MethodOptions mo = renderer::method_options(o);
  std::optional<renderer::Method> method;
  std::optional<renderer::RenderScene> scene;
  renderer::KernelCheck kernel;  // --radius against the scene: the set-up fails on its error, the root prints its warning
  if (!on_every_rank(ranks, [&] {
        // (A resumed render may end with a partial round: ranks beyond its iterations wait.)
        if (!o.time && first == 0 && size > o.spp)
          fail(std::to_string(size) + " ranks for " + std::to_string(o.spp - first) +
               " iterations: every rank renders whole iterations; start at most " + std::to_string(o.spp - first) +
               " ranks or raise --spp");
        method = renderer::make_method(o.method, mo);
        if (!method) fail("--method " + o.method + ": unknown method (use " + joined(renderer::method_names(), ", ") + ")");
        scene.emplace(renderer::load_scene(o));
        if (o.radius) {
          kernel = kernel_check(o, *method, *scene);
          if (kernel.error) fail(*kernel.error);
        }
        if (o.passes != 1 && !std::visit([&](const auto& m) {
              if constexpr (requires { m.check_passes(*scene, mo); }) {
                m.check_passes(*scene, mo);
                return true;
              } else {
                return false;
              }
            }, *method))
          fail("--passes applies to mvf, phf and bdpf only, not to " + o.method);
        const double resumed_bytes = resumed ? double(resumed->sum.pixel_count()) * sizeof(resumed->sum[0]) : 0.0;
        renderer::fit_in_memory(o, mo, *scene, method, resumed_bytes, root);
      }))
    return 1;
  if (root)
    if (const auto family = renderer::unsampled_family(o.method, *scene, o.next_event))
      std::fprintf(stderr, "segpath-render: warning: %s\n", family->c_str());
  if (root && kernel.warning) std::fprintf(stderr, "segpath-render: warning: %s\n", kernel.warning->c_str());
  if (root)
    for (const auto& warning : {renderer::ignored_camera_options(o), renderer::ignored_method_options(o, *method)})
      if (warning) std::fprintf(stderr, "segpath-render: warning: %s\n", warning->c_str());

  renderer::Stats stats;  // rank 0: the whole render's; other ranks: the round's
  if (!on_every_rank(ranks, [&] {
        if (!resumed) return;
        std::visit([&](auto& m) { m.resume(*scene, std::move(resumed->sum), first); }, *method);
        stats = resumed->stats;
        std::fprintf(stderr, "segpath-render: resuming %s at iteration %llu\n", o.resume->c_str(),
                     static_cast<unsigned long long>(first));
      }))
    return 1;
  const renderer::Stats before = stats;

  stop_on_signals();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, o.threads);
  tbb::task_arena arena(int(o.threads));
  Progress progress;
  const auto start = Clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  double checkpointed = 0;  // elapsed() at the last checkpoint
  bool checkpoint_failed = false;
  // A checkpoint that cannot be written is a warning: the render goes on (the previous
  // checkpoint stays valid) and exits with 1 after writing its images.
  const auto checkpoint = [&](std::uint64_t iterations) {
    try {
      std::visit([&](const auto& m) { renderer::write_checkpoint(*o.checkpoint, image_options, iterations, stats, m.sum()); },
                 *method);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "segpath-render: warning: %s\n", e.what());
      checkpoint_failed = true;
    }
    checkpointed = elapsed();
  };
  std::uint64_t next = first;
  bool stopped = false;  // by a signal, before the render's end
  Reduction reduction;  // rank 0's cost of the other ranks' iterations
  segpath::Framebuffer<renderer::Color> received(size > 1 && root ? o.width : 1, size > 1 && root ? o.height : 1);
  try {
    std::visit(
        [&](auto& m) {
          for (;;) {
            // A round: ranks 0 .. count - 1 render iterations next .. next + count - 1.
            // Rank 0 decides whether it starts, for every rank: the budget, or a stop signal.
            constexpr std::uint64_t finished = 0, go = 1, stop = 2;
            const bool more = o.time ? next == first || elapsed() < *o.time : next < o.spp;
            const std::uint64_t decision = ranks.broadcast(!root || !more ? finished : stop_signal.load() ? stop : go);
            if (decision != go) {
              stopped = decision == stop;
              break;
            }
            const std::uint64_t count = o.time ? size : std::min(size, o.spp - next);
            const std::uint64_t rank = std::uint64_t(ranks.rank());
            if (rank < count) arena.execute([&] { m.render(*scene, next + rank, stats, renderer::TbbFor{}); });
            if (root) {
              m.accumulate(*scene, m.iteration_image(), stats);
              for (std::uint64_t r = 1; r < count; ++r) {
                std::array<std::uint64_t, stats_words> words{};
                const auto waiting = Clock::now();
                ranks.wait_for(int(r));
                const auto receiving = Clock::now();
                ranks.receive(int(r), std::as_writable_bytes(received.pixels()));
                ranks.receive(int(r), std::as_writable_bytes(std::span(words)));
                const auto adding = Clock::now();
                m.accumulate(*scene, received, stats);
                stats += stats_of(words);
                reduction.add(waiting, receiving, adding, Clock::now());
              }
            } else if (rank < count) {
              ranks.send_to_root(std::as_bytes(m.iteration_image().pixels()));
              const auto words = stats_words_of(stats);
              ranks.send_to_root(std::as_bytes(std::span(words)));
              stats = {};
            }
            next += count;
            if (root) {
              progress.update(o.time ? elapsed() / *o.time : double(next - first) / double(o.spp - first), elapsed());
              if (o.checkpoint && elapsed() - checkpointed >= o.checkpoint_every) checkpoint(next);
            }
          }
        },
        *method);
  } catch (const std::exception& e) {
    // An error during the render is one rank's own (a failed checkpoint write, no memory):
    // the other ranks would wait for its images forever.
    std::fprintf(stderr, "segpath-render%s: error: %s\n",
                 size > 1 ? (" (rank " + std::to_string(ranks.rank()) + ")").c_str() : "", e.what());
    ranks.abort_all(1);
  }
  const double seconds = elapsed();
  // A rank other than 0 may not have seen the signal: rank 0's is the exit code.
  const int stopped_code = 128 + int(ranks.broadcast(std::uint64_t(stop_signal.load())));
  if (!root) return stopped ? stopped_code : 0;
  progress.finish();
  if (stopped) {
    std::fprintf(stderr, "segpath-render: stopped by signal %d after %llu iterations%s\n", stopped_code - 128,
                 static_cast<unsigned long long>(next),
                 o.checkpoint && next > 0 ? ("; continue with --resume " + *o.checkpoint).c_str() : "");
    if (next == 0) return stopped_code;  // nothing rendered: no image, no checkpoint
  }
  if (o.stats && reduction.iterations)
    std::fprintf(stderr,
                 "segpath-render: rank 0 added %llu iterations of other ranks: waiting for them %.3f s in all; per "
                 "iteration %.3f ms receiving (%.1f MB), %.3f ms adding\n",
                 static_cast<unsigned long long>(reduction.iterations), reduction.waiting,
                 1e3 * reduction.receiving / double(reduction.iterations),
                 double(received.pixel_count()) * sizeof(renderer::Color) * 1e-6,
                 1e3 * reduction.adding / double(reduction.iterations));

  // The image: sum / iterations (the sum in double, each iteration's non-finite pixels already
  // dropped); a pixel that does not fit a float is zeroed and counted.
  const renderer::Accumulator& sum = std::visit([](const auto& m) -> const renderer::Accumulator& { return m.sum(); }, *method);
  examples::Image image(int(o.width), int(o.height));
  for (std::uint32_t p = 0; p < sum.pixel_count(); ++p) {
    const auto v = sum[p] / double(next);
    const segpath::Rgb<float> f(float(v.r), float(v.g), float(v.b));
    if (segpath::is_finite(f)) {
      image.pixels[p] = f;
    } else {
      image.pixels[p] = segpath::Rgb<float>(0.0f);
      stats.dropped.add(segpath::DropReason::non_finite);
    }
  }
  for (const auto& path : o.out) renderer::write_image(image, path);
  if (o.checkpoint) checkpoint(next);  // after the images: a failure here must not lose them
  // Rank 0's own peak, images and checkpoint written, to compare with the estimate printed
  // before the render.
  if (o.stats)
    if (const std::uint64_t peak = renderer::peak_resident_bytes())
      std::fprintf(stderr, "segpath-render: peak resident memory %s\n", renderer::memory_size(peak).c_str());

  std::string dropped;
  for (std::size_t r = 0; r < segpath::drop_reason_count; ++r)
    dropped += std::string(r ? ", " : "") + segpath::to_string(segpath::DropReason(r)) + " " +
               std::to_string(stats.dropped.counts[r]);
  const std::string threads = std::to_string(o.threads) + (o.threads == 1 ? " thread" : " threads");
  const std::string workers = size > 1 ? std::to_string(size) + " ranks x " + threads : threads;
  // Rates of this run (a resumed render's earlier iterations are not in `seconds`).
  const double paths = double(stats.paths - before.paths), rays = double(stats.rays - before.rays);
  std::printf("segpath-render: %s %s %ux%u, %llu spp (%llu iterations), %s, %.2f s, %.3f M samples/s, %.3f M rays/s, mean %.4f, dropped %llu (%s)",
              std::string(renderer::method_name(*method)).c_str(), scene->name().c_str(), o.width, o.height,
              static_cast<unsigned long long>(next), static_cast<unsigned long long>(next), workers.c_str(), seconds,
              seconds > 0 ? paths / seconds * 1e-6 : 0.0, seconds > 0 ? rays / seconds * 1e-6 : 0.0, image.mean(),
              static_cast<unsigned long long>(stats.dropped.total()), dropped.c_str());
  if (reference) {
    const auto e = renderer::compare(image, *reference);
    std::printf(", RMSE %.6g, relMSE %.6g", e.rmse, e.relmse);
  }
  std::printf("\n");
  return stopped ? stopped_code : checkpoint_failed ? 1 : 0;
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
  // And one heap for every thread: their paths are recorded by the worker threads, and what a
  // worker frees stays in its own arena, out of reach of the pool and propagation arrays the
  // main thread allocates next. BDPF's peak 9-11 % lower (docs/figures.md, session 25). A
  // MALLOC_ARENA_MAX of the user's is left alone.
  if (std::getenv("MALLOC_ARENA_MAX") == nullptr) mallopt(M_ARENA_MAX, 1);
  const renderer::Ranks ranks(argc, argv);  // MPI from here (a build with it) to the end of main
  const renderer::CommandLine command_line = renderer::parse_command_line(argc, argv);
  // Ranks normally share one command line: rank 0 prints the help or the error, other ranks
  // only an error of their own.
  const bool parsed = command_line.options.has_value();
  if (!ranks.all(parsed)) {
    const bool root_parsed = ranks.broadcast(ranks.root() && parsed) != 0;
    if (!parsed && (ranks.root() || root_parsed))
      std::fputs(command_line.message.c_str(), command_line.exit_code == 0 ? stdout : stderr);
    return parsed ? 1 : command_line.exit_code;
  }
  try {
    return run(*command_line.options, ranks);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "segpath-render: error: %s\n", e.what());
    ranks.abort_all(1);
  }
}
