// A linear RGB image with PNG (tone-mapped, sRGB, via stb) and PFM output, for the examples.
#pragma once

#include <segpath/core/spectrum.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

namespace examples {

struct Image {
  int width = 0, height = 0;
  std::vector<segpath::Rgb<float>> pixels;

  Image(int w, int h) : width(w), height(h), pixels(static_cast<std::size_t>(w) * static_cast<std::size_t>(h)) {}
  segpath::Rgb<float>& at(int x, int y) { return pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)]; }

  [[nodiscard]] double mean() const {
    double sum = 0;
    for (const auto& p : pixels) sum += double(p.r) + double(p.g) + double(p.b);
    return sum / (3.0 * double(pixels.size()));
  }
};

/// Linear -> sRGB transfer function, clamped to [0, 1].
inline float to_srgb(float v) {
  v = std::clamp(v, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

/// Portable float map: little-endian RGB, rows stored bottom to top.
inline void write_pfm(const Image& img, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw std::runtime_error("cannot open " + path + " for writing");
  std::fprintf(f, "PF\n%d %d\n-1.0\n", img.width, img.height);
  for (int y = img.height - 1; y >= 0; --y)
    for (int x = 0; x < img.width; ++x) {
      const auto& p = img.pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(img.width) + static_cast<std::size_t>(x)];
      const float rgb[3] = {p.r, p.g, p.b};
      std::fwrite(rgb, sizeof(float), 3, f);
    }
  std::fclose(f);
}

}  // namespace examples
