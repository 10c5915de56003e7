// The four Cornell boxes of SmallVCM, exactly as ../shared/scenes/cornell-boxes.md gives them
// (geometry, materials, lights, camera), so that our images and SmallVCM's have the same
// expected value pixel for pixel. Paths there have at most 10 segments.
#pragma once

#include "render_scene.hpp"

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace renderer {

inline constexpr std::size_t cornell_max_length = 10;

namespace detail {

using Vec3 = segpath::Vec3<T>;

/// Adds the quad a-b-c-d as two triangles wound so that their normal is `inward`.
inline void add_quad(segpath::EmbreeManifold<T>::Mesh& mesh, Vec3 a, Vec3 b, Vec3 c, Vec3 d, Vec3 inward) {
  if (glm::dot(glm::cross(b - a, c - a), inward) < 0) std::swap(b, d);
  const auto base = static_cast<std::uint32_t>(mesh.positions.size());
  mesh.positions.insert(mesh.positions.end(), {a, b, c, d});
  mesh.triangles.push_back({base, base + 1, base + 2});
  mesh.triangles.push_back({base, base + 2, base + 3});
}

}  // namespace detail

/// Cornell box `box` in 0..3 at width x height pixels (the camera keeps its 45 degree field of
/// view on both axes at 512 x 512; other sizes keep square pixels).
inline RenderScene make_cornell(int box, std::uint32_t width, std::uint32_t height) {
  using detail::Vec3;
  if (box < 0 || box > 3) throw std::invalid_argument("cornell box must be 0..3, got " + std::to_string(box));
  const T x0 = T(-1.27029), x1 = T(1.28975), y0 = T(-1.25549), y1 = T(1.30455), z0 = T(-1.28002), z1 = T(1.28002);

  segpath::MaterialSet<Color> materials;
  const auto white = materials.add(segpath::Lambertian<Color>{Color(T(0.803922))});
  const auto green = materials.add(segpath::Lambertian<Color>{Color(T(0.156863), T(0.803922), T(0.172549))});
  const auto red = materials.add(segpath::Lambertian<Color>{Color(T(0.803922), T(0.152941), T(0.152941))});
  const auto blue = materials.add(segpath::Lambertian<Color>{Color(T(0.156863), T(0.172549), T(0.803922))});
  const auto glossy = materials.add(segpath::Glossy<Color>(Color(T(0.1)), Color(T(0.7)), T(90)));
  const auto mirror = materials.add(segpath::Mirror<Color>(Color(T(1))));
  const auto glass = materials.add(segpath::Dielectric<Color>(T(1.6)));
  // "A path that hits an emitter ends there": the emitter surface reflects nothing.
  const auto black = materials.add(segpath::Lambertian<Color>{Color(T(0))});

  segpath::EmbreeManifold<T>::Description description;
  auto mesh_of = [&](std::uint32_t material) -> segpath::EmbreeManifold<T>::Mesh& {
    description.meshes.push_back({});
    description.meshes.back().material_id = material;
    return description.meshes.back();
  };
  // The box; the front face (y = y0) is open.
  detail::add_quad(mesh_of(glossy), {x0, y0, z0}, {x1, y0, z0}, {x1, y1, z0}, {x0, y1, z0}, {0, 0, 1});
  detail::add_quad(mesh_of(white), {x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1}, {0, 0, -1});
  detail::add_quad(mesh_of(green), {x0, y0, z0}, {x0, y1, z0}, {x0, y1, z1}, {x0, y0, z1}, {1, 0, 0});
  detail::add_quad(mesh_of(red), {x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1}, {x1, y0, z1}, {-1, 0, 0});
  detail::add_quad(mesh_of(blue), {x0, y1, z0}, {x1, y1, z0}, {x1, y1, z1}, {x0, y1, z1}, {0, -1, 0});
  std::uint32_t triangles = 10;

  // The light box hanging under the ceiling (not in box 2): outward-facing white faces; in
  // box 1 its underside is the emitter. Its top lies in the ceiling and is never seen.
  std::vector<segpath::EmissiveTriangle<T>> emissive;
  if (box != 2) {
    const T lx0 = T(-0.25), lx1 = T(0.25), lz0 = T(1.26002), lz1 = T(1.28002);
    auto& sides = mesh_of(white);
    detail::add_quad(sides, {lx0, lx0, lz0}, {lx0, lx1, lz0}, {lx0, lx1, lz1}, {lx0, lx0, lz1}, {-1, 0, 0});
    detail::add_quad(sides, {lx1, lx0, lz0}, {lx1, lx1, lz0}, {lx1, lx1, lz1}, {lx1, lx0, lz1}, {1, 0, 0});
    detail::add_quad(sides, {lx0, lx0, lz0}, {lx1, lx0, lz0}, {lx1, lx0, lz1}, {lx0, lx0, lz1}, {0, -1, 0});
    detail::add_quad(sides, {lx0, lx1, lz0}, {lx1, lx1, lz0}, {lx1, lx1, lz1}, {lx0, lx1, lz1}, {0, 1, 0});
    triangles += 8;
    auto& underside = mesh_of(box == 1 ? black : white);
    // The two emitter triangles exactly as SmallVCM lists them (normal -z by their winding).
    const std::array<std::array<Vec3, 3>, 2> light_triangles{{{Vec3(-0.25f, 0.25f, lz0), Vec3(0.25f, -0.25f, lz0), Vec3(-0.25f, -0.25f, lz0)},
                                                              {Vec3(0.25f, -0.25f, lz0), Vec3(-0.25f, 0.25f, lz0), Vec3(0.25f, 0.25f, lz0)}}};
    for (const auto& tri : light_triangles) {
      const auto base = static_cast<std::uint32_t>(underside.positions.size());
      underside.positions.insert(underside.positions.end(), tri.begin(), tri.end());
      underside.triangles.push_back({base, base + 1, base + 2});
      if (box == 1) emissive.push_back({tri[0], tri[1], tri[2], triangles, black, Vec3(0)});
      ++triangles;
    }
  }
  if (box == 1) {
    description.spheres.push_back({Vec3(0.00973f, 0.02453f, -0.48002f), T(0.8), mirror});
  } else {
    description.spheres.push_back({Vec3(-0.53885f, 0.02453f, -0.78002f), T(0.5), mirror});
    description.spheres.push_back({Vec3(0.55831f, 0.02453f, -0.78002f), T(0.5), glass});
  }

  // Bounds for the distant lights' emission disks: the box's bounding sphere.
  const Vec3 centre((x0 + x1) / 2, (y0 + y1) / 2, T(0));
  const T radius = glm::length(Vec3(x1, y1, z1) - centre) * T(1.01);
  auto emitter = [&]() -> Emitter {
    switch (box) {
      case 0: return segpath::DirectionalLight<Color>(glm::normalize(Vec3(-1, 1.5f, -1)), Color(10, 4, 0), centre, radius);
      case 1: return segpath::TriangleLights<Color>(emissive, Color(T(25.03329849)));
      case 2: return segpath::PointLight<Color>(Vec3(0, -0.5f, 1), Color(T(70.0 / (4.0 * 3.14159265358979323846))));
      default: return segpath::BackgroundLight<Color>(Color(135, 206, 250) / T(255), centre, radius);
    }
  }();
  return RenderScene("cornell" + std::to_string(box), segpath::EmbreeManifold<T>(description), std::move(materials),
                     std::move(emitter), segpath::cornell_camera<T>(width, height));
}

}  // namespace renderer
