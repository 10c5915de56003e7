// A scene's materials by id: a closed variant of the reference BSDFs, dispatched on the
// surface point's material_id without virtual calls (it is itself a Bsdf).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "segpath/core/format.hpp"
#include "segpath/materials/dielectric.hpp"
#include "segpath/materials/glossy.hpp"
#include "segpath/materials/lambertian.hpp"
#include "segpath/materials/mirror.hpp"
#include "segpath/materials/phong.hpp"

namespace segpath {

/// One of the reference BSDFs.
template <Spectrum S>
using Material = std::variant<Lambertian<S>, Phong<S>, Glossy<S>, Mirror<S>, Dielectric<S>>;

/// The materials of a scene, indexed by SurfacePoint::material_id. eval, sample and pdf
/// forward to the point's material (a switch on the variant's index, no virtual call); a point
/// whose id has no material (invalid_id included) is black: eval 0, pdf 0, sample nullopt.
/// A scene adapter's bsdf() can return a reference to one of these (Scene requirement 3).
template <Spectrum S>
class MaterialSet {
 public:
  using Scalar = spectrum_scalar_t<S>;

  MaterialSet() = default;
  /// Throws std::invalid_argument for too many materials or a Lambertian albedo that is not
  /// finite and >= 0 in every channel (the other materials check theirs when constructed).
  explicit MaterialSet(std::vector<Material<S>> materials) : materials_(std::move(materials)) {
    if (materials_.size() >= invalid_id)
      throw std::invalid_argument("segpath::MaterialSet: too many materials");
    for (std::size_t id = 0; id < materials_.size(); ++id) check(materials_[id], id);
  }

  /// Appends a material and returns its id; throws as the constructor does.
  std::uint32_t add(Material<S> material) {
    if (materials_.size() + 1 >= invalid_id)
      throw std::invalid_argument("segpath::MaterialSet: too many materials");
    check(material, materials_.size());
    materials_.push_back(std::move(material));
    return static_cast<std::uint32_t>(materials_.size() - 1);
  }

  [[nodiscard]] std::size_t size() const noexcept { return materials_.size(); }
  /// The material of `id`, or nullptr.
  [[nodiscard]] const Material<S>* find(std::uint32_t id) const noexcept {
    return id < materials_.size() ? &materials_[id] : nullptr;
  }

  [[nodiscard]] S eval(const BsdfQuery<Scalar>& q) const noexcept {
    const Material<S>* m = find(q.point.material_id);
    if (m == nullptr) return S(Scalar(0));
    return dispatch(*m, [&](const auto& b) noexcept -> S { return b.eval(q); });
  }

  [[nodiscard]] std::optional<BsdfSample<S>> sample(
      const BsdfSampleQuery<Scalar>& q) const noexcept {
    const Material<S>* m = find(q.point.material_id);
    if (m == nullptr) return std::nullopt;
    return dispatch(*m, [&](const auto& b) noexcept { return b.sample(q); });
  }

  [[nodiscard]] Scalar pdf(const BsdfQuery<Scalar>& q) const noexcept {
    const Material<S>* m = find(q.point.material_id);
    if (m == nullptr) return Scalar(0);
    return dispatch(*m, [&](const auto& b) noexcept -> Scalar { return b.pdf(q); });
  }

  /// Whether the point's material has only delta lobes (a path cannot connect through it; the
  /// optional Bsdf customization point `is_delta`, concepts/bsdf.hpp).
  [[nodiscard]] bool is_delta(const SurfacePoint<Scalar>& p) const noexcept {
    const Material<S>* m = find(p.material_id);
    return m != nullptr &&
           (std::holds_alternative<Mirror<S>>(*m) || std::holds_alternative<Dielectric<S>>(*m));
  }

  /// Whether the point's material scatters light arriving from `w` (the optional Bsdf
  /// customization point `scatters_from`, concepts/bsdf.hpp); a point without one is black.
  [[nodiscard]] bool scatters_from(const SurfacePoint<Scalar>& p, const Vec3<Scalar>& w) const noexcept {
    const Material<S>* m = find(p.material_id);
    if (m == nullptr) return false;
    return dispatch(*m, [&](const auto& b) noexcept { return b.scatters_from(p, w); });
  }

  /// The albedo when the point's material is Lambertian (the optional Bsdf customization
  /// point `lambertian_albedo`, concepts/bsdf.hpp), else nullopt.
  [[nodiscard]] std::optional<S> lambertian_albedo(const SurfacePoint<Scalar>& p) const noexcept {
    const Material<S>* m = find(p.material_id);
    if (m == nullptr) return std::nullopt;
    if (const auto* l = std::get_if<Lambertian<S>>(m)) return l->albedo;
    return std::nullopt;
  }

 private:
  /// A Lambertian is an aggregate without a constructor of its own: its albedo is checked here.
  static void check(const Material<S>& material, std::size_t id) {
    const auto* lambertian = std::get_if<Lambertian<S>>(&material);
    if (lambertian && !(is_finite(lambertian->albedo) && min_component(lambertian->albedo) >= Scalar(0)))
      throw std::invalid_argument("segpath::MaterialSet: material " + std::to_string(id) +
                                  " (Lambertian): the albedo must be finite and >= 0 in every channel, got " +
                                  least_channel_text(lambertian->albedo));
  }

  /// f(alternative) through a switch (std::get_if never fails on the matching index).
  template <class F>
  static decltype(auto) dispatch(const Material<S>& m, F&& f) noexcept {
    switch (m.index()) {
      case 0:
        return f(*std::get_if<0>(&m));
      case 1:
        return f(*std::get_if<1>(&m));
      case 2:
        return f(*std::get_if<2>(&m));
      case 3:
        return f(*std::get_if<3>(&m));
      default:
        return f(*std::get_if<4>(&m));
    }
  }
  static_assert(std::variant_size_v<Material<S>> == 5, "dispatch lists every alternative");

  std::vector<Material<S>> materials_;
};

}  // namespace segpath
