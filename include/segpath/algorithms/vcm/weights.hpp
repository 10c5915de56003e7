// The multiple importance sampling of segpath's VCM family (algorithms/vcm.hpp): Georgiev et
// al. 2012's recursive quantities per subpath end (dVCM, dVC, dVM as in SmallVCM) and the MIS
// weight (N5, N36 over the full-path densities) of each technique: emission (s = 0), next-event
// bridge (s = 1), Dirac bridge between subpath ends, light subpath bridged to the sensor (t = 1)
// and merge. Stateless: every function takes the scene and the iteration's constants.
#pragma once

#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/frame.hpp"
#include "segpath/core/geometry.hpp"
#include "segpath/core/roulette.hpp"
#include "segpath/weights/mis.hpp"

#include <cmath>
#include <cstdint>

namespace segpath {

/// Georgiev et al.'s recursive MIS quantities of a subpath end (SmallVCM's dVCM, dVC, dVM),
/// already divided by the heuristic's power of the cosine and distance of the segment that
/// reached the end.
template <Real T>
struct VcmMisState {
  T d_vcm = 0;
  T d_vc = 0;
  T d_vm = 0;
};

/// A camera or light subpath end: the y of a camera subpath's last segment, or the x of a light
/// subpath's first segment. `to_previous` is the unit direction towards the previous end of the
/// same subpath (towards the sensor on camera subpaths, towards the light on light subpaths);
/// `throughput` is the product of the sampler weights of its segments; `length` their number.
template <class S>
struct VcmVertex {
  using Scalar = spectrum_scalar_t<S>;
  SurfacePoint<Scalar> point;
  Vec3<Scalar> to_previous{};
  S throughput{};
  VcmMisState<Scalar> mis{};
  std::uint32_t length = 0;
  /// Camera ends: every scattering before this end was a delta lobe. Light ends: the lobe that
  /// continued the light subpath from this end was a delta (no connection or merging here).
  bool specular = false;
};

/// What merging reads of a stored light end (VcmVertex without its position, which the hash grid
/// keeps beside it, and without what only connections need). The grid stores these in its cell
/// order, so a merge query streams through them.
template <class S>
struct VcmPhoton {
  using Scalar = spectrum_scalar_t<S>;
  Vec3<Scalar> normal{};
  Vec3<Scalar> to_previous{};
  S throughput{};
  VcmMisState<Scalar> mis{};
  std::uint32_t length = 0;

  [[nodiscard]] static VcmPhoton of(const VcmVertex<S>& v) noexcept {
    return VcmPhoton{v.point.normal, v.to_previous, v.throughput, v.mis, v.length};
  }
};

/// The constants of one iteration: radius, light-subpath count and the MIS factors of
/// (Georgiev et al. 2012) eta = pi r^2 N_light.
template <Real T>
struct VcmIteration {
  T radius = 0;
  T light_paths = 1;
  T merge_normalization = 0;  ///< K / N_light = 1 / (pi r^2 N_light)
  T vm_factor = 0;            ///< heuristic(eta) when merging is on, else 0
  T vc_factor = 0;            ///< heuristic(1 / eta) when connections are on, else 0
  MisHeuristic heuristic = MisHeuristic::power;
  bool connect = false;
  bool merge = false;
  bool ppm = false;
  /// Every scattering is subject to Russian roulette (VcmOptions::roulette_from == 1): the MIS
  /// densities of scatterings carry its continuation probability.
  bool roulette = false;
  /// Light subpaths can be bridged to the sensor (t = 1): off for sensors that are Dirac in
  /// direction (radiance probes), whose rays no bridge can hit.
  bool camera_connectable = false;
};

/// The MIS quantities and weights of VertexConnectionMerging<Scn>, which derives from it.
template <LightSampledScene Scn>
struct VcmWeights {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  using Vertex = VcmVertex<S>;
  using Iteration = VcmIteration<T>;
  using MisState = VcmMisState<T>;

  // ---- MIS weights of each technique (N5 over Georgiev et al.'s full-path densities) -------

  /// s = 0: the camera subpath reached an emitter at `v` (`previous` is the end before it).
  [[nodiscard]] static T emission_weight(const Scn& scene, const Iteration& it, const SurfacePoint<T>& previous,
                                  const Vertex& v) noexcept {
    if (v.length <= 1) return T(1);
    const auto& emitter = scene.emitter();
    const T direct = emitter.pdf_towards(EmitterPdfTowardsQuery<T>{previous, v.point});
    const bool finite = v.point.kind != PointKind::direction;
    const EmissionPdf<T> e =
        emitter.pdf_emission(EmissionPdfQuery<T>{v.point, finite ? v.to_previous : previous.position});
    const T w_camera = mis(it, direct) * v.mis.d_vcm + mis(it, e.position * e.direction) * v.mis.d_vc;
    return reciprocal(T(1) + w_camera);
  }

  /// s = 1: the next-event bridge `e` (LightBridgeSampler's sample from camera end `v`).
  [[nodiscard]] static T nee_weight(const Scn& scene, const Iteration& it, const Vertex& v,
                             const SegmentSample<S>& e) noexcept {
    return nee_weight(scene, it, v, e, roulette_f(scene, it, {v.point, v.to_previous, e.direction, Transport::radiance}));
  }
  /// nee_weight with f_r at v for the bridge's direction (used only with roulette in the MIS).
  [[nodiscard]] static T nee_weight(const Scn& scene, const Iteration& it, const Vertex& v, const SegmentSample<S>& e,
                             const S& f) noexcept {
    const Vec3<T>& d = e.direction;
    const BsdfQuery<T> forward{v.point, v.to_previous, d, Transport::radiance};
    const BsdfQuery<T> reverse{v.point, v.to_previous, d, Transport::importance};
    const T forward_pdf = scene.bsdf().pdf(forward);
    const T reverse_pdf = scene.bsdf().pdf(reverse);
    const T forward_density = forward_pdf * continuation(it, f, endpoint_cosine(v.point, d), forward_pdf);
    const T reverse_density = reverse_pdf * continuation(it, f, endpoint_cosine(v.point, v.to_previous), reverse_pdf);
    const T w_light = e.delta ? T(0) : mis(it, solid_angle_to_area(forward_density, v.point, e.segment.y) / e.pdf);
    const SurfacePoint<T>& y = e.segment.y;
    const bool finite = y.kind != PointKind::direction;
    const EmissionPdf<T> ep = scene.emitter().pdf_emission(EmissionPdfQuery<T>{y, finite ? -d : v.point.position});
    const T to_x = finite ? solid_angle_to_area(T(1), y, v.point) : endpoint_cosine(v.point, d);
    const T w_camera = mis(it, ep.position * ep.direction * to_x / e.pdf) *
                       (it.vm_factor + v.mis.d_vcm + v.mis.d_vc * mis(it, reverse_density));
    return reciprocal(w_light + T(1) + w_camera);
  }

  /// s, t >= 2: the Dirac bridge (N34) between camera end `c` and light end `l`.
  [[nodiscard]] static T connection_weight(const Scn& scene, const Iteration& it, const Vertex& c, const Vertex& l) noexcept {
    const Vec3<T> delta = l.point.position - c.point.position;
    const T d2 = glm::dot(delta, delta);
    if (!(d2 > T(0)) || !std::isfinite(d2)) return T(0);
    const Vec3<T> d = delta / std::sqrt(d2);
    return connection_weight(scene, it, c, l, d, d2, roulette_f(scene, it, {c.point, c.to_previous, d, Transport::radiance}),
                             roulette_f(scene, it, {l.point, -d, l.to_previous, Transport::radiance}));
  }

  /// t = 1: the sensor bridge `b` (SensorBridgeSampler's sample towards light end `l`).
  [[nodiscard]] static T camera_connection_weight(const Scn& scene, const Iteration& it, const Vertex& l,
                                           const SegmentSample<S>& b) noexcept {
    return camera_connection_weight(scene, it, l, b,
                                    roulette_f(scene, it, {l.point, -b.direction, l.to_previous, Transport::radiance}));
  }
  /// camera_connection_weight with f_r at l for the bridge's direction.
  [[nodiscard]] static T camera_connection_weight(const Scn& scene, const Iteration& it, const Vertex& l, const SegmentSample<S>& b,
                                           const S& f) noexcept {
    const T reverse_pdf = scene.bsdf().pdf(BsdfQuery<T>{l.point, -b.direction, l.to_previous, Transport::radiance});
    const T reverse = reverse_pdf * continuation(it, f, endpoint_cosine(l.point, l.to_previous), reverse_pdf);
    const T camera_pdf = solid_angle_to_area(
        scene.sensor().pdf(SensorQuery<T>{b.segment.x, b.direction}).direction, b.segment.x, l.point);
    const T w_light = mis(it, camera_pdf / it.light_paths) * (it.vm_factor + l.mis.d_vcm + l.mis.d_vc * mis(it, reverse));
    return reciprocal(T(1) + w_light);
  }

  /// The merge of camera end `c` with light end `l` (disk kernel); 1 in ppm mode.
  [[nodiscard]] static T merge_weight(const Scn& scene, const Iteration& it, const Vertex& c, const Vertex& l) noexcept {
    if (it.ppm) return T(1);
    return merge_weight(scene, it, c, l, roulette_f(scene, it, {c.point, c.to_previous, l.to_previous, Transport::radiance}));
  }
  /// merge_weight with f_r at c between the two subpaths' directions; `l` is a light end's
  /// VcmVertex or VcmPhoton (its `to_previous` and `mis` are read).
  template <class LightEnd>
  [[nodiscard]] static T merge_weight(const Scn& scene, const Iteration& it, const Vertex& c, const LightEnd& l, const S& f) noexcept {
    if (it.ppm) return T(1);
    const T forward_pdf = scene.bsdf().pdf(BsdfQuery<T>{c.point, c.to_previous, l.to_previous, Transport::radiance});
    const T reverse_pdf = scene.bsdf().pdf(BsdfQuery<T>{c.point, c.to_previous, l.to_previous, Transport::importance});
    const T forward = forward_pdf * continuation(it, f, endpoint_cosine(c.point, l.to_previous), forward_pdf);
    const T reverse = reverse_pdf * continuation(it, f, endpoint_cosine(c.point, c.to_previous), reverse_pdf);
    const T w_light = l.mis.d_vcm * it.vc_factor + l.mis.d_vm * mis(it, forward);
    const T w_camera = c.mis.d_vcm * it.vc_factor + c.mis.d_vm * mis(it, reverse);
    return reciprocal(w_light + T(1) + w_camera);
  }

  // ---- the recursion of Georgiev et al.'s quantities along a subpath -----------------------

  [[nodiscard]] static T mis(const Iteration& it, T x) noexcept {
    return it.heuristic == MisHeuristic::balance ? x : x * x;
  }
  [[nodiscard]] static T reciprocal(T x) noexcept { return x > T(0) && std::isfinite(x) ? T(1) / x : T(0); }

  /// The roulette's continuation probability as a factor of a scattering's solid-angle density
  /// in the MIS (it.roulette): q = min(1, max(f_r) |cos| / pdf) of the scattering that samples
  /// the direction (cosine `cosine`, density `pdf`), the rule the subpaths' roulette applies
  /// (core/roulette.hpp). The reverse direction's q takes f_r of radiance transport, exact for
  /// BSDFs that are symmetric there (no refraction, no shading normals); a weight computed with
  /// another q is still unbiased.
  [[nodiscard]] static T continuation(const Iteration& it, const S& f, T cosine, T pdf) noexcept {
    if (!it.roulette || !(pdf > T(0))) return T(1);
    return continuation_probability(S(f * (cosine / pdf)), false);
  }
  /// f_r for `continuation`, evaluated only when the MIS carries the roulette.
  [[nodiscard]] static S roulette_f(const Scn& scene, const Iteration& it, const BsdfQuery<T>& q) noexcept {
    return it.roulette ? scene.bsdf().eval(q) : S(T(0));
  }

  /// Whether a light end is a Dirac (see the class comment).
  [[nodiscard]] static bool dirac_light_end(const Scn& scene, const SurfacePoint<T>& y, const SurfacePoint<T>& x) noexcept {
    if (y.kind == PointKind::point) return true;
    if (y.kind == PointKind::surface) return false;
    const Frame<T> frame = Frame<T>::from_normal(y.position);
    SurfacePoint<T> nearby = y;
    nearby.position = glm::normalize(y.position + frame.tangent * T(1e-3));
    nearby.normal = nearby.shading_normal = nearby.position;
    return !(scene.emitter().pdf_emission(EmissionPdfQuery<T>{nearby, x.position}).position > T(0));
  }

  /// The camera subpath's quantities at the sensor: only t = 1 (a light subpath bridged to the
  /// sensor) competes there, with density N_light per unit of the pixel's direction density.
  [[nodiscard]] static MisState camera_start(const Iteration& it, T camera_pdf_direction) noexcept {
    MisState s;
    if (it.camera_connectable && camera_pdf_direction > T(0) && std::isfinite(camera_pdf_direction))
      s.d_vcm = mis(it, it.light_paths / camera_pdf_direction);
    return s;
  }

  /// The light subpath's quantities at its first surface end x (segment x -> y, unit
  /// direction d from x towards the light end y).
  [[nodiscard]] static bool light_first(const Scn& scene, const Iteration& it, const SurfacePoint<T>& y,
                                        const SurfacePoint<T>& x, const Vec3<T>& d, MisState& s) noexcept {
    const auto& emitter = scene.emitter();
    const bool finite = y.kind != PointKind::direction;
    const EmissionPdf<T> e = emitter.pdf_emission(EmissionPdfQuery<T>{y, finite ? -d : x.position});
    const T emission = e.position * e.direction;
    if (!(emission > T(0)) || !std::isfinite(emission)) return false;
    const T direct = emitter.pdf_towards(EmitterPdfTowardsQuery<T>{x, y});
    const T cos_y = finite ? endpoint_cosine(y, d) : T(1);
    s.d_vcm = mis(it, direct / emission);
    s.d_vc = dirac_light_end(scene, y, x) ? T(0) : mis(it, cos_y / emission);
    s.d_vm = s.d_vc * it.vc_factor;
    return arrive(it, s, y, x, d);
  }

  /// Divides by the heuristic's power of the density conversion of the segment from -> to.
  [[nodiscard]] static bool arrive(const Iteration& it, MisState& s, const SurfacePoint<T>& from,
                                   const SurfacePoint<T>& to, const Vec3<T>& d) noexcept {
    const T cosine = endpoint_cosine(to, d);
    if (!(cosine > T(0))) return false;
    T d2 = T(1);
    if (from.kind != PointKind::direction) {
      const Vec3<T> delta = to.position - from.position;
      d2 = glm::dot(delta, delta);
      if (!(d2 > T(0)) || !std::isfinite(d2)) return false;
    }
    const T inv_cos = mis(it, T(1) / cosine);
    s.d_vcm *= mis(it, d2) * inv_cos;
    s.d_vc *= inv_cos;
    s.d_vm *= inv_cos;
    return std::isfinite(s.d_vcm) && std::isfinite(s.d_vc) && std::isfinite(s.d_vm);
  }

  /// The recursion through a scattering end with forward and reverse solid-angle densities.
  [[nodiscard]] static bool scatter(const Iteration& it, MisState& s, T forward, T reverse, T cos_out, bool delta) noexcept {
    if (delta) {
      s.d_vcm = T(0);
      s.d_vc *= mis(it, cos_out);
      s.d_vm *= mis(it, cos_out);
      return true;
    }
    if (!(forward > T(0)) || !std::isfinite(forward)) return false;
    const T a = mis(it, cos_out / forward);
    const T d_vc = a * (s.d_vc * mis(it, reverse) + s.d_vcm + it.vm_factor);
    const T d_vm = a * (s.d_vm * mis(it, reverse) + s.d_vcm * it.vc_factor + T(1));
    s.d_vcm = mis(it, T(1) / forward);
    s.d_vc = d_vc;
    s.d_vm = d_vm;
    return std::isfinite(d_vc) && std::isfinite(d_vm);
  }

  /// Camera subpath leaving end v along `out` (towards the light).
  [[nodiscard]] static bool scatter_camera(const Scn& scene, const Iteration& it, MisState& s, const Vertex& v,
                                           const Vec3<T>& out, bool delta) noexcept {
    const T cos_out = endpoint_cosine(v.point, out);
    if (delta) return scatter(it, s, T(0), T(0), cos_out, true);
    const BsdfQuery<T> query{v.point, v.to_previous, out, Transport::radiance};
    const T forward = scene.bsdf().pdf(query);
    const T reverse = scene.bsdf().pdf(BsdfQuery<T>{v.point, v.to_previous, out, Transport::importance});
    const S f = roulette_f(scene, it, query);
    return scatter(it, s, forward * continuation(it, f, cos_out, forward),
                   reverse * continuation(it, f, endpoint_cosine(v.point, v.to_previous), reverse), cos_out, false);
  }

  /// Light subpath leaving end v along `out` (towards the sensor).
  [[nodiscard]] static bool scatter_light(const Scn& scene, const Iteration& it, MisState& s, const Vertex& v,
                                          const Vec3<T>& out, bool delta) noexcept {
    const T cos_out = endpoint_cosine(v.point, out);
    if (delta) return scatter(it, s, T(0), T(0), cos_out, true);
    const BsdfQuery<T> query{v.point, out, v.to_previous, Transport::radiance};
    const T forward = scene.bsdf().pdf(BsdfQuery<T>{v.point, out, v.to_previous, Transport::importance});
    const T reverse = scene.bsdf().pdf(query);
    const S f = roulette_f(scene, it, query);
    return scatter(it, s, forward * continuation(it, f, cos_out, forward),
                   reverse * continuation(it, f, endpoint_cosine(v.point, v.to_previous), reverse), cos_out, false);
  }

  /// connection_weight with the unit direction d from c to l, their squared distance and f_r at
  /// both ends (f_c, f_l: used only with roulette in the MIS).
  [[nodiscard]] static T connection_weight(const Scn& scene, const Iteration& it, const Vertex& c, const Vertex& l,
                                    const Vec3<T>& d, T d2, const S& f_c, const S& f_l) noexcept {
    const auto& bsdf = scene.bsdf();
    T c_forward = bsdf.pdf(BsdfQuery<T>{c.point, c.to_previous, d, Transport::radiance});
    T c_reverse = bsdf.pdf(BsdfQuery<T>{c.point, c.to_previous, d, Transport::importance});
    T l_forward = bsdf.pdf(BsdfQuery<T>{l.point, -d, l.to_previous, Transport::importance});
    T l_reverse = bsdf.pdf(BsdfQuery<T>{l.point, -d, l.to_previous, Transport::radiance});
    c_forward *= continuation(it, f_c, endpoint_cosine(c.point, d), c_forward);
    c_reverse *= continuation(it, f_c, endpoint_cosine(c.point, c.to_previous), c_reverse);
    l_forward *= continuation(it, f_l, endpoint_cosine(l.point, d), l_forward);
    l_reverse *= continuation(it, f_l, endpoint_cosine(l.point, l.to_previous), l_reverse);
    const T c_forward_area = c_forward * endpoint_cosine(l.point, d) / d2;
    const T l_forward_area = l_forward * endpoint_cosine(c.point, d) / d2;
    const T w_light = mis(it, c_forward_area) * (it.vm_factor + l.mis.d_vcm + l.mis.d_vc * mis(it, l_reverse));
    const T w_camera = mis(it, l_forward_area) * (it.vm_factor + c.mis.d_vcm + c.mis.d_vc * mis(it, c_reverse));
    return reciprocal(w_light + T(1) + w_camera);
  }
};

}  // namespace segpath
