// A linear RGB image with PFM input/output and the sRGB transfer function PNG output uses,
// for the examples.
#pragma once

#include <segpath/core/spectrum.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
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

/// Portable float map: little-endian RGB, rows stored bottom to top. Throws
/// std::runtime_error when the file cannot be written.
inline void write_pfm(const Image& img, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw std::runtime_error("cannot open " + path + " for writing");
  bool ok = std::fprintf(f, "PF\n%d %d\n-1.0\n", img.width, img.height) > 0;
  for (int y = img.height - 1; ok && y >= 0; --y)
    for (int x = 0; ok && x < img.width; ++x) {
      const auto& p = img.pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(img.width) + static_cast<std::size_t>(x)];
      const float rgb[3] = {p.r, p.g, p.b};
      ok = std::fwrite(rgb, sizeof(float), 3, f) == 3;
    }
  ok = std::fclose(f) == 0 && ok;
  if (!ok) throw std::runtime_error("cannot write " + path);
}

/// Reads a PFM written by write_pfm or any other writer: colour ("PF") or grey ("Pf"), either
/// byte order (by the sign of the scale). Throws std::runtime_error on a malformed file.
inline Image read_pfm(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw std::runtime_error("cannot open " + path + " for reading");
  struct Closer {
    std::FILE* f;
    ~Closer() { std::fclose(f); }
  } closer{f};
  char kind[3] = {};
  int w = 0, h = 0;
  double scale = 0;
  if (std::fscanf(f, "%2s %d %d %lf", kind, &w, &h, &scale) != 4 || (std::string(kind) != "PF" && std::string(kind) != "Pf") ||
      w <= 0 || h <= 0 || w > (1 << 16) || h > (1 << 16) || scale == 0 || !std::isfinite(scale))
    throw std::runtime_error(path + " is not a valid PFM file (bad header)");
  if (std::fgetc(f) == EOF) throw std::runtime_error(path + " is not a valid PFM file (truncated)");
  const int channels = std::string(kind) == "PF" ? 3 : 1;
  const bool little = scale < 0;
  const std::uint16_t probe = 1;
  const bool host_little = *reinterpret_cast<const unsigned char*>(&probe) == 1;
  Image img(w, h);
  std::vector<float> row(static_cast<std::size_t>(w) * static_cast<std::size_t>(channels));
  for (int y = h - 1; y >= 0; --y) {
    if (std::fread(row.data(), sizeof(float), row.size(), f) != row.size())
      throw std::runtime_error(path + " is not a valid PFM file (truncated)");
    if (little != host_little)
      for (float& v : row) {
        unsigned char b[4];
        std::memcpy(b, &v, 4);
        std::swap(b[0], b[3]);
        std::swap(b[1], b[2]);
        std::memcpy(&v, b, 4);
      }
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(x) * static_cast<std::size_t>(channels);
      img.at(x, y) = channels == 3 ? segpath::Rgb<float>(row[i], row[i + 1], row[i + 2]) : segpath::Rgb<float>(row[i]);
    }
  }
  return img;
}

}  // namespace examples
