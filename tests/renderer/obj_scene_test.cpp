// Tests of the renderer's OBJ/MTL loader: material mapping, per-triangle emitters, the
// camera, a Cornell-like OBJ rendering like the same scene built in code, clear errors.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <segpath/algorithms/path_tracer.hpp>
#include <segpath/core/rng.hpp>
#include <segpath/testing/statistics.hpp>
#include <stdexcept>
#include <string>
#include <variant>

#include "../../examples/renderer/cornell.hpp"
#include "../../examples/renderer/obj_scene.hpp"
#include "support/catch.hpp"

namespace {

using renderer::Color;
using renderer::T;
using renderer::Vec3;
using segpath::Pcg32;

const std::filesystem::path data_dir = std::filesystem::path(__FILE__).parent_path() / "data";

/// The cornell-boxes.md camera as an ObjCamera.
renderer::ObjCamera cornell_obj_camera() {
  const Vec3 position(T(-0.0439815), T(-4.12529), T(0.222539));
  return {position, position + Vec3(T(0.006886253), T(0.9985055), T(-0.05421613)),
          Vec3(T(0.0003738963), T(0.05421484), T(0.9985293)), 45.0f};
}

/// The message of the exception `f` throws as E ("" if none or another type).
template <class E, class F>
std::string message_of(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  } catch (...) {
    return "<other exception>";
  }
  return "";
}

/// Writes `text` to a file in a fresh test directory and returns its path.
std::string write_file(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / "segpath_obj_scene_test";
  std::filesystem::create_directories(dir);
  const auto path = dir / name;
  std::ofstream(path) << text;
  return path.string();
}

/// Box [lo, hi] as quads facing outwards (or inwards), one material per face
/// (x0, x1, y0, y1, z0, z1; invalid_id: face omitted) — cornell.hpp style.
void add_box(segpath::EmbreeManifold<T>::Description& d, Vec3 lo, Vec3 hi, bool outward,
             const std::array<std::uint32_t, 6>& material) {
  const T s = outward ? T(1) : T(-1);
  const std::array<std::array<Vec3, 5>, 6> faces{{
      {Vec3(lo.x, lo.y, lo.z), Vec3(lo.x, hi.y, lo.z), Vec3(lo.x, hi.y, hi.z), Vec3(lo.x, lo.y, hi.z), Vec3(-s, 0, 0)},
      {Vec3(hi.x, lo.y, lo.z), Vec3(hi.x, hi.y, lo.z), Vec3(hi.x, hi.y, hi.z), Vec3(hi.x, lo.y, hi.z), Vec3(s, 0, 0)},
      {Vec3(lo.x, lo.y, lo.z), Vec3(hi.x, lo.y, lo.z), Vec3(hi.x, lo.y, hi.z), Vec3(lo.x, lo.y, hi.z), Vec3(0, -s, 0)},
      {Vec3(lo.x, hi.y, lo.z), Vec3(hi.x, hi.y, lo.z), Vec3(hi.x, hi.y, hi.z), Vec3(lo.x, hi.y, hi.z), Vec3(0, s, 0)},
      {Vec3(lo.x, lo.y, lo.z), Vec3(hi.x, lo.y, lo.z), Vec3(hi.x, hi.y, lo.z), Vec3(lo.x, hi.y, lo.z), Vec3(0, 0, -s)},
      {Vec3(lo.x, lo.y, hi.z), Vec3(hi.x, lo.y, hi.z), Vec3(hi.x, hi.y, hi.z), Vec3(lo.x, hi.y, hi.z), Vec3(0, 0, s)},
  }};
  for (std::size_t k = 0; k < 6; ++k) {
    if (material[k] == segpath::invalid_id) continue;
    auto& mesh = d.meshes.emplace_back();
    mesh.material_id = material[k];
    renderer::detail::add_quad(mesh, faces[k][0], faces[k][1], faces[k][2], faces[k][3], faces[k][4]);
  }
}

/// tests/renderer/data/cornell_obj.obj built in code, its light's radiance times `light_scale`.
renderer::RenderScene cornell_obj_in_code(std::uint32_t width, std::uint32_t height, T light_scale = 1) {
  segpath::MaterialSet<Color> m;
  const auto white = m.add(segpath::Lambertian<Color>{Color(T(0.803922))});
  const auto green = m.add(segpath::Lambertian<Color>{Color(T(0.156863), T(0.803922), T(0.172549))});
  const auto red = m.add(segpath::Lambertian<Color>{Color(T(0.803922), T(0.152941), T(0.152941))});
  const auto blue = m.add(segpath::Lambertian<Color>{Color(T(0.156863), T(0.172549), T(0.803922))});
  const auto floor = m.add(segpath::Glossy<Color>(Color(T(0.1)), Color(T(0.7)), T(90)));
  const auto mirror = m.add(segpath::Mirror<Color>(Color(T(1))));
  const auto glass = m.add(segpath::Dielectric<Color>(T(1.6)));
  const auto black = m.add(segpath::Lambertian<Color>{Color(T(0))});
  constexpr auto none = segpath::invalid_id;
  const T x0 = T(-1.27029), x1 = T(1.28975), y0 = T(-1.25549), y1 = T(1.30455), z0 = T(-1.28002), z1 = T(1.28002);
  segpath::EmbreeManifold<T>::Description d;
  add_box(d, {x0, y0, z0}, {x1, y1, z1}, false, {green, red, none, blue, floor, white});
  add_box(d, {-0.25f, -0.25f, 1.26002f}, {0.25f, 0.25f, 1.28002f}, true, {white, white, white, white, none, none});
  add_box(d, {-0.8f, -0.2f, z0}, {-0.2f, 0.5f, -0.4f}, true, {mirror, mirror, mirror, mirror, none, mirror});
  add_box(d, {0.2f, -0.6f, -1.0f}, {0.8f, 0.0f, -0.4f}, true, {glass, glass, glass, glass, glass, glass});
  // The emitter last: primitive ids are the triangles counted so far.
  std::uint32_t id = 0;
  for (const auto& mesh : d.meshes) id += std::uint32_t(mesh.triangles.size());
  auto& light = d.meshes.emplace_back();
  light.material_id = black;
  renderer::detail::add_quad(light, {-0.25f, -0.25f, 1.26002f}, {0.25f, -0.25f, 1.26002f}, {0.25f, 0.25f, 1.26002f},
                             {-0.25f, 0.25f, 1.26002f}, {0, 0, -1});
  std::vector<segpath::EmissiveTriangle<T>> emissive;
  for (const auto& t : light.triangles)
    emissive.push_back({light.positions[t[0]], light.positions[t[1]], light.positions[t[2]], id++, black, Vec3(0)});
  return renderer::RenderScene("cornell_obj (code)", segpath::EmbreeManifold<T>(d), std::move(m),
                               segpath::TriangleLights<Color>(emissive, Color(T(25.03329849) * light_scale)),
                               segpath::cornell_camera<T>(width, height));
}

struct SumSink {
  Color value{T(0)};
  std::uint64_t drops = 0;
  void add(std::uint32_t, const Color& v) noexcept { value += v; }
  void drop(segpath::DropReason) noexcept { ++drops; }
};

/// Per-path PT estimates (channel average) over every pixel, `spp` paths each.
segpath::testing::RunningStats render_stats(const renderer::RenderScene& scene, std::uint32_t pixels,
                                            std::uint32_t spp, std::uint64_t seed, std::uint64_t& drops) {
  const segpath::PathTracer<renderer::RenderScene> pt({renderer::cornell_max_length, segpath::MisHeuristic::power, 0});
  segpath::testing::RunningStats stats;
  for (std::uint32_t s = 0; s < spp; ++s)
    for (std::uint32_t p = 0; p < pixels; ++p) {
      Pcg32 rng = Pcg32::for_sample(seed, p, s);
      SumSink sink;
      pt.estimate(scene, {p, s}, rng, sink);
      drops += sink.drops;
      stats.add(double(segpath::average(sink.value)));
    }
  return stats;
}

}  // namespace

TEST_CASE("parse_vec3 reads x,y,z and rejects anything else", "[renderer]") {
  CHECK(renderer::parse_vec3("1,2.5,-3") == Vec3(1, T(2.5), -3));
  CHECK(renderer::parse_vec3(" 0.5 , 1e-3,2 ") == Vec3(T(0.5), T(1e-3), 2));
  for (const char* bad : {"", "1,2", "1,2,3,4", "1,,3", "a,b,c", "1,2,nan", "1,2,inf", "1;2;3", "1,2,3x"})
    CHECK_THROWS_AS(renderer::parse_vec3(bad), std::invalid_argument);
}

TEST_CASE("The OBJ camera is a look-at pinhole", "[renderer]") {
  // Square: the cornell camera's 45 degrees on both axes.
  const auto ours = renderer::make_obj_camera(cornell_obj_camera(), 64, 64);
  const auto reference = segpath::cornell_camera<T>(64, 64);
  for (std::uint32_t pixel : {0u, 100u, 64u * 64u - 1u}) {
    const Vec3 a = ours.direction_through({T(pixel % 64) + T(0.5), T(pixel / 64) + T(0.5)});
    const Vec3 b = reference.direction_through({T(pixel % 64) + T(0.5), T(pixel / 64) + T(0.5)});
    CHECK(glm::length(a - b) < T(1e-5));
  }
  // Wide: the vertical field of view is kept, the horizontal one follows the aspect ratio.
  const auto wide = renderer::make_obj_camera(cornell_obj_camera(), 96, 48);
  const Vec3 forward = glm::normalize(cornell_obj_camera().target - cornell_obj_camera().position);
  const T half_angle_y = std::acos(glm::dot(wide.direction_through({48, 0}), forward));
  const T half_angle_x = std::acos(glm::dot(wide.direction_through({0, 24}), forward));
  CHECK(half_angle_y == Approx(22.5 * 3.14159265358979 / 180).epsilon(1e-4));
  CHECK(std::tan(half_angle_x) == Approx(2 * std::tan(22.5 * 3.14159265358979 / 180)).epsilon(1e-4));
  auto c = cornell_obj_camera();
  c.up = c.target - c.position;
  CHECK_THROWS_AS(renderer::make_obj_camera(c, 8, 8), std::invalid_argument);
  c = cornell_obj_camera();
  c.target = c.position;
  CHECK_THROWS_AS(renderer::make_obj_camera(c, 8, 8), std::invalid_argument);
  c = cornell_obj_camera();
  c.fov_y_degrees = 180;
  CHECK_THROWS_AS(renderer::make_obj_camera(c, 8, 8), std::invalid_argument);
}

TEST_CASE("MTL materials map to the reference BSDFs; Ke faces are per-triangle lights", "[renderer]") {
  const auto scene = renderer::load_obj_scene((data_dir / "materials.obj").string(), cornell_obj_camera(), 8, 8);
  CHECK(scene.name() == "materials");
  const auto& m = scene.bsdf();
  REQUIRE(m.size() == 10);  // nine MTL materials and the default one
  const auto is = [&]<class B>(std::uint32_t id, B) { return std::holds_alternative<B>(*m.find(id)); };
  CHECK(is(0, segpath::Lambertian<Color>{}));
  CHECK(std::get<segpath::Lambertian<Color>>(*m.find(0)).albedo == Color(T(0.5)));
  CHECK(is(1, segpath::Glossy<Color>(Color(0), Color(0), 1)));
  CHECK(is(2, segpath::Mirror<Color>()));
  CHECK(std::get<segpath::Mirror<Color>>(*m.find(2)).reflectance() == Color(T(0.9)));
  CHECK(is(3, segpath::Mirror<Color>()));
  CHECK(is(4, segpath::Dielectric<Color>(1)));
  CHECK(std::get<segpath::Dielectric<Color>>(*m.find(4)).eta() == T(1.5));
  CHECK(is(5, segpath::Dielectric<Color>(1)));
  CHECK(is(6, segpath::Dielectric<Color>(1)));
  for (std::uint32_t lamp : {7u, 8u, 9u}) {
    INFO("material " << lamp);
    REQUIRE(is(lamp, segpath::Lambertian<Color>{}));
    CHECK(std::get<segpath::Lambertian<Color>>(*m.find(lamp)).albedo == Color(T(lamp == 9 ? 0.8 : 0)));
  }

  // Primitive ids in file order; the default material last; the degenerate triangle kept.
  const auto& manifold = scene.manifold();
  REQUIRE(manifold.triangle_count() == 11);
  CHECK(manifold.primitive_area(10) == T(0));
  std::map<std::uint32_t, std::uint32_t> material_of;
  Pcg32 rng(5, 0);
  for (int k = 0; k < 3000; ++k) {
    const auto s = scene.sample_area({rng.uniform2<T>()});
    REQUIRE(s);
    material_of[s->point.primitive_id] = s->point.material_id;
  }
  REQUIRE(material_of.size() == 10);
  CHECK(material_of[0] == 9);
  for (std::uint32_t id = 1; id < 10; ++id) CHECK(material_of[id] == id - 1);

  // Lights: triangles 8 (Ke 1 2 3, normal +z) and 9 (Ke 4, wound the other way: -z), 10 (degenerate).
  const auto& lights = std::get<segpath::TriangleLights<Color>>(scene.emitter().get());
  REQUIRE(lights.size() == 3);
  CHECK(lights.radiance_of(0) == Color(1, 2, 3));
  CHECK(lights.radiance_of(1) == Color(4));
  CHECK(lights.area(2) == T(0));
  const auto up = segpath::SurfacePoint<T>::on_surface(Vec3(T(0.2), T(0.2), 0), Vec3(0, 0, 1), 8, 7);
  const auto down = segpath::SurfacePoint<T>::on_surface(Vec3(T(0.2), T(0.2), 0), Vec3(0, 0, -1), 9, 8);
  CHECK(scene.emitter().radiance({up, Vec3(0, 0, 1)}) == Color(1, 2, 3));
  CHECK(segpath::is_black(scene.emitter().radiance({up, Vec3(0, 0, -1)})));
  CHECK(scene.emitter().radiance({down, Vec3(0, 0, -1)}) == Color(4));
}

TEST_CASE("A Cornell-like OBJ renders like the same scene built in code", "[renderer][stat]") {
  // Welch t-test on the per-path PT estimates (each pixel alike, so the mean of the sample is
  // the image mean) of the loaded OBJ and of cornell_obj_in_code, independent seeds.
  const std::uint32_t w = 48, h = 48, spp = 32;
  const auto loaded = renderer::load_obj_scene((data_dir / "cornell_obj.obj").string(), cornell_obj_camera(), w, h);
  const auto code = cornell_obj_in_code(w, h);
  const auto brighter = cornell_obj_in_code(w, h, T(1.2));
  std::uint64_t drops = 0;
  const auto a = render_stats(loaded, w * h, spp, 1, drops);
  const auto b = render_stats(code, w * h, spp, 2, drops);
  const auto c = render_stats(brighter, w * h, spp, 3, drops);
  const double alpha = segpath::testing::sidak_alpha(0.01, 2);
  INFO("obj " << a.mean() << " +- " << a.standard_error() << ", code " << b.mean() << " +- " << b.standard_error()
              << ", code with a 20% brighter light " << c.mean() << " +- " << c.standard_error());
  CHECK(drops == 0);
  CHECK(a.mean() > 0);
  CHECK_FALSE(segpath::testing::welch_t_test(a, b).rejects(alpha));
  CHECK(segpath::testing::welch_t_test(a, c).rejects(alpha));  // the test has power
}

TEST_CASE("Bad OBJ and MTL input gives clear errors naming the file", "[renderer]") {
  const renderer::ObjCamera camera = cornell_obj_camera();
  const std::string good_mtl = write_file("good.mtl", "newmtl lamp\nKe 1 1 1\nnewmtl white\nKd 0.5 0.5 0.5\n");
  const std::string triangle = "mtllib good.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl lamp\n";
  const auto load = [&](const std::string& path) {
    return [path, &camera] { (void)renderer::load_obj_scene(path, camera, 4, 4); };
  };
  const auto expect_error = [&]<class E>(const std::string& name, const std::string& text, const std::string& what, E) {
    const std::string path = write_file(name, text);
    const std::string message = message_of<E>(load(path));
    INFO(name << ": \"" << message << "\"");
    CHECK(message.find(path) != std::string::npos);
    CHECK(message.find(what) != std::string::npos);
  };
  const std::runtime_error runtime("");
  const std::invalid_argument invalid("");

  // The good case loads.
  CHECK_NOTHROW(load(write_file("good.obj", triangle + "f 1 2 3\n"))());
  // Missing files.
  const std::string missing = (std::filesystem::temp_directory_path() / "segpath_no_such_file.obj").string();
  CHECK(message_of<std::runtime_error>(load(missing)).find(missing) != std::string::npos);
  expect_error("no_mtl.obj", "mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "missing.mtl", runtime);
  // Malformed or non-finite numbers, bad faces.
  expect_error("nan.obj", "mtllib good.mtl\nv 0 0 nan\nv 1 0 0\nv 0 1 0\nusemtl lamp\nf 1 2 3\n", "line 2", runtime);
  expect_error("huge.obj", "mtllib good.mtl\nv 0 0 1e999\nv 1 0 0\nv 0 1 0\nusemtl lamp\nf 1 2 3\n", "not a finite",
               runtime);
  expect_error("short.obj", "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "line 1", runtime);
  expect_error("range.obj", triangle + "f 1 2 9\n", "out of", runtime);
  expect_error("two.obj", triangle + "f 1 2\n", "malformed", runtime);
  expect_error("zero.obj", triangle + "f 0 1 2\n", "malformed", runtime);
  expect_error("unknown.obj", "mtllib good.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl lampp\nf 1 2 3\n", "lampp", runtime);
  expect_error("bad_mtl.obj", "mtllib bad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "bad.mtl", runtime);
  write_file("bad.mtl", "newmtl x\nKd 0.5 zero 0.5\n");
  expect_error("bad_mtl2.obj", "mtllib bad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "line 2", runtime);
  // Nothing to render.
  expect_error("dark.obj", "mtllib good.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl white\nf 1 2 3\n", "no emitter", runtime);
  expect_error("empty.obj", "v 0 0 0\n", "no faces", runtime);
  expect_error("dark_degenerate.obj", triangle + "f 1 1 2\n", "light", runtime);
  // Materials no BSDF accepts.
  write_file("energy.mtl", "newmtl lamp\nKe 1 1 1\nnewmtl hot\nKd 0.5 0.5 0.5\nKs 0.6 0.6 0.6\nNs 10\n");
  expect_error("energy.obj", "mtllib energy.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl lamp\nf 1 2 3\n", "\"hot\"", invalid);
  write_file("negative.mtl", "newmtl lamp\nKe 1 -1 1\n");
  expect_error("negative.obj", "mtllib negative.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl lamp\nf 1 2 3\n", "Ke", invalid);
  write_file("nons.mtl", "newmtl lamp\nKe 1 1 1\nnewmtl shiny\nKd 0.3 0.3 0.3\nKs 0.3 0.3 0.3\n");
  expect_error("nons.obj", "mtllib nons.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl lamp\nf 1 2 3\n", "Ns", invalid);
  // Degenerate triangles are kept (never sampled): a light with one good triangle loads.
  const auto scene = renderer::load_obj_scene(write_file("degenerate.obj", triangle + "f 1 2 3\nf 1 1 2\nf 3 3 3\n"),
                                              camera, 4, 4);
  CHECK(scene.manifold().triangle_count() == 3);
  CHECK(scene.manifold().primitive_area(1) == T(0));
}
