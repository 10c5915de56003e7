// Image file formats of the renderer (see image_io.hpp); holds the stb_image_write
// implementation, tinyexr comes as a library.
#include "image_io.hpp"

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>
#include <tinyexr.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace renderer {

namespace {

std::string extension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  const auto slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return {};
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

std::string take_exr_error(const char* err) {
  std::string message = err ? err : "unknown error";
  if (err) FreeEXRErrorMessage(err);
  return message;
}

}  // namespace

bool writable_format(const std::string& path) {
  const std::string ext = extension(path);
  return ext == ".exr" || ext == ".pfm" || ext == ".png";
}

bool readable_format(const std::string& path) {
  const std::string ext = extension(path);
  return ext == ".exr" || ext == ".pfm";
}

void write_image(const examples::Image& image, const std::string& path) {
  const std::string ext = extension(path);
  const std::size_t n = image.pixels.size();
  if (ext == ".pfm") {
    examples::write_pfm(image, path);
  } else if (ext == ".exr") {
    std::vector<float> rgb(3 * n);
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) rgb[3 * i + std::size_t(c)] = image.pixels[i][c];
    // tinyexr's SaveEXR convenience function leaks its header (seen with LeakSanitizer on
    // Debian's libtinyexr 1.0.1), so the header and channel planes are ours here.
    const std::size_t pixels = std::size_t(image.width) * std::size_t(image.height);
    std::array<std::vector<float>, 3> planes;  // EXR stores channels in B, G, R order
    for (int c = 0; c < 3; ++c) {
      planes[std::size_t(c)].resize(pixels);
      for (std::size_t i = 0; i < pixels; ++i) planes[std::size_t(c)][i] = rgb[3 * i + std::size_t(2 - c)];
    }
    std::array<float*, 3> plane_pointers{planes[0].data(), planes[1].data(), planes[2].data()};
    std::array<EXRChannelInfo, 3> channels{};
    const char* names[3] = {"B", "G", "R"};
    for (int c = 0; c < 3; ++c) {
      std::snprintf(channels[std::size_t(c)].name, sizeof(channels[std::size_t(c)].name), "%s", names[c]);
    }
    std::array<int, 3> pixel_types{TINYEXR_PIXELTYPE_FLOAT, TINYEXR_PIXELTYPE_FLOAT, TINYEXR_PIXELTYPE_FLOAT};
    EXRHeader header;
    InitEXRHeader(&header);
    header.num_channels = 3;
    header.channels = channels.data();
    header.pixel_types = pixel_types.data();
    header.requested_pixel_types = pixel_types.data();
    EXRImage exr;
    InitEXRImage(&exr);
    exr.num_channels = 3;
    exr.images = reinterpret_cast<unsigned char**>(plane_pointers.data());
    exr.width = image.width;
    exr.height = image.height;
    const char* err = nullptr;
    if (SaveEXRImageToFile(&exr, &header, path.c_str(), &err) != TINYEXR_SUCCESS)
      throw std::runtime_error("cannot write " + path + ": " + take_exr_error(err));
  } else if (ext == ".png") {
    std::vector<unsigned char> ldr(3 * n);
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        ldr[3 * i + std::size_t(c)] = static_cast<unsigned char>(examples::to_srgb(image.pixels[i][c]) * 255.0f + 0.5f);
    if (!stbi_write_png(path.c_str(), image.width, image.height, 3, ldr.data(), image.width * 3))
      throw std::runtime_error("cannot write " + path);
  } else {
    throw std::runtime_error("unknown image format '" + ext + "' for " + path + " (use .exr, .pfm or .png)");
  }
}

examples::Image read_image(const std::string& path) {
  const std::string ext = extension(path);
  if (ext == ".pfm") return examples::read_pfm(path);
  if (ext != ".exr") throw std::runtime_error("cannot read '" + ext + "' images (" + path + "): use .pfm or .exr");
  float* rgba = nullptr;
  int w = 0, h = 0;
  const char* err = nullptr;
  if (LoadEXR(&rgba, &w, &h, path.c_str(), &err) != TINYEXR_SUCCESS)
    throw std::runtime_error("cannot read " + path + ": " + take_exr_error(err));
  examples::Image image(w, h);
  for (std::size_t i = 0; i < image.pixels.size(); ++i)
    image.pixels[i] = segpath::Rgb<float>(rgba[4 * i], rgba[4 * i + 1], rgba[4 * i + 2]);
  std::free(rgba);
  return image;
}

ErrorMetrics compare(const examples::Image& image, const examples::Image& reference) {
  if (image.width != reference.width || image.height != reference.height)
    throw std::runtime_error("the reference is " + std::to_string(reference.width) + "x" + std::to_string(reference.height) +
                             " but the image is " + std::to_string(image.width) + "x" + std::to_string(image.height));
  for (const auto& p : reference.pixels)
    if (!segpath::is_finite(p)) throw std::runtime_error("the reference image contains NaN or infinite values");
  double se = 0, rel = 0;
  for (std::size_t i = 0; i < image.pixels.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double x = image.pixels[i][c], r = reference.pixels[i][c];
      se += (x - r) * (x - r);
      rel += (x - r) * (x - r) / (r * r + 1e-2);
    }
  const double count = 3.0 * double(image.pixels.size());
  return {std::sqrt(se / count), rel / count};
}

}  // namespace renderer
