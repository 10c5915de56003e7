// The Kernel concept: the soft junction K(s_i, s_{i+1}) between the light end y_i of one
// segment and the sensor end x_{i+1} of the next (N18, N19).
// Customization points: K::Scalar, K::is_dirac, eval(KernelQuery), sample(KernelSampleQuery),
//   pdf(KernelQuery), support_radius(KernelSupportQuery).
#pragma once

#include "segpath/core/segment.hpp"

#include <concepts>
#include <optional>

namespace segpath {

/// K(from, to): the kernel value joining from.y to to.x. Kernels may also depend on the
/// directions of both segments.
template <Real T>
struct KernelQuery {
  const Segment<T>& from;
  const Segment<T>& to;
};

/// Draw the next sensor end x' around `from.y` (p_K in (N31)).
template <Real T>
struct KernelSampleQuery {
  const Segment<T>& from;
  Vec2<T> u;
};

/// The drawn junction point and its area density p_K(x' | from). For a Dirac kernel the
/// point is from.y and pdf is 1, the coefficient of the delta shared with eval.
template <Real T>
struct KernelSample {
  SurfacePoint<T> point;
  T pdf = 0;
};

template <Real T>
struct KernelSupportQuery {
  const SurfacePoint<T>& center;
};

namespace detail {
template <class K>
concept HasKernelScalar = requires { typename K::Scalar; } && Real<typename K::Scalar>;
template <class K>
concept HasIsDirac = requires {
  { K::is_dirac } -> std::convertible_to<bool>;
} && std::bool_constant<K::is_dirac>::value == K::is_dirac;
template <class K>
concept HasKernelEval = requires(const K& k, const KernelQuery<typename K::Scalar>& q) {
  { k.eval(q) } -> std::convertible_to<typename K::Scalar>;
};
template <class K>
concept HasKernelSample = requires(const K& k, const KernelSampleQuery<typename K::Scalar>& q) {
  { k.sample(q) } -> std::same_as<std::optional<KernelSample<typename K::Scalar>>>;
};
template <class K>
concept HasKernelPdf = requires(const K& k, const KernelQuery<typename K::Scalar>& q) {
  { k.pdf(q) } -> std::convertible_to<typename K::Scalar>;
};
template <class K>
concept HasSupportRadius = requires(const K& k, const KernelSupportQuery<typename K::Scalar>& q) {
  { k.support_radius(q) } -> std::convertible_to<typename K::Scalar>;
};
}  // namespace detail

/// A junction kernel. Syntactic requirements:
///  1. `K::Scalar` is float or double;
///  2. `K::is_dirac` is a constant expression (true: K = delta(x' - y), the segments touch);
///  3. `k.eval(KernelQuery)` returns K(s, s');
///  4. `k.sample(KernelSampleQuery)` returns std::optional<KernelSample>;
///  5. `k.pdf(KernelQuery)` returns p_K(to.x | from);
///  6. `k.support_radius(KernelSupportQuery)` returns the radius of the support around a
///     point (0 for a Dirac kernel).
/// Semantic requirements:
///  7. normalisation (N18): the integral of eval over to.x on M is 1 (exactly on planar
///     neighbourhoods for the disk kernel);
///  8. eval is 0 outside the support; pdf of a sample equals the returned pdf;
///  9. for a Dirac kernel eval and pdf are 1 when to.x is from.y and 0 otherwise.
template <class K>
concept Kernel = detail::HasKernelScalar<K> && detail::HasIsDirac<K> && detail::HasKernelEval<K> &&
                 detail::HasKernelSample<K> && detail::HasKernelPdf<K> &&
                 detail::HasSupportRadius<K>;

/// A Kernel of scalar T: what every template taking a scene and a kernel requires of the
/// kernel, so that a DiracKernel<double> given to a float scene is rejected at the template's
/// own constraints (KernelOf<K, float>: std::same_as<double, float>), not inside it.
template <class K, class T>
concept KernelOf = Kernel<K> && std::same_as<typename K::Scalar, T>;

}  // namespace segpath
