// libFuzzer harness for the renderer's OBJ/MTL loader (examples/renderer/obj_scene.hpp): the
// input up to its first NUL byte is an OBJ file, the rest the MTL file next to it (scene.mtl,
// which the OBJ names with `mtllib scene.mtl`). Any input must load or be refused with a
// std::exception naming the file; a crash, hang, leak or sanitizer report is a finding.
#include "obj_scene.hpp"

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace {

/// A directory of this process's own under the temporary directory, made once.
const std::filesystem::path& work_directory() {
  static const std::filesystem::path dir = [] {
    auto d = std::filesystem::temp_directory_path() / ("segpath-obj-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

void write(const std::filesystem::path& path, std::string_view text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(text.data(), std::streamsize(text.size()));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const std::size_t split = input.find('\0');
  const auto obj = work_directory() / "scene.obj", mtl = work_directory() / "scene.mtl";
  write(obj, input.substr(0, split));
  write(mtl, split == std::string_view::npos ? std::string_view() : input.substr(split + 1));
  renderer::ObjCamera camera;
  camera.position = {0, -3, 0};
  camera.target = {0, 0, 0};
  camera.up = {0, 0, 1};
  try {
    const renderer::RenderScene scene = renderer::load_obj_scene(obj.string(), camera, 4, 4);
    (void)scene;
  } catch (const std::exception&) {
    // a refused file: the loader's documented behaviour
  }
  return 0;
}
