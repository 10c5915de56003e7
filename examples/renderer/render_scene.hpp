// The renderer's one scene type: an Embree manifold, a material table, one emitter of a
// kind chosen at load time, and a pinhole camera. It models segpath::LightSampledScene, so
// every library algorithm runs on it unchanged.
#pragma once

#include <segpath/adapters/embree.hpp>
#include <segpath/concepts/scene.hpp>
#include <segpath/lights/background_light.hpp>
#include <segpath/lights/directional_light.hpp>
#include <segpath/lights/emitter_variant.hpp>
#include <segpath/lights/point_light.hpp>
#include <segpath/lights/triangle_light.hpp>
#include <segpath/materials/material_set.hpp>
#include <segpath/sensors/pinhole_camera.hpp>

#include <string>
#include <utility>

namespace renderer {

using T = float;
using Color = segpath::Rgb<T>;
using Emitter = segpath::EmitterVariant<Color, segpath::TriangleLights<Color>, segpath::PointLight<Color>,
                                        segpath::DirectionalLight<Color>, segpath::BackgroundLight<Color>>;

class RenderScene {
 public:
  using Scalar = T;
  using Spectrum = Color;

  RenderScene(std::string name, segpath::EmbreeManifold<T> manifold, segpath::MaterialSet<Color> materials,
              Emitter emitter, segpath::PinholeCamera<T> camera)
      : name_(std::move(name)), manifold_(std::move(manifold)), materials_(std::move(materials)),
        emitter_(std::move(emitter)), camera_(std::move(camera)) {}

  [[nodiscard]] const std::string& name() const noexcept { return name_; }
  [[nodiscard]] const segpath::EmbreeManifold<T>& manifold() const noexcept { return manifold_; }

  // Manifold
  [[nodiscard]] T area() const noexcept { return manifold_.area(); }
  [[nodiscard]] std::optional<segpath::AreaSample<T>> sample_area(const segpath::AreaSampleQuery<T>& q) const noexcept {
    return manifold_.sample_area(q);
  }
  [[nodiscard]] std::optional<segpath::Hit<T>> intersect(const segpath::IntersectQuery<T>& q) const noexcept {
    return manifold_.intersect(q);
  }
  [[nodiscard]] bool visible(const segpath::VisibilityQuery<T>& q) const noexcept { return manifold_.visible(q); }

  // Radiometry
  [[nodiscard]] const segpath::MaterialSet<Color>& bsdf() const noexcept { return materials_; }
  [[nodiscard]] const Emitter& emitter() const noexcept { return emitter_; }
  [[nodiscard]] const segpath::PinholeCamera<T>& sensor() const noexcept { return camera_; }

 private:
  std::string name_;
  segpath::EmbreeManifold<T> manifold_;
  segpath::MaterialSet<Color> materials_;
  Emitter emitter_;
  segpath::PinholeCamera<T> camera_;
};

static_assert(segpath::LightSampledScene<RenderScene>);

}  // namespace renderer
