// One render protocol for every progressive method: PT, LT, BDPT, PPM, BPM, VCM, MVF, PhF,
// BDPF, and a user's own. Iterations are numbered from 0; each is rendered into an image of its
// own (given iteration i, the same pixels whatever the ParallelFor) and added to a sum kept in
// double; the estimate is the mean over the iterations. A kernel method's schedule (its
// options' initial size, or the automatic one in pixel footprints, sensors/pixel_footprint.hpp,
// or one the caller gives) is computed once, when the render is made.
//
// Iterations are independent given their index, so a render can be split: render(i) computes
// iteration i anywhere (another thread, process or machine), accumulate() adds iteration images
// in index order, and the sum is then bit for bit the one iterate() gives; resume() continues a
// render from a saved sum (examples/renderer: MPI ranks and checkpoints).
#pragma once

#include "segpath/concepts/scene.hpp"
#include "segpath/core/drop.hpp"
#include "segpath/core/framebuffer.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/spectrum.hpp"
#include "segpath/kernels/progressive_radius.hpp"

#include <concepts>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

namespace segpath {

/// A method ProgressiveRender runs: render_iteration(scene, i, image, drops, parallel_for) adds
/// iteration i's estimate of every pixel to the sensor-sized `image` and counts the samples it
/// drops in `drops`. PathTracer, LightTracer, VertexConnectionMerging and SegmentFiltering
/// model it.
template <class M, class Scn>
concept ProgressiveMethod =
    Scene<Scn> && requires(const M& m, const Scn& scene, std::uint64_t iteration,
                           Framebuffer<typename Scn::Spectrum>& image, DropCounters& drops, const SerialFor& serial) {
      m.render_iteration(scene, iteration, image, drops, serial);
    };

/// A ProgressiveMethod with a kernel: its schedule for a scene (KernelSchedule, possibly
/// none), and an iteration at a given kernel size.
template <class M, class Scn>
concept KernelMethod =
    ProgressiveMethod<M, Scn> &&
    requires(const M& m, const Scn& scene, std::uint64_t iteration, typename Scn::Scalar kernel,
             Framebuffer<typename Scn::Spectrum>& image, DropCounters& drops, const SerialFor& serial) {
      { m.kernel_schedule(scene) } -> std::same_as<KernelSchedule<typename Scn::Scalar>>;
      m.render_iteration_at(scene, iteration, kernel, image, drops, serial);
    };

/// A progressive render of `scene` with `method`: call iterate() as often as time allows and
/// read image() (the mean of the iterations so far, in the scene's spectrum accumulated in
/// double: accumulation_spectrum_t). The scene must outlive the render.
template <Scene Scn, ProgressiveMethod<Scn> M>
  requires Spectrum<accumulation_spectrum_t<typename Scn::Spectrum>> &&
           std::constructible_from<accumulation_spectrum_t<typename Scn::Spectrum>, typename Scn::Spectrum>
class ProgressiveRender {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  using Accumulated = accumulation_spectrum_t<S>;

  /// width x height must be the sensor's pixel count (pixel p is row p / width).
  ProgressiveRender(const Scn& scene, M method, std::uint32_t width, std::uint32_t height)
      : scene_(&scene), method_(std::move(method)), sum_(width, height), iteration_image_(width, height) {
    if (std::uint64_t(width) * height != scene.sensor().pixel_count())
      throw std::invalid_argument("segpath::ProgressiveRender: " + std::to_string(width) + " x " + std::to_string(height) +
                                  " pixels, but the sensor has " + std::to_string(scene.sensor().pixel_count()));
    // A sensor with rows (a camera) must have the same ones: 144 x 1 for 12 x 12 reshaped the image.
    if constexpr (requires { scene.sensor().width(); })
      if (scene.sensor().width() != width)
        throw std::invalid_argument("segpath::ProgressiveRender: " + std::to_string(width) + " x " + std::to_string(height) +
                                    " pixels, but the sensor is " + std::to_string(scene.sensor().width()) + " pixels wide");
    if constexpr (KernelMethod<M, Scn>) schedule_ = method_.kernel_schedule(scene);
  }

  /// A kernel method's render with a schedule of the caller's (e.g. KernelSchedule::fixed, to
  /// measure the kernel's bias at one size) instead of the method's own.
  ProgressiveRender(const Scn& scene, M method, std::uint32_t width, std::uint32_t height, KernelSchedule<T> schedule)
    requires KernelMethod<M, Scn>
      : ProgressiveRender(scene, std::move(method), width, height) {
    if (!schedule.has_kernel())
      throw std::invalid_argument("segpath::ProgressiveRender: a kernel method needs a kernel schedule");
    schedule_ = schedule;
  }

  [[nodiscard]] const M& method() const noexcept { return method_; }
  [[nodiscard]] const Scn& scene() const noexcept { return *scene_; }
  /// The kernel size of every iteration (none for PT, LT, BDPT and methods without a kernel).
  [[nodiscard]] const KernelSchedule<T>& kernel_schedule() const noexcept { return schedule_; }
  /// The iterations rendered so far: the index of the next one.
  [[nodiscard]] std::uint64_t iterations() const noexcept { return iterations_; }
  /// The samples dropped so far, by reason (a non-finite pixel sum is one more).
  [[nodiscard]] const DropCounters& drops() const noexcept { return drops_; }
  [[nodiscard]] std::uint32_t width() const noexcept { return sum_.width(); }
  [[nodiscard]] std::uint32_t height() const noexcept { return sum_.height(); }

  /// Renders iteration iterations() and adds it to the sum; returns what the method's
  /// render_iteration returns (SegmentFiltering: the iteration's FilteringStats).
  template <ParallelFor P = SerialFor>
  decltype(auto) iterate(const P& parallel_for = {}) {
    using Result = decltype(render(iterations_, parallel_for));
    if constexpr (std::is_void_v<Result>) {
      render(iterations_, parallel_for);
      accumulate(iteration_image_);
    } else {
      Result result = render(iterations_, parallel_for);
      accumulate(iteration_image_);
      return result;
    }
  }

  /// Renders iteration `iteration` (any index, at its scheduled kernel size) into
  /// iteration_image() without adding it to the sum; the samples it drops are counted in
  /// drops(). Returns what the method's render_iteration returns.
  template <ParallelFor P = SerialFor>
  decltype(auto) render(std::uint64_t iteration, const P& parallel_for = {}) {
    iteration_image_.clear();
    if constexpr (KernelMethod<M, Scn>) {
      if (schedule_.has_kernel())
        return method_.render_iteration_at(*scene_, iteration, schedule_.at(iteration), iteration_image_, drops_,
                                           parallel_for);
    }
    return method_.render_iteration(*scene_, iteration, iteration_image_, drops_, parallel_for);
  }
  /// The image of the last render() (iteration's estimate of every pixel, not yet averaged).
  [[nodiscard]] const Framebuffer<S>& iteration_image() const noexcept { return iteration_image_; }

  /// Adds `image`, the estimate of iteration iterations() (from render() here or elsewhere), to
  /// the sum: a non-finite pixel is dropped and counted. Adding the iterations in index order
  /// gives the same sum, bit for bit, wherever they were rendered.
  void accumulate(const Framebuffer<S>& image) {
    if (image.pixel_count() != sum_.pixel_count())
      throw std::invalid_argument("segpath::ProgressiveRender::accumulate: " + std::to_string(image.pixel_count()) +
                                  " pixels, the render has " + std::to_string(sum_.pixel_count()));
    for (std::uint32_t p = 0; p < sum_.pixel_count(); ++p) {
      const Accumulated v(image[p]);
      if (is_finite(v)) sum_.add(p, v);
      else drops_.add(DropReason::non_finite);
    }
    ++iterations_;
  }

  /// Continues a render saved after `iterations` iterations: its sum and drop counters (e.g.
  /// read from a checkpoint). The next iterate() renders iteration `iterations`.
  void resume(Framebuffer<Accumulated> sum, std::uint64_t iterations, const DropCounters& drops) {
    if (sum.width() != sum_.width() || sum.height() != sum_.height())
      throw std::invalid_argument("segpath::ProgressiveRender::resume: a " + std::to_string(sum.width()) + " x " +
                                  std::to_string(sum.height()) + " sum, the render is " + std::to_string(sum_.width()) +
                                  " x " + std::to_string(sum_.height()));
    sum_ = std::move(sum);
    iterations_ = iterations;
    drops_ = drops;
  }

  /// The estimate of pixel p: the mean of its iterations (black before the first).
  [[nodiscard]] Accumulated pixel(std::uint32_t p) const {
    return iterations_ ? sum_[p] / spectrum_scalar_t<Accumulated>(iterations_) : Accumulated(spectrum_scalar_t<Accumulated>(0));
  }
  /// The estimate of every pixel.
  [[nodiscard]] Framebuffer<Accumulated> image() const {
    Framebuffer<Accumulated> out(sum_.width(), sum_.height());
    for (std::uint32_t p = 0; p < out.pixel_count(); ++p) out[p] = pixel(p);
    return out;
  }
  /// The sum over the iterations (e.g. to reduce several renders of disjoint iterations).
  [[nodiscard]] const Framebuffer<Accumulated>& sum() const noexcept { return sum_; }

 private:
  const Scn* scene_;
  M method_;
  KernelSchedule<T> schedule_;
  Framebuffer<Accumulated> sum_;
  Framebuffer<S> iteration_image_;
  DropCounters drops_;
  std::uint64_t iterations_ = 0;
};

}  // namespace segpath
