// --radius against the scene's size. A kernel (merge ball, voxel) as wide as the scene merges
// every vertex with vertices anywhere in it, so the image is a blur of the whole scene: a
// kernel bias of tens of per cent on SmallVCM's boxes, and an iteration of VCM costs the product
// of its camera and light vertices. The progressive shrinking (r_i = r_1 i^((alpha - 1) / 2))
// takes astronomically many iterations to bring it back down.
#pragma once

#include "render_scene.hpp"

#include <segpath/core/format.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace renderer {

/// What a method reads --radius as (each method's `radius_use`).
enum class RadiusUse : std::uint8_t {
  ignored,       ///< no kernel: pt, lt, bdpt
  merge_radius,  ///< the radius of the ball merged around a vertex (ppm, bpm, vcm): 2 r wide
  voxel,         ///< a voxel's edge (mvf, phf, bdpf; over disks, disks of a voxel's area): v wide
};

/// The width of the kernel --radius `radius` gives.
[[nodiscard]] constexpr double kernel_width(RadiusUse use, double radius) noexcept {
  return use == RadiusUse::merge_radius ? 2 * radius : radius;
}

/// The kernel's width as a share of the scene's diagonal from which a render is refused (the
/// whole diagonal) and warned about (a tenth of it).
inline constexpr double refused_kernel_share = 1.0, warned_kernel_share = 0.1;

/// The length of the diagonal of the scene's bounding box (Embree's bounds of its geometry).
[[nodiscard]] inline double scene_diagonal(const RenderScene& scene) {
  RTCBounds b;
  rtcGetSceneBounds(scene.manifold().rtc_scene(), &b);
  const double dx = double(b.upper_x) - b.lower_x, dy = double(b.upper_y) - b.lower_y, dz = double(b.upper_z) - b.lower_z;
  return std::sqrt(std::max(0.0, dx * dx + dy * dy + dz * dz));
}

struct KernelCheck {
  std::optional<std::string> error, warning;
};

/// --radius `radius` of `method` (which reads it as `use`) against the scene's diagonal: an
/// error where the kernel is as wide as the scene, a warning where it is a tenth as wide or
/// more, or where the method has no kernel to read it.
[[nodiscard]] inline KernelCheck check_kernel(std::string_view method, RadiusUse use, double radius, double diagonal) {
  KernelCheck c;
  const std::string option = "--radius " + segpath::format_number(radius);
  if (use == RadiusUse::ignored) {
    c.warning = std::string(method) + " has no kernel: " + option + " is ignored";
    return c;
  }
  if (!(diagonal > 0)) return c;
  const double width = kernel_width(use, radius);
  const std::string what = option + " (" + std::string(method) + "'s " + (use == RadiusUse::voxel ? "voxel" : "merge radius") +
                           ", a kernel " + segpath::format_number(width, 3) + " wide)";
  const std::string scene = "the scene's bounding box has a diagonal of " + segpath::format_number(diagonal, 3);
  if (width >= refused_kernel_share * diagonal)
    c.error = what + " is as wide as the scene (" + scene +
              "): every vertex would merge with vertices anywhere in it, a blur that the kernel's shrinking never "
              "undoes; leave --radius unset for the default (a few pixel footprints) or give a kernel well below the diagonal";
  else if (width >= warned_kernel_share * diagonal)
    c.warning = what + " is a tenth of the scene's width or more (" + scene + "): expect a blurred, biased image and slow iterations";
  return c;
}

}  // namespace renderer
