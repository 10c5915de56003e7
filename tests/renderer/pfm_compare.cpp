// pfm_compare A B [--tolerance T]: whether two images (.pfm or .exr, read with the renderer's
// image_io) agree channel by channel within a relative tolerance: |a - b| <= T * max(|a|, |b|),
// T = 1e-6 by default (exactly equal values, zeros included, always agree). Used by the golden
// image tests (renderer.golden.*, tests/renderer/golden/).
// Exit code 0: same size and every channel agrees; 1: different sizes, a channel over the
// tolerance or a non-finite value in either image (prints the worst pixel and how many pixels
// are over); 2: bad arguments or an unreadable file.
#include "image_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <string>

namespace {

int usage() {
  std::fprintf(stderr, "usage: pfm_compare A B [--tolerance T]  (T > 0, default 1e-6)\n");
  return 2;
}

/// |a - b| / max(|a|, |b|); 0 when a == b (both zero included), infinity when either is
/// not finite (a failure whatever the tolerance).
double relative_difference(float a, float b) {
  if (!std::isfinite(a) || !std::isfinite(b)) return std::numeric_limits<double>::infinity();
  if (a == b) return 0;
  const double da = a, db = b;
  return std::abs(da - db) / std::max(std::abs(da), std::abs(db));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3 && argc != 5) return usage();
  double tolerance = 1e-6;
  if (argc == 5) {
    if (std::string(argv[3]) != "--tolerance") return usage();
    char* end = nullptr;
    tolerance = std::strtod(argv[4], &end);
    if (end == argv[4] || *end != '\0' || !(tolerance > 0) || !std::isfinite(tolerance)) return usage();
  }
  const std::string path_a = argv[1], path_b = argv[2];
  try {
    const examples::Image a = renderer::read_image(path_a);
    const examples::Image b = renderer::read_image(path_b);
    if (a.width != b.width || a.height != b.height) {
      std::printf("pfm_compare: %s is %dx%d, %s is %dx%d\n", path_a.c_str(), a.width, a.height, path_b.c_str(),
                  b.width, b.height);
      return 1;
    }
    double worst = 0;
    int worst_x = 0, worst_y = 0, worst_c = 0;
    long pixels_over = 0, channels_over = 0, channels_unequal = 0;
    for (int y = 0; y < a.height; ++y)
      for (int x = 0; x < a.width; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(a.width) + static_cast<std::size_t>(x);
        bool over = false;
        for (int c = 0; c < 3; ++c) {
          const double d = relative_difference(a.pixels[i][c], b.pixels[i][c]);
          if (d > 0) ++channels_unequal;
          if (!(d <= tolerance)) {
            over = true;
            ++channels_over;
          }
          if (d > worst) {
            worst = d;
            worst_x = x, worst_y = y, worst_c = c;
          }
        }
        pixels_over += over ? 1 : 0;
      }
    const long total = static_cast<long>(a.pixels.size());
    if (pixels_over == 0) {
      std::printf("pfm_compare: %s and %s agree (%dx%d): max relative difference %.9g, %ld of %ld channels not "
                  "bit-equal, tolerance %g\n",
                  path_a.c_str(), path_b.c_str(), a.width, a.height, worst, channels_unequal, 3 * total, tolerance);
      return 0;
    }
    const std::size_t w = static_cast<std::size_t>(worst_y) * static_cast<std::size_t>(a.width) + static_cast<std::size_t>(worst_x);
    std::printf("pfm_compare: %s and %s differ (%dx%d): %ld of %ld pixels (%ld channels) over the relative "
                "tolerance %g; worst at x %d, y %d (from the top), channel %d: %.9g vs %.9g, relative difference "
                "%.9g\n",
                path_a.c_str(), path_b.c_str(), a.width, a.height, pixels_over, total, channels_over, tolerance,
                worst_x, worst_y, worst_c, double(a.pixels[w][worst_c]), double(b.pixels[w][worst_c]), worst);
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pfm_compare: %s\n", e.what());
    return 2;
  }
}
