// Image files for the renderer, chosen by extension: .exr (tinyexr, float RGB), .pfm, .png
// (stb, clamped and sRGB-encoded); reading .exr and .pfm; error metrics against a reference.
#pragma once

#include "common/image.hpp"

#include <string>

namespace renderer {

/// Whether `path` ends in an extension write_image knows (.exr, .pfm, .png; any case).
[[nodiscard]] bool writable_format(const std::string& path);
/// Whether `path` ends in an extension read_image knows (.exr, .pfm).
[[nodiscard]] bool readable_format(const std::string& path);

/// Writes `image` in the format of the path's extension. Throws std::runtime_error on an
/// unknown extension or a failed write.
void write_image(const examples::Image& image, const std::string& path);
/// Reads a .pfm or .exr image (EXR: its R, G, B channels). Throws std::runtime_error.
[[nodiscard]] examples::Image read_image(const std::string& path);

struct ErrorMetrics {
  double rmse = 0;    ///< sqrt(mean over pixels and channels of (x - r)^2)
  double relmse = 0;  ///< mean over pixels and channels of (x - r)^2 / (r^2 + 1e-2)
};
/// Throws std::runtime_error when the sizes differ.
[[nodiscard]] ErrorMetrics compare(const examples::Image& image, const examples::Image& reference);

}  // namespace renderer
