// libFuzzer harness for segpath-render's command line (examples/renderer/options.hpp): the
// input's lines are the arguments. Parsing, and for a parsed command line building the method
// and the OBJ camera from it (what segpath-render checks before it loads a scene), must succeed
// or report an error; a crash, hang, leak or sanitizer report is a finding.
#include "options.hpp"

#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>
#include <string_view>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> arguments{"segpath-render"};
  for (std::size_t begin = 0; begin <= input.size() && arguments.size() < 64;) {
    const std::size_t end = std::min(input.find('\n', begin), input.size());
    arguments.emplace_back(input.substr(begin, end - begin));
    begin = end + 1;
  }
  std::vector<const char*> argv;
  for (const auto& a : arguments) argv.push_back(a.c_str());
  const renderer::CommandLine command_line = renderer::parse_command_line(int(argv.size()), argv.data());
  if (!command_line.options) return 0;
  const renderer::Options& o = *command_line.options;
  try {
    (void)renderer::make_method(o.method, renderer::method_options(o));
#if SEGPATH_RENDER_HAS_OBJ
    renderer::ObjCamera camera;
    camera.position = renderer::parse_vec3(o.camera_position);
    camera.target = renderer::parse_vec3(o.camera_target);
    camera.up = renderer::parse_vec3(o.camera_up);
    camera.fov_y_degrees = o.fov;
    (void)renderer::make_obj_camera(camera, o.width, o.height);
#endif
  } catch (const std::exception&) {
    // an error message for the user: the documented behaviour
  }
  return 0;
}
