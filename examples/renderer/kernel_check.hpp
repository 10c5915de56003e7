// --radius against the scene's size: a kernel (merge radius or voxel) as wide as the scene
// merges every vertex with every other, so the image is a blur of the whole scene (a kernel
// bias of tens of per cent on SmallVCM's boxes) and an iteration of VCM costs the product of
// its camera and light vertices; the progressive shrinking (r_i = r_1 i^((alpha - 1) / 2))
// takes astronomically many iterations to bring it back down.
#pragma once

#include "render_scene.hpp"

#include <segpath/core/format.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>

namespace renderer {

/// The length of the diagonal of the scene's bounding box (Embree's bounds of its geometry).
[[nodiscard]] inline double scene_diagonal(const RenderScene& scene) {
  RTCBounds b;
  rtcGetSceneBounds(scene.manifold().rtc_scene(), &b);
  const double dx = double(b.upper_x) - b.lower_x, dy = double(b.upper_y) - b.lower_y, dz = double(b.upper_z) - b.lower_z;
  return std::sqrt(std::max(0.0, dx * dx + dy * dy + dz * dz));
}

/// Whether `method` reads --radius as a kernel: the merge radius of ppm, bpm and vcm, the voxel
/// of mvf, phf and bdpf.
[[nodiscard]] inline bool reads_kernel(std::string_view method) {
  return method == "ppm" || method == "bpm" || method == "vcm" || method == "mvf" || method == "phf" || method == "bdpf";
}

/// The kernel as a share of the scene at which a render is refused (the whole diagonal) and
/// warned about (a tenth of it: every merge spans a tenth of the scene).
inline constexpr double refused_kernel_share = 1.0, warned_kernel_share = 0.1;

struct KernelCheck {
  std::optional<std::string> error, warning;
};

/// --radius `radius` of `method` against the scene's diagonal `diagonal`: an error where the
/// kernel spans the scene, a warning where it spans a tenth of it or more.
[[nodiscard]] inline KernelCheck check_kernel(std::string_view method, double radius, double diagonal) {
  KernelCheck c;
  if (!reads_kernel(method) || !(diagonal > 0)) return c;
  const std::string what = "--radius " + segpath::format_number(radius) + " (" + std::string(method) + "'s " +
                           (method == "mvf" || method == "phf" || method == "bdpf" ? "voxel" : "merge radius") + ")";
  const std::string scene = "the scene's bounding box has a diagonal of " + segpath::format_number(diagonal, 3);
  if (radius >= refused_kernel_share * diagonal)
    c.error = what + " spans the whole scene (" + scene +
              "): every vertex would merge with every other, a blur of the scene that the kernel's shrinking never "
              "undoes; leave --radius unset for the default (a few pixel footprints) or give one well below the diagonal";
  else if (radius >= warned_kernel_share * diagonal)
    c.warning = what + " spans a tenth of the scene or more (" + scene +
                "): expect a blurred, darkened image (kernel bias) and slow iterations";
  return c;
}

}  // namespace renderer
