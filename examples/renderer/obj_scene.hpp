// Wavefront OBJ/MTL scenes for the renderer (through tinyobjloader): triangles, MTL materials
// mapped to the reference BSDFs, Ke surfaces as triangle area lights, a look-at camera.
#pragma once

#include "render_scene.hpp"

#include <segpath/core/format.hpp>

#include <tiny_obj_loader.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace renderer {

using Vec3 = segpath::Vec3<T>;

/// A look-at pinhole camera: at `position`, looking at `target`, `up` giving the image's up
/// direction (it need not be perpendicular to the view direction, only not parallel to it);
/// `fov_y_degrees` is the full vertical field of view, the horizontal one follows from the
/// image's aspect ratio (square pixels).
struct ObjCamera {
  Vec3 position{0, 0, 0};
  Vec3 target{0, 1, 0};
  Vec3 up{0, 0, 1};
  float fov_y_degrees = 45;
};

/// "x,y,z" (three finite numbers separated by commas; spaces around them allowed) as a Vec3.
/// Throws std::invalid_argument naming the text otherwise.
inline Vec3 parse_vec3(const std::string& text) {
  Vec3 v(0);
  std::size_t start = 0;
  for (int k = 0; k < 3; ++k) {
    const std::size_t comma = text.find(',', start);
    if ((k < 2) != (comma != std::string::npos))
      throw std::invalid_argument("expected three comma-separated numbers \"x,y,z\", got \"" + text + "\"");
    std::string_view field(text.data() + start, (k < 2 ? comma : text.size()) - start);
    while (!field.empty() && field.front() == ' ') field.remove_prefix(1);
    while (!field.empty() && field.back() == ' ') field.remove_suffix(1);
    float x = 0;
    const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), x);
    if (field.empty() || error != std::errc() || end != field.data() + field.size() || !std::isfinite(x))
      throw std::invalid_argument("expected three finite numbers \"x,y,z\", got \"" + text + "\"");
    v[k] = x;
    start = comma + 1;
  }
  return v;
}

/// The pinhole camera of an ObjCamera at width x height pixels. Throws std::invalid_argument
/// for non-finite vectors, position == target, `up` parallel to the view direction, or a
/// field of view outside (0, 180) degrees (or one whose horizontal angle reaches 180).
inline segpath::PinholeCamera<T> make_obj_camera(const ObjCamera& c, std::uint32_t width, std::uint32_t height) {
  using D = segpath::Vec3<double>;
  const auto to_d = [](const Vec3& v) { return D(v.x, v.y, v.z); };
  if (!segpath::is_finite(c.position) || !segpath::is_finite(c.target) || !segpath::is_finite(c.up))
    throw std::invalid_argument("obj camera: position, target and up must be finite");
  const D view = to_d(c.target) - to_d(c.position);
  if (!(glm::length(view) > 0)) throw std::invalid_argument("obj camera: the target equals the position");
  const D forward = glm::normalize(view);
  const D side = glm::cross(forward, to_d(c.up));
  if (!(glm::length(side) > 1e-6 * glm::length(to_d(c.up))))
    throw std::invalid_argument("obj camera: `up` is zero or parallel to the view direction");
  const D right = glm::normalize(side);
  const D up = glm::cross(right, forward);
  if (!(c.fov_y_degrees > 0 && c.fov_y_degrees < 180))
    throw std::invalid_argument("obj camera: the vertical field of view must lie in (0, 180) degrees, got " +
                                segpath::format_number(double(c.fov_y_degrees)));
  if (width == 0 || height == 0) throw std::invalid_argument("obj camera: the image size must be positive");
  const double pi = 3.14159265358979323846;
  const double tan_y = std::tan(double(c.fov_y_degrees) * pi / 360.0);
  const double fov_x = std::atan(tan_y * double(width) / double(height)) * 360.0 / pi;
  segpath::PinholeCameraParameters<T> p;
  p.position = c.position;
  p.forward = Vec3(forward);
  p.right = Vec3(right);
  p.up = Vec3(up);
  p.width = width;
  p.height = height;
  p.fov_x_degrees = T(fov_x);
  p.fov_y_degrees = c.fov_y_degrees;
  return segpath::PinholeCamera<T>(p);
}

namespace detail {

[[noreturn]] inline void obj_fail(const std::string& file, const std::string& what) {
  throw std::runtime_error(file + ": " + what);
}

/// The whitespace-separated tokens of a line, comments (#...) removed.
inline std::vector<std::string_view> obj_tokens(std::string_view line) {
  if (const auto hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

/// Whether `token` is one whole finite number (tinyobjloader reads "nan", "inf" and
/// garbage as 0 or infinity without a word, so the loader checks numbers first).
inline bool obj_finite_number(std::string_view token) {
  double x = 0;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), x);
  return error == std::errc() && end == token.data() + token.size() && std::isfinite(x);
}

inline std::string read_text(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open " + what + " file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw std::runtime_error(path + ": error reading " + what + " file");
  return text.str();
}

/// Checks the numbers of the OBJ vertex lines: "v x y z [w]" or "v x y z r g b", all finite.
inline void check_obj_text(const std::string& file, const std::string& text) {
  std::istringstream lines(text);
  std::string line;
  for (std::size_t number = 1; std::getline(lines, line); ++number) {
    const auto t = obj_tokens(line);
    if (t.empty() || t[0] != "v") continue;
    if (t.size() != 4 && t.size() != 5 && t.size() != 7)
      obj_fail(file, "line " + std::to_string(number) + ": a vertex needs 3 coordinates (\"" + line + "\")");
    for (std::size_t k = 1; k < t.size(); ++k)
      if (!obj_finite_number(t[k]))
        obj_fail(file, "line " + std::to_string(number) + ": vertex coordinate \"" + std::string(t[k]) +
                           "\" is not a finite number");
  }
}

/// Checks the numbers of an MTL file and records which materials state Ns (tinyobjloader
/// cannot tell "Ns 1" from no Ns).
inline void check_mtl_text(const std::string& file, const std::string& text, std::set<std::string>& with_ns) {
  std::istringstream lines(text);
  std::string line, current;
  for (std::size_t number = 1; std::getline(lines, line); ++number) {
    const auto t = obj_tokens(line);
    if (t.empty()) continue;
    const auto where = [&] { return "line " + std::to_string(number) + ": "; };
    if (t[0] == "newmtl") {
      if (t.size() < 2) obj_fail(file, where() + "newmtl without a name");
      current = std::string(t[1]);
      continue;
    }
    const bool colour = t[0] == "Ka" || t[0] == "Kd" || t[0] == "Ks" || t[0] == "Ke" || t[0] == "Tf";
    const bool scalar = t[0] == "Ns" || t[0] == "Ni" || t[0] == "d" || t[0] == "Tr" || t[0] == "illum";
    if (!colour && !scalar) continue;
    if (colour ? (t.size() != 2 && t.size() != 4) : t.size() != 2)
      obj_fail(file, where() + std::string(t[0]) + " needs " + (colour ? "1 or 3 numbers" : "one number") +
                         " (\"" + line + "\")");
    for (std::size_t k = 1; k < t.size(); ++k)
      if (!obj_finite_number(t[k]))
        obj_fail(file, where() + std::string(t[0]) + " value \"" + std::string(t[k]) + "\" is not a finite number");
    if (current.empty()) obj_fail(file, where() + std::string(t[0]) + " before any newmtl");
    if (t[0] == "Ns") with_ns.insert(current);
  }
}

/// Reads mtllib files relative to the OBJ's directory, checking them first; remembers
/// failures so that a missing MTL file is an error, not tinyobjloader's warning.
class ObjMaterialReader : public tinyobj::MaterialReader {
 public:
  explicit ObjMaterialReader(std::filesystem::path directory) : directory_(std::move(directory)) {}

  bool operator()(const std::string& name, std::vector<tinyobj::material_t>* materials,
                  std::map<std::string, int>* map, std::string* warning, std::string* error) override {
    const std::string path = (directory_ / name).string();
    try {
      const std::string text = read_text(path, "MTL");
      check_mtl_text(path, text, with_ns_);
      std::istringstream in(text);
      std::string mtl_warning;
      tinyobj::LoadMtl(map, materials, &in, &mtl_warning, error);
      if (!mtl_warning.empty()) failure_ = path + ": " + mtl_warning;
      if (warning != nullptr && !mtl_warning.empty()) *warning += mtl_warning;
    } catch (const std::exception& e) {
      if (failure_.empty()) failure_ = e.what();
      return false;
    }
    return true;
  }

  [[nodiscard]] const std::string& failure() const noexcept { return failure_; }
  [[nodiscard]] const std::set<std::string>& with_ns() const noexcept { return with_ns_; }

 private:
  std::filesystem::path directory_;
  std::string failure_;
  std::set<std::string> with_ns_;
};

inline Color obj_colour(const tinyobj::real_t (&c)[3]) { return Color(T(c[0]), T(c[1]), T(c[2])); }

inline bool obj_at_most_one(const Color& c) { return c.r <= 1 && c.g <= 1 && c.b <= 1; }

inline std::string obj_text(const Color& c) {
  std::string s(1, '(');
  s.append(segpath::format_number(double(c.r))).append(", ").append(segpath::format_number(double(c.g))).append(", ");
  return s.append(segpath::format_number(double(c.b))).append(")");
}

}  // namespace detail

/// How MTL parameters become materials (the first rule that applies):
///  1. Ke not black: an emitter. Its triangles are TriangleLights of radiance Ke (one-sided,
///     emitting along the winding normal cross(v1 - v0, v2 - v0)); the surface itself is black
///     (albedo 0: a path that hits an emitter ends there, as in the Cornell boxes).
///  2. illum 7, or Ni > 1 with d < 1 or Tf not black: Dielectric(Ni).
///  3. illum 5, or Kd black with Ks not black and no Ns: Mirror(Ks) (Mirror(1) for illum 5
///     with black Ks).
///  4. Ks not black (with Ns): Glossy(Kd, Ks, Ns), Lambertian Kd plus Phong Ks with exponent
///     Ns; Kd + Ks must be <= 1 per channel.
///  5. Otherwise Lambertian(Kd), Kd <= 1 per channel.
/// Material id k is the MTL's k-th material (in the order tinyobjloader reads them); faces
/// without a material get a grey Lambertian(0.8) with the next id. Vertex normals and texture
/// coordinates are ignored (flat shading), polygons are triangulated, every OBJ face becomes
/// one triangle with primitive id in file order (one Embree mesh).
///
/// Errors: std::runtime_error naming the file for a missing or unreadable OBJ or MTL file,
/// malformed or non-finite numbers, face indices out of range, faces of fewer than three
/// vertices, unknown material names (tinyobjloader's warnings are errors here), and a scene
/// with no emitter of positive area (nothing to render); std::invalid_argument (also naming
/// the file) for MTL values no material accepts (negative colours, Kd + Ks > 1, ...) and a bad
/// camera. Degenerate (zero-area) triangles are kept: they are never hit nor sampled.
inline RenderScene load_obj_scene(const std::string& path, const ObjCamera& camera, std::uint32_t width,
                                  std::uint32_t height) {
  const std::string text = detail::read_text(path, "OBJ");
  detail::check_obj_text(path, text);

  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> mtl;
  std::string warning, error;
  detail::ObjMaterialReader reader(std::filesystem::path(path).parent_path());
  std::istringstream in(text);
  const bool ok = tinyobj::LoadObj(&attrib, &shapes, &mtl, &warning, &error, &in, &reader, true);
  if (!reader.failure().empty()) throw std::runtime_error(path + ": " + reader.failure());
  const auto trim = [](std::string s) {
    while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
    return s;
  };
  if (!ok || !error.empty()) detail::obj_fail(path, "malformed OBJ: " + trim(error));
  if (!warning.empty()) detail::obj_fail(path, "malformed OBJ: " + trim(warning));

  // Materials.
  segpath::MaterialSet<Color> materials;
  std::vector<Color> emission(mtl.size() + 1, Color(T(0)));
  for (std::size_t k = 0; k < mtl.size(); ++k) {
    const tinyobj::material_t& m = mtl[k];
    const std::string where = path + ": material \"" + m.name + "\": ";
    const Color kd = detail::obj_colour(m.diffuse), ks = detail::obj_colour(m.specular),
                ke = detail::obj_colour(m.emission), tf = detail::obj_colour(m.transmittance);
    for (const auto& [name, c] : {std::pair{"Kd", kd}, std::pair{"Ks", ks}, std::pair{"Ke", ke}, std::pair{"Tf", tf}})
      if (std::min({c.r, c.g, c.b}) < 0)
        throw std::invalid_argument(where + name + " " + detail::obj_text(c) + " is negative");
    const bool has_ns = reader.with_ns().count(m.name) != 0;
    try {
      if (!segpath::is_black(ke)) {
        emission[k] = ke;
        materials.add(segpath::Lambertian<Color>{Color(T(0))});
      } else if (m.illum == 7 || (m.ior > 1 && (m.dissolve < 1 || !segpath::is_black(tf)))) {
        materials.add(segpath::Dielectric<Color>(T(m.ior)));
      } else if (m.illum == 5 || (segpath::is_black(kd) && !segpath::is_black(ks) && !has_ns)) {
        if (!detail::obj_at_most_one(ks))
          throw std::invalid_argument("mirror reflectance Ks " + detail::obj_text(ks) + " exceeds 1");
        materials.add(segpath::Mirror<Color>(segpath::is_black(ks) ? Color(T(1)) : ks));
      } else if (!segpath::is_black(ks)) {
        if (!detail::obj_at_most_one(kd + ks))
          throw std::invalid_argument("Kd + Ks " + detail::obj_text(kd + ks) +
                                      " exceeds 1 in some channel (the material would create energy)");
        if (!has_ns) throw std::invalid_argument("Ks without Ns (give Ns for a glossy lobe, or Kd 0 for a mirror)");
        materials.add(segpath::Glossy<Color>(kd, ks, T(m.shininess)));
      } else {
        if (!detail::obj_at_most_one(kd))
          throw std::invalid_argument("Kd " + detail::obj_text(kd) + " exceeds 1 in some channel");
        materials.add(segpath::Lambertian<Color>{kd});
      }
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(where + e.what());
    }
  }
  const auto default_material = static_cast<std::uint32_t>(mtl.size());

  // Geometry: one mesh, one triangle per (triangulated) face, in file order.
  segpath::EmbreeManifold<T>::Description description;
  auto& mesh = description.meshes.emplace_back();
  const std::size_t vertex_count = attrib.vertices.size() / 3;
  mesh.positions.reserve(vertex_count);
  for (std::size_t i = 0; i < vertex_count; ++i)
    mesh.positions.emplace_back(attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]);
  std::vector<segpath::EmissiveTriangle<T>> emissive;
  std::vector<Color> radiance;
  bool uses_default = false;
  for (const tinyobj::shape_t& shape : shapes) {
    std::size_t offset = 0;
    for (std::size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
      const std::size_t n = shape.mesh.num_face_vertices[f];
      if (n != 3)
        detail::obj_fail(path, "shape \"" + shape.name + "\", face " + std::to_string(f) + " has " +
                                   std::to_string(n) + " vertices after triangulation");
      std::array<std::uint32_t, 3> tri{};
      for (std::size_t k = 0; k < 3; ++k) {
        const int index = shape.mesh.indices[offset + k].vertex_index;
        if (index < 0 || std::size_t(index) >= vertex_count)
          detail::obj_fail(path, "shape \"" + shape.name + "\", face " + std::to_string(f) + ": vertex index " +
                                     std::to_string(index + 1) + " out of range (" + std::to_string(vertex_count) +
                                     " vertices)");
        tri[k] = std::uint32_t(index);
      }
      offset += n;
      const int material = shape.mesh.material_ids.empty() ? -1 : shape.mesh.material_ids[f];
      std::uint32_t id = default_material;
      if (material >= 0 && std::size_t(material) < mtl.size()) {
        id = std::uint32_t(material);
      } else {
        uses_default = true;
      }
      const auto primitive = static_cast<std::uint32_t>(mesh.triangles.size());
      if (!segpath::is_black(emission[id])) {
        emissive.push_back({mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]], primitive, id,
                            Vec3(0)});
        radiance.push_back(emission[id]);
      }
      mesh.triangles.push_back(tri);
      mesh.triangle_materials.push_back(id);
    }
  }
  if (uses_default) materials.add(segpath::Lambertian<Color>{Color(T(0.8))});
  if (mesh.triangles.empty()) detail::obj_fail(path, "no faces");
  if (emissive.empty())
    detail::obj_fail(path, "no emitter (no face has a material with non-black Ke): nothing to render");

  std::optional<segpath::TriangleLights<Color>> lights;
  try {
    lights.emplace(emissive, radiance);
  } catch (const std::invalid_argument& e) {
    detail::obj_fail(path, std::string("the emissive faces cannot form a light: ") + e.what());
  }
  try {
    segpath::EmbreeManifold<T> manifold(description);
    std::string name = std::filesystem::path(path).stem().string();
    return RenderScene(std::move(name), std::move(manifold), std::move(materials), Emitter(std::move(*lights)),
                       make_obj_camera(camera, width, height));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path + ": " + e.what());
  }
}

}  // namespace renderer
