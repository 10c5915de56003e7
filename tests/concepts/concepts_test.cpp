// Negative models of every concept: for each syntactic requirement a type that lacks or
// mistypes exactly that member, with the detail:: requirement that must name it. Then
// runtime checks that the archetypes (archetypes.hpp) work with the library's functions.
#include <cstdint>
#include <optional>
#include <segpath/algorithms/filtering/techniques.hpp>
#include <segpath/integrand/contribution.hpp>
#include <segpath/core/rng.hpp>
#include <segpath/core/segment.hpp>
#include <segpath/kernels/dirac.hpp>
#include <vector>

#include "concepts/archetypes.hpp"
#include "support/catch.hpp"

namespace {

using namespace segpath;
namespace arch = segpath::archetypes;

/// A model assembled from parts, each contributing one member; a negative model leaves
/// one part out or swaps in a mistyped one.
template <class... Parts>
struct Model : Parts... {};

/// Neither a scalar nor a bool nor anything else a concept asks for.
struct Unrelated {};

// ---------------------------------------------------------------------------------------
// Spectrum (core/spectrum.hpp): one class template, each instance without one operation.

enum class Op {
  none,
  scalar_trait,        // 3: no spectrum_scalar specialization
  equality,            // 1: not std::regular
  construct,           // 1: not constructible from a scalar
  plus,                // 1: +
  plus_assign,         // 1: +=
  times,               // 1: * per channel
  times_scalar,        // 1: * by a scalar
  divide_scalar,       // 1: / by a scalar
  max_component,       // 2
  average,             // 2
  is_finite,           // 2
  is_black,            // 2
  max_component_type,  // 2: max_component returns something that is not a scalar
};

template <Op Missing>
struct PartialSpectrum {
  PartialSpectrum() = default;
  explicit PartialSpectrum(float) noexcept requires(Missing != Op::construct) {}

  PartialSpectrum& operator+=(const PartialSpectrum&) noexcept
      requires(Missing != Op::plus_assign) {
    return *this;
  }
  friend PartialSpectrum operator+(PartialSpectrum a, const PartialSpectrum&) noexcept
      requires(Missing != Op::plus) {
    return a;
  }
  friend PartialSpectrum operator*(PartialSpectrum a, const PartialSpectrum&) noexcept
      requires(Missing != Op::times) {
    return a;
  }
  friend PartialSpectrum operator*(PartialSpectrum a, float) noexcept
      requires(Missing != Op::times_scalar) {
    return a;
  }
  friend PartialSpectrum operator/(PartialSpectrum a, float) noexcept
      requires(Missing != Op::divide_scalar) {
    return a;
  }
  friend bool operator==(const PartialSpectrum&, const PartialSpectrum&) noexcept
      requires(Missing != Op::equality) {
    return true;
  }
  friend float max_component(const PartialSpectrum&) noexcept
      requires(Missing != Op::max_component && Missing != Op::max_component_type) {
    return 0;
  }
  friend Unrelated max_component(const PartialSpectrum&) noexcept
      requires(Missing == Op::max_component_type) {
    return {};
  }
  friend float average(const PartialSpectrum&) noexcept requires(Missing != Op::average) {
    return 0;
  }
  friend bool is_finite(const PartialSpectrum&) noexcept requires(Missing != Op::is_finite) {
    return true;
  }
  friend bool is_black(const PartialSpectrum&) noexcept requires(Missing != Op::is_black) {
    return true;
  }
};

}  // namespace

namespace user_types {

/// A spectrum with every operation but whose overloads were added to namespace segpath
/// instead of its own: the Spectrum concept calls them unqualified, so they are not found.
struct OverloadsInSegpath {
  OverloadsInSegpath() = default;
  explicit OverloadsInSegpath(float) noexcept {}
  OverloadsInSegpath& operator+=(const OverloadsInSegpath&) noexcept { return *this; }
  friend OverloadsInSegpath operator+(OverloadsInSegpath a, const OverloadsInSegpath&) noexcept {
    return a;
  }
  friend OverloadsInSegpath operator*(OverloadsInSegpath a, const OverloadsInSegpath&) noexcept {
    return a;
  }
  friend OverloadsInSegpath operator*(OverloadsInSegpath a, float) noexcept { return a; }
  friend OverloadsInSegpath operator/(OverloadsInSegpath a, float) noexcept { return a; }
  friend bool operator==(const OverloadsInSegpath&, const OverloadsInSegpath&) noexcept = default;
};

}  // namespace user_types

namespace segpath {
template <Op M>
requires(M != Op::scalar_trait) struct spectrum_scalar<PartialSpectrum<M>> {
  using type = float;
};
template <>
struct spectrum_scalar<user_types::OverloadsInSegpath> {
  using type = float;
};
// Declared after the concept: neither unqualified lookup at its definition nor
// argument-dependent lookup for OverloadsInSegpath finds these.
inline float max_component(const user_types::OverloadsInSegpath&) noexcept { return 0; }
inline float average(const user_types::OverloadsInSegpath&) noexcept { return 0; }
inline bool is_finite(const user_types::OverloadsInSegpath&) noexcept { return true; }
inline bool is_black(const user_types::OverloadsInSegpath&) noexcept { return true; }
}  // namespace segpath

namespace {

static_assert(Spectrum<float> && Spectrum<double>);
static_assert(Spectrum<Rgb<float>> && Spectrum<Rgb<double>>);
static_assert(!Spectrum<int>);
static_assert(!Spectrum<Vec3<float>>);
static_assert(Spectrum<PartialSpectrum<Op::none>>);
static_assert(!Spectrum<PartialSpectrum<Op::scalar_trait>>);
static_assert(!Spectrum<PartialSpectrum<Op::equality>>);
static_assert(!Spectrum<PartialSpectrum<Op::construct>>);
static_assert(!Spectrum<PartialSpectrum<Op::plus>>);
static_assert(!Spectrum<PartialSpectrum<Op::plus_assign>>);
static_assert(!Spectrum<PartialSpectrum<Op::times>>);
static_assert(!Spectrum<PartialSpectrum<Op::times_scalar>>);
static_assert(!Spectrum<PartialSpectrum<Op::divide_scalar>>);
static_assert(!Spectrum<PartialSpectrum<Op::max_component>>);
static_assert(!Spectrum<PartialSpectrum<Op::average>>);
static_assert(!Spectrum<PartialSpectrum<Op::is_finite>>);
static_assert(!Spectrum<PartialSpectrum<Op::is_black>>);
static_assert(!Spectrum<PartialSpectrum<Op::max_component_type>>);
static_assert(!Spectrum<user_types::OverloadsInSegpath>);

// ---------------------------------------------------------------------------------------
// Manifold (concepts/manifold.hpp), points 1-5.

namespace manifold {
template <class X>
struct ScalarIs {
  using Scalar = X;
};
struct Area {
  float area() const noexcept;
};
struct AreaUnrelated {
  Unrelated area() const noexcept;
};
struct SampleArea {
  std::optional<AreaSample<float>> sample_area(const AreaSampleQuery<float>&) const noexcept;
};
struct SampleAreaBare {
  AreaSample<float> sample_area(const AreaSampleQuery<float>&) const noexcept;
};
struct Intersect {
  std::optional<Hit<float>> intersect(const IntersectQuery<float>&) const noexcept;
};
struct IntersectBareHit {
  Hit<float> intersect(const IntersectQuery<float>&) const noexcept;
};
struct IntersectNonConst {
  std::optional<Hit<float>> intersect(const IntersectQuery<float>&) noexcept;
};
struct Visible {
  bool visible(const VisibilityQuery<float>&) const noexcept;
};
struct VisibleUnrelated {
  Unrelated visible(const VisibilityQuery<float>&) const noexcept;
};

template <class M>
constexpr int failures = !detail::HasScalar<M> + !detail::HasArea<M> + !detail::HasSampleArea<M> +
                         !detail::HasIntersect<M> + !detail::HasVisible<M>;

using Ok = Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible>;
static_assert(Manifold<Ok> && failures<Ok> == 0);

using NoScalar = Model<Area, SampleArea, Intersect, Visible>;
static_assert(!Manifold<NoScalar> && !detail::HasScalar<NoScalar>);
using IntScalar = Model<ScalarIs<int>, Area, SampleArea, Intersect, Visible>;
static_assert(!Manifold<IntScalar> && !detail::HasScalar<IntScalar>);

using NoArea = Model<ScalarIs<float>, SampleArea, Intersect, Visible>;
static_assert(!Manifold<NoArea> && !detail::HasArea<NoArea> && failures<NoArea> == 1);
using AreaMistyped = Model<ScalarIs<float>, AreaUnrelated, SampleArea, Intersect, Visible>;
static_assert(!Manifold<AreaMistyped> && !detail::HasArea<AreaMistyped> &&
              failures<AreaMistyped> == 1);

using NoSampleArea = Model<ScalarIs<float>, Area, Intersect, Visible>;
static_assert(!Manifold<NoSampleArea> && !detail::HasSampleArea<NoSampleArea> &&
              failures<NoSampleArea> == 1);
using SampleAreaNotOptional = Model<ScalarIs<float>, Area, SampleAreaBare, Intersect, Visible>;
static_assert(!Manifold<SampleAreaNotOptional> && !detail::HasSampleArea<SampleAreaNotOptional> &&
              failures<SampleAreaNotOptional> == 1);

using NoIntersect = Model<ScalarIs<float>, Area, SampleArea, Visible>;
static_assert(!Manifold<NoIntersect>);
static_assert(!detail::HasIntersect<NoIntersect>);
static_assert(detail::HasScalar<NoIntersect> && detail::HasArea<NoIntersect> &&
              detail::HasSampleArea<NoIntersect> && detail::HasVisible<NoIntersect>);
using IntersectReturnsHit = Model<ScalarIs<float>, Area, SampleArea, IntersectBareHit, Visible>;
static_assert(!Manifold<IntersectReturnsHit> && !detail::HasIntersect<IntersectReturnsHit> &&
              failures<IntersectReturnsHit> == 1);
using IntersectMutable = Model<ScalarIs<float>, Area, SampleArea, IntersectNonConst, Visible>;
static_assert(!Manifold<IntersectMutable> && !detail::HasIntersect<IntersectMutable> &&
              failures<IntersectMutable> == 1);
using ScalarMismatch = Model<ScalarIs<double>, Area, SampleArea, Intersect, Visible>;
static_assert(!Manifold<ScalarMismatch> && !detail::HasSampleArea<ScalarMismatch> &&
              !detail::HasIntersect<ScalarMismatch> && !detail::HasVisible<ScalarMismatch>);

using NoVisible = Model<ScalarIs<float>, Area, SampleArea, Intersect>;
static_assert(!Manifold<NoVisible> && !detail::HasVisible<NoVisible> && failures<NoVisible> == 1);
using VisibleMistyped = Model<ScalarIs<float>, Area, SampleArea, Intersect, VisibleUnrelated>;
static_assert(!Manifold<VisibleMistyped> && !detail::HasVisible<VisibleMistyped> &&
              failures<VisibleMistyped> == 1);
}  // namespace manifold

// ---------------------------------------------------------------------------------------
// Bsdf (concepts/bsdf.hpp), points 1-3, for S = Rgb<float>.

namespace bsdf {
using S = Rgb<float>;
struct Eval {
  S eval(const BsdfQuery<float>&) const noexcept;
};
struct EvalScalar {  // f_r as one number: not convertible to an Rgb
  float eval(const BsdfQuery<float>&) const noexcept;
};
struct Sample {
  std::optional<BsdfSample<S>> sample(const BsdfSampleQuery<float>&) const noexcept;
};
struct SampleBare {
  BsdfSample<S> sample(const BsdfSampleQuery<float>&) const noexcept;
};
struct SampleOtherSpectrum {
  std::optional<BsdfSample<float>> sample(const BsdfSampleQuery<float>&) const noexcept;
};
struct Pdf {
  float pdf(const BsdfQuery<float>&) const noexcept;
};
struct PdfOptional {
  std::optional<float> pdf(const BsdfQuery<float>&) const noexcept;
};

template <class B>
constexpr int failures =
    !detail::HasBsdfEval<B, S> + !detail::HasBsdfSample<B, S> + !detail::HasBsdfPdf<B, S>;

using Ok = Model<Eval, Sample, Pdf>;
static_assert(Bsdf<Ok, S> && failures<Ok> == 0);
static_assert(!Bsdf<Ok, Rgb<double>>);
static_assert(!Bsdf<Ok, int>);

using NoEval = Model<Sample, Pdf>;
static_assert(!Bsdf<NoEval, S> && !detail::HasBsdfEval<NoEval, S> && failures<NoEval> == 1);
using EvalMistyped = Model<EvalScalar, Sample, Pdf>;
static_assert(!Bsdf<EvalMistyped, S> && !detail::HasBsdfEval<EvalMistyped, S> &&
              failures<EvalMistyped> == 1);

using NoSample = Model<Eval, Pdf>;
static_assert(!Bsdf<NoSample, S> && !detail::HasBsdfSample<NoSample, S> && failures<NoSample> == 1);
using SampleNotOptional = Model<Eval, SampleBare, Pdf>;
static_assert(!Bsdf<SampleNotOptional, S> && !detail::HasBsdfSample<SampleNotOptional, S> &&
              failures<SampleNotOptional> == 1);
using SampleWrongSpectrum = Model<Eval, SampleOtherSpectrum, Pdf>;
static_assert(!Bsdf<SampleWrongSpectrum, S> && !detail::HasBsdfSample<SampleWrongSpectrum, S> &&
              failures<SampleWrongSpectrum> == 1);

using NoPdf = Model<Eval, Sample>;
static_assert(!Bsdf<NoPdf, S> && !detail::HasBsdfPdf<NoPdf, S> && failures<NoPdf> == 1);
using PdfMistyped = Model<Eval, Sample, PdfOptional>;
static_assert(!Bsdf<PdfMistyped, S> && !detail::HasBsdfPdf<PdfMistyped, S> &&
              failures<PdfMistyped> == 1);
}  // namespace bsdf

// ---------------------------------------------------------------------------------------
// Emitter, point 1, and SampledEmitter, points 1-4 (concepts/emitter.hpp), S = Rgb<float>.

namespace emitter {
using S = Rgb<float>;
struct Radiance {
  S radiance(const EmissionQuery<float>&) const noexcept;
};
struct RadianceScalar {
  float radiance(const EmissionQuery<float>&) const noexcept;
};
struct SampleEmission {
  std::optional<EmissionSample<S>> sample_emission(
      const EmissionSampleQuery<float>&) const noexcept;
};
struct SampleEmissionBare {
  EmissionSample<S> sample_emission(const EmissionSampleQuery<float>&) const noexcept;
};
struct PdfEmission {
  EmissionPdf<float> pdf_emission(const EmissionPdfQuery<float>&) const noexcept;
};
struct PdfEmissionScalar {
  float pdf_emission(const EmissionPdfQuery<float>&) const noexcept;
};
struct SampleTowards {
  std::optional<EmitterTowardsSample<S>> sample_towards(
      const EmitterTowardsQuery<float>&) const noexcept;
};
struct SampleTowardsBare {
  EmitterTowardsSample<S> sample_towards(const EmitterTowardsQuery<float>&) const noexcept;
};
struct PdfTowards {
  float pdf_towards(const EmitterPdfTowardsQuery<float>&) const noexcept;
};
struct PdfTowardsPair {
  EmissionPdf<float> pdf_towards(const EmitterPdfTowardsQuery<float>&) const noexcept;
};

template <class E>
constexpr int failures =
    !detail::HasRadiance<E, S> + !detail::HasSampleEmission<E, S> + !detail::HasPdfEmission<E, S> +
    !detail::HasSampleTowards<E, S> + !detail::HasPdfTowards<E, S>;

using Ok = Model<Radiance, SampleEmission, PdfEmission, SampleTowards, PdfTowards>;
static_assert(SampledEmitter<Ok, S> && failures<Ok> == 0);
static_assert(Emitter<Model<Radiance>, S> && !SampledEmitter<Model<Radiance>, S>);
static_assert(!Emitter<Ok, Rgb<double>> && !Emitter<Ok, int>);

using NoRadiance = Model<SampleEmission, PdfEmission, SampleTowards, PdfTowards>;
static_assert(!Emitter<NoRadiance, S> && !SampledEmitter<NoRadiance, S>);
static_assert(!detail::HasRadiance<NoRadiance, S> && failures<NoRadiance> == 1);
using RadianceMistyped =
    Model<RadianceScalar, SampleEmission, PdfEmission, SampleTowards, PdfTowards>;
static_assert(!Emitter<RadianceMistyped, S> && !detail::HasRadiance<RadianceMistyped, S> &&
              failures<RadianceMistyped> == 1);

using NoSampleEmission = Model<Radiance, PdfEmission, SampleTowards, PdfTowards>;
static_assert(Emitter<NoSampleEmission, S> && !SampledEmitter<NoSampleEmission, S>);
static_assert(!detail::HasSampleEmission<NoSampleEmission, S> && failures<NoSampleEmission> == 1);
using SampleEmissionNotOptional =
    Model<Radiance, SampleEmissionBare, PdfEmission, SampleTowards, PdfTowards>;
static_assert(!SampledEmitter<SampleEmissionNotOptional, S> &&
              !detail::HasSampleEmission<SampleEmissionNotOptional, S> &&
              failures<SampleEmissionNotOptional> == 1);

using NoPdfEmission = Model<Radiance, SampleEmission, SampleTowards, PdfTowards>;
static_assert(!SampledEmitter<NoPdfEmission, S> && !detail::HasPdfEmission<NoPdfEmission, S> &&
              failures<NoPdfEmission> == 1);
using PdfEmissionMistyped =
    Model<Radiance, SampleEmission, PdfEmissionScalar, SampleTowards, PdfTowards>;
static_assert(!SampledEmitter<PdfEmissionMistyped, S> &&
              !detail::HasPdfEmission<PdfEmissionMistyped, S> &&
              failures<PdfEmissionMistyped> == 1);

using NoSampleTowards = Model<Radiance, SampleEmission, PdfEmission, PdfTowards>;
static_assert(!SampledEmitter<NoSampleTowards, S> &&
              !detail::HasSampleTowards<NoSampleTowards, S> && failures<NoSampleTowards> == 1);
using SampleTowardsNotOptional =
    Model<Radiance, SampleEmission, PdfEmission, SampleTowardsBare, PdfTowards>;
static_assert(!SampledEmitter<SampleTowardsNotOptional, S> &&
              !detail::HasSampleTowards<SampleTowardsNotOptional, S> &&
              failures<SampleTowardsNotOptional> == 1);

using NoPdfTowards = Model<Radiance, SampleEmission, PdfEmission, SampleTowards>;
static_assert(!SampledEmitter<NoPdfTowards, S> && !detail::HasPdfTowards<NoPdfTowards, S> &&
              failures<NoPdfTowards> == 1);
using PdfTowardsMistyped =
    Model<Radiance, SampleEmission, PdfEmission, SampleTowards, PdfTowardsPair>;
static_assert(!SampledEmitter<PdfTowardsMistyped, S> &&
              !detail::HasPdfTowards<PdfTowardsMistyped, S> && failures<PdfTowardsMistyped> == 1);
}  // namespace emitter

// ---------------------------------------------------------------------------------------
// Sensor (concepts/sensor.hpp), points 1-4, for T = float.

namespace sensor {
struct PixelCount {
  std::uint32_t pixel_count() const noexcept;
};
struct PixelCountUnrelated {
  Unrelated pixel_count() const noexcept;
};
struct SampleRay {
  std::optional<SensorSample<float>> sample_ray(const SensorSampleQuery<float>&) const noexcept;
};
struct SampleRayBare {
  SensorSample<float> sample_ray(const SensorSampleQuery<float>&) const noexcept;
};
struct Importance {
  std::optional<SensorResponse<float>> importance(const SensorQuery<float>&) const noexcept;
};
struct ImportanceBare {
  SensorResponse<float> importance(const SensorQuery<float>&) const noexcept;
};
struct Pdf {
  SensorPdf<float> pdf(const SensorQuery<float>&) const noexcept;
};
struct PdfScalar {
  float pdf(const SensorQuery<float>&) const noexcept;
};

template <class C>
constexpr int failures = !detail::HasPixelCount<C> + !detail::HasSampleRay<C, float> +
                         !detail::HasImportance<C, float> + !detail::HasSensorPdf<C, float>;

using Ok = Model<PixelCount, SampleRay, Importance, Pdf>;
static_assert(Sensor<Ok, float> && failures<Ok> == 0);
static_assert(!Sensor<Ok, double> && !Sensor<Ok, int>);

using NoPixelCount = Model<SampleRay, Importance, Pdf>;
static_assert(!Sensor<NoPixelCount, float> && !detail::HasPixelCount<NoPixelCount> &&
              failures<NoPixelCount> == 1);
using PixelCountMistyped = Model<PixelCountUnrelated, SampleRay, Importance, Pdf>;
static_assert(!Sensor<PixelCountMistyped, float> && !detail::HasPixelCount<PixelCountMistyped> &&
              failures<PixelCountMistyped> == 1);

using NoSampleRay = Model<PixelCount, Importance, Pdf>;
static_assert(!Sensor<NoSampleRay, float> && !detail::HasSampleRay<NoSampleRay, float> &&
              failures<NoSampleRay> == 1);
using SampleRayNotOptional = Model<PixelCount, SampleRayBare, Importance, Pdf>;
static_assert(!Sensor<SampleRayNotOptional, float> &&
              !detail::HasSampleRay<SampleRayNotOptional, float> &&
              failures<SampleRayNotOptional> == 1);

using NoImportance = Model<PixelCount, SampleRay, Pdf>;
static_assert(!Sensor<NoImportance, float> && !detail::HasImportance<NoImportance, float> &&
              failures<NoImportance> == 1);
using ImportanceNotOptional = Model<PixelCount, SampleRay, ImportanceBare, Pdf>;
static_assert(!Sensor<ImportanceNotOptional, float> &&
              !detail::HasImportance<ImportanceNotOptional, float> &&
              failures<ImportanceNotOptional> == 1);

using NoPdf = Model<PixelCount, SampleRay, Importance>;
static_assert(!Sensor<NoPdf, float> && !detail::HasSensorPdf<NoPdf, float> && failures<NoPdf> == 1);
using PdfMistyped = Model<PixelCount, SampleRay, Importance, PdfScalar>;
static_assert(!Sensor<PdfMistyped, float> && !detail::HasSensorPdf<PdfMistyped, float> &&
              failures<PdfMistyped> == 1);
}  // namespace sensor

// ---------------------------------------------------------------------------------------
// Kernel (concepts/kernel.hpp), points 1-6.

namespace kernel {
template <class X>
struct ScalarIs {
  using Scalar = X;
};
struct IsDirac {
  static constexpr bool is_dirac = false;
};
struct IsDiracRuntime {  // a static member, but not a constant expression
  static inline bool is_dirac = false;
};
struct IsDiracNonStatic {
  bool is_dirac = false;
};
struct IsDiracFunction {
  static constexpr bool is_dirac() noexcept { return false; }
};
struct Eval {
  float eval(const KernelQuery<float>&) const noexcept;
};
struct EvalUnrelated {
  Unrelated eval(const KernelQuery<float>&) const noexcept;
};
struct Sample {
  std::optional<KernelSample<float>> sample(const KernelSampleQuery<float>&) const noexcept;
};
struct SampleBare {
  KernelSample<float> sample(const KernelSampleQuery<float>&) const noexcept;
};
struct Pdf {
  float pdf(const KernelQuery<float>&) const noexcept;
};
struct PdfOptional {
  std::optional<float> pdf(const KernelQuery<float>&) const noexcept;
};
struct SupportRadius {
  float support_radius(const KernelSupportQuery<float>&) const noexcept;
};
struct SupportRadiusVoid {
  void support_radius(const KernelSupportQuery<float>&) const noexcept;
};

template <class K>
constexpr int failures =
    !detail::HasKernelScalar<K> + !detail::HasIsDirac<K> + !detail::HasKernelEval<K> +
    !detail::HasKernelSample<K> + !detail::HasKernelPdf<K> + !detail::HasSupportRadius<K>;

using Ok = Model<ScalarIs<float>, IsDirac, Eval, Sample, Pdf, SupportRadius>;
static_assert(Kernel<Ok> && failures<Ok> == 0);
static_assert(Kernel<DiracKernel<float>> && Kernel<DiracKernel<double>>);

using NoScalar = Model<IsDirac, Eval, Sample, Pdf, SupportRadius>;
static_assert(!Kernel<NoScalar> && !detail::HasKernelScalar<NoScalar> &&
              detail::HasIsDirac<NoScalar>);
using IntScalar = Model<ScalarIs<int>, IsDirac, Eval, Sample, Pdf, SupportRadius>;
static_assert(!Kernel<IntScalar> && !detail::HasKernelScalar<IntScalar> &&
              detail::HasIsDirac<IntScalar>);

using NoIsDirac = Model<ScalarIs<float>, Eval, Sample, Pdf, SupportRadius>;
static_assert(!Kernel<NoIsDirac> && !detail::HasIsDirac<NoIsDirac> && failures<NoIsDirac> == 1);
using IsDiracNotConstant = Model<ScalarIs<float>, IsDiracRuntime, Eval, Sample, Pdf, SupportRadius>;
static_assert(!Kernel<IsDiracNotConstant> && !detail::HasIsDirac<IsDiracNotConstant> &&
              failures<IsDiracNotConstant> == 1);
using IsDiracMember = Model<ScalarIs<float>, IsDiracNonStatic, Eval, Sample, Pdf, SupportRadius>;
static_assert(!Kernel<IsDiracMember> && !detail::HasIsDirac<IsDiracMember> &&
              failures<IsDiracMember> == 1);
using IsDiracIsFunction = Model<ScalarIs<float>, IsDiracFunction, Eval, Sample, Pdf, SupportRadius>;
static_assert(!Kernel<IsDiracIsFunction> && !detail::HasIsDirac<IsDiracIsFunction> &&
              failures<IsDiracIsFunction> == 1);

using NoEval = Model<ScalarIs<float>, IsDirac, Sample, Pdf, SupportRadius>;
static_assert(!Kernel<NoEval> && !detail::HasKernelEval<NoEval> && failures<NoEval> == 1);
using EvalMistyped = Model<ScalarIs<float>, IsDirac, EvalUnrelated, Sample, Pdf, SupportRadius>;
static_assert(!Kernel<EvalMistyped> && !detail::HasKernelEval<EvalMistyped> &&
              failures<EvalMistyped> == 1);

using NoSample = Model<ScalarIs<float>, IsDirac, Eval, Pdf, SupportRadius>;
static_assert(!Kernel<NoSample> && !detail::HasKernelSample<NoSample> && failures<NoSample> == 1);
using SampleNotOptional = Model<ScalarIs<float>, IsDirac, Eval, SampleBare, Pdf, SupportRadius>;
static_assert(!Kernel<SampleNotOptional> && !detail::HasKernelSample<SampleNotOptional> &&
              failures<SampleNotOptional> == 1);

using NoPdf = Model<ScalarIs<float>, IsDirac, Eval, Sample, SupportRadius>;
static_assert(!Kernel<NoPdf> && !detail::HasKernelPdf<NoPdf> && failures<NoPdf> == 1);
using PdfMistyped = Model<ScalarIs<float>, IsDirac, Eval, Sample, PdfOptional, SupportRadius>;
static_assert(!Kernel<PdfMistyped> && !detail::HasKernelPdf<PdfMistyped> &&
              failures<PdfMistyped> == 1);

using NoSupportRadius = Model<ScalarIs<float>, IsDirac, Eval, Sample, Pdf>;
static_assert(!Kernel<NoSupportRadius> && !detail::HasSupportRadius<NoSupportRadius> &&
              failures<NoSupportRadius> == 1);
using SupportRadiusMistyped = Model<ScalarIs<float>, IsDirac, Eval, Sample, Pdf, SupportRadiusVoid>;
static_assert(!Kernel<SupportRadiusMistyped> && !detail::HasSupportRadius<SupportRadiusMistyped> &&
              failures<SupportRadiusMistyped> == 1);
}  // namespace kernel

// ---------------------------------------------------------------------------------------
// Scene and LightSampledScene (concepts/scene.hpp), points 1-5, for T = S = float.

namespace scene {
using manifold::Area;
using manifold::Intersect;
using manifold::SampleArea;
using manifold::ScalarIs;
using manifold::Visible;
template <class X>
struct SpectrumIs {
  using Spectrum = X;
};
template <class B>
struct BsdfIs {
  B bsdf() const noexcept;
};
template <class E>
struct EmitterIs {
  E emitter() const noexcept;
};
template <class C>
struct SensorIs {
  C sensor() const noexcept;
};
template <class C>
struct SensorByReference {
  const C& sensor() const noexcept;
};

using GoodBsdf = BsdfIs<arch::BsdfArchetype<float>>;
using GoodEmitter = EmitterIs<arch::SampledEmitterArchetype<float>>;
using GoodSensor = SensorIs<arch::SensorArchetype<float>>;

template <class Scn>
constexpr int failures = !Manifold<Scn> + !detail::HasSpectrum<Scn> + !detail::HasSceneBsdf<Scn> +
                         !detail::HasSceneEmitter<Scn> + !detail::HasSceneSensor<Scn>;

using Ok = Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible, SpectrumIs<float>, GoodBsdf,
                 GoodEmitter, GoodSensor>;
static_assert(Scene<Ok> && LightSampledScene<Ok> && failures<Ok> == 0);
using SensorReturnedByReference =
    Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible, SpectrumIs<float>, GoodBsdf,
          GoodEmitter, SensorByReference<arch::SensorArchetype<float>>>;
static_assert(Scene<SensorReturnedByReference>);

using NotAManifold = Model<ScalarIs<float>, Area, SampleArea, Visible, SpectrumIs<float>, GoodBsdf,
                           GoodEmitter, GoodSensor>;
static_assert(!Scene<NotAManifold> && !Manifold<NotAManifold> &&
              !detail::HasIntersect<NotAManifold> && failures<NotAManifold> == 1);

using NoSpectrum =
    Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible, GoodBsdf, GoodEmitter, GoodSensor>;
static_assert(!Scene<NoSpectrum> && !detail::HasSpectrum<NoSpectrum> && Manifold<NoSpectrum> &&
              detail::HasSceneSensor<NoSpectrum>);
using IntSpectrum = Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible, SpectrumIs<int>,
                          GoodBsdf, GoodEmitter, GoodSensor>;
static_assert(!Scene<IntSpectrum> && !detail::HasSpectrum<IntSpectrum> && Manifold<IntSpectrum>);
using SpectrumOfOtherScalar = Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible,
                                    SpectrumIs<double>, BsdfIs<arch::BsdfArchetype<double>>,
                                    EmitterIs<arch::SampledEmitterArchetype<double>>, GoodSensor>;
static_assert(!Scene<SpectrumOfOtherScalar> && !detail::HasSpectrum<SpectrumOfOtherScalar> &&
              failures<SpectrumOfOtherScalar> == 1);
using RgbOfOtherScalar = Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible,
                               SpectrumIs<Rgb<double>>, BsdfIs<arch::BsdfArchetype<Rgb<double>>>,
                               EmitterIs<arch::SampledEmitterArchetype<Rgb<double>>>, GoodSensor>;
static_assert(!Scene<RgbOfOtherScalar> && !detail::HasSpectrum<RgbOfOtherScalar> &&
              failures<RgbOfOtherScalar> == 1);

using NoBsdf = Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible, SpectrumIs<float>,
                     GoodEmitter, GoodSensor>;
static_assert(!Scene<NoBsdf> && !detail::HasSceneBsdf<NoBsdf> && failures<NoBsdf> == 1);
using BsdfOfOtherSpectrum =
    Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible, SpectrumIs<float>,
          BsdfIs<arch::BsdfArchetype<Rgb<float>>>, GoodEmitter, GoodSensor>;
static_assert(!Scene<BsdfOfOtherSpectrum> && !detail::HasSceneBsdf<BsdfOfOtherSpectrum> &&
              failures<BsdfOfOtherSpectrum> == 1);

using NoEmitter = Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible, SpectrumIs<float>,
                        GoodBsdf, GoodSensor>;
static_assert(!Scene<NoEmitter> && !detail::HasSceneEmitter<NoEmitter> && failures<NoEmitter> == 1);
using EmitterOfOtherSpectrum =
    Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible, SpectrumIs<float>, GoodBsdf,
          EmitterIs<arch::SampledEmitterArchetype<Rgb<float>>>, GoodSensor>;
static_assert(!Scene<EmitterOfOtherSpectrum> && !detail::HasSceneEmitter<EmitterOfOtherSpectrum> &&
              failures<EmitterOfOtherSpectrum> == 1);

using NoSensor = Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible, SpectrumIs<float>,
                       GoodBsdf, GoodEmitter>;
static_assert(!Scene<NoSensor> && !detail::HasSceneSensor<NoSensor> && failures<NoSensor> == 1);
using SensorOfOtherScalar =
    Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible, SpectrumIs<float>, GoodBsdf,
          GoodEmitter, SensorIs<arch::SensorArchetype<double>>>;
static_assert(!Scene<SensorOfOtherScalar> && !detail::HasSceneSensor<SensorOfOtherScalar> &&
              failures<SensorOfOtherScalar> == 1);

using UnsampledEmitter =
    Model<ScalarIs<float>, Area, SampleArea, Intersect, Visible, SpectrumIs<float>, GoodBsdf,
          EmitterIs<arch::EmitterArchetype<float>>, GoodSensor>;
static_assert(Scene<UnsampledEmitter> && !LightSampledScene<UnsampledEmitter> &&
              !detail::HasSampledEmitter<UnsampledEmitter>);
static_assert(!LightSampledScene<NoSensor> && detail::HasSampledEmitter<NoSensor>);
}  // namespace scene

// ---------------------------------------------------------------------------------------
// SegmentSampler (concepts/sampler.hpp), points 1-5, on the archetype scene.

namespace sampler {
using Scn = arch::SceneArchetype<float>;
struct Tech {};
struct TechniqueIs {
  using Technique = Tech;
};
struct IsDirac {
  static constexpr bool is_dirac = false;
};
struct Sample {
  template <class Sc>
  std::optional<SegmentSample<typename Sc::Spectrum>> sample(const Sc&, const Tech&,
                                                             Pcg32&) const noexcept;
};
struct SampleBare {
  template <class Sc>
  SegmentSample<typename Sc::Spectrum> sample(const Sc&, const Tech&, Pcg32&) const noexcept;
};
struct SampleOtherSpectrum {
  template <class Sc>
  std::optional<SegmentSample<Rgb<typename Sc::Scalar>>> sample(const Sc&, const Tech&,
                                                                Pcg32&) const noexcept;
};
struct Pdf {
  template <class Sc>
  typename Sc::Scalar pdf(const Sc&, const Tech&,
                          const Segment<typename Sc::Scalar>&) const noexcept;
};
struct PdfVoid {
  template <class Sc>
  void pdf(const Sc&, const Tech&, const Segment<typename Sc::Scalar>&) const noexcept;
};
struct UnoccludedPdf {
  template <class Sc>
  typename Sc::Scalar unoccluded_pdf(const Sc&, const Tech&,
                                     const Segment<typename Sc::Scalar>&) const noexcept;
};
struct UnoccludedPdfVoid {
  template <class Sc>
  void unoccluded_pdf(const Sc&, const Tech&, const Segment<typename Sc::Scalar>&) const noexcept;
};
/// unoccluded_pdf without the scene argument (a sampler whose density never needs it must
/// still take the scene, like pdf).
struct UnoccludedPdfNoScene {
  template <class T>
  T unoccluded_pdf(const Tech&, const Segment<T>&) const noexcept;
};

template <class Smp>
constexpr int failures = !detail::HasTechnique<Smp> + !detail::HasSamplerIsDirac<Smp> +
                         !detail::HasSegmentSample<Smp, Scn> + !detail::HasSegmentPdf<Smp, Scn> +
                         !detail::HasUnoccludedPdf<Smp, Scn>;

using Ok = Model<TechniqueIs, IsDirac, Sample, Pdf, UnoccludedPdf>;
static_assert(SegmentSampler<Ok, Scn> && failures<Ok> == 0);
static_assert(SegmentSampler<Ok, arch::SceneArchetype<double, Rgb<double>>>);

// Point 1 (without a Technique the other requirements cannot be checked: they name it).
using NoTechnique = Model<IsDirac, Sample, Pdf, UnoccludedPdf>;
static_assert(!SegmentSampler<NoTechnique, Scn> && !detail::HasTechnique<NoTechnique> &&
              detail::HasSamplerIsDirac<NoTechnique>);

// Point 2.
using NoIsDirac = Model<TechniqueIs, Sample, Pdf, UnoccludedPdf>;
static_assert(!SegmentSampler<NoIsDirac, Scn> && !detail::HasSamplerIsDirac<NoIsDirac> &&
              failures<NoIsDirac> == 1);

// Point 3.
using NoSample = Model<TechniqueIs, IsDirac, Pdf, UnoccludedPdf>;
static_assert(!SegmentSampler<NoSample, Scn> && !detail::HasSegmentSample<NoSample, Scn> &&
              failures<NoSample> == 1);
using SampleNotOptional = Model<TechniqueIs, IsDirac, SampleBare, Pdf, UnoccludedPdf>;
static_assert(!SegmentSampler<SampleNotOptional, Scn> &&
              !detail::HasSegmentSample<SampleNotOptional, Scn> &&
              failures<SampleNotOptional> == 1);
using SampleWrongSpectrum = Model<TechniqueIs, IsDirac, SampleOtherSpectrum, Pdf, UnoccludedPdf>;
static_assert(!SegmentSampler<SampleWrongSpectrum, Scn> &&
              !detail::HasSegmentSample<SampleWrongSpectrum, Scn> &&
              failures<SampleWrongSpectrum> == 1);

// Point 4.
using NoPdf = Model<TechniqueIs, IsDirac, Sample, UnoccludedPdf>;
static_assert(!SegmentSampler<NoPdf, Scn> && !detail::HasSegmentPdf<NoPdf, Scn> &&
              failures<NoPdf> == 1);
using PdfMistyped = Model<TechniqueIs, IsDirac, Sample, PdfVoid, UnoccludedPdf>;
static_assert(!SegmentSampler<PdfMistyped, Scn> && !detail::HasSegmentPdf<PdfMistyped, Scn> &&
              failures<PdfMistyped> == 1);

// Point 5: pdf alone is not enough (and unoccluded_pdf alone is not either: NoPdf).
using NoUnoccludedPdf = Model<TechniqueIs, IsDirac, Sample, Pdf>;
static_assert(!SegmentSampler<NoUnoccludedPdf, Scn> && !detail::HasUnoccludedPdf<NoUnoccludedPdf, Scn> &&
              failures<NoUnoccludedPdf> == 1);
using UnoccludedPdfMistyped = Model<TechniqueIs, IsDirac, Sample, Pdf, UnoccludedPdfVoid>;
static_assert(!SegmentSampler<UnoccludedPdfMistyped, Scn> &&
              !detail::HasUnoccludedPdf<UnoccludedPdfMistyped, Scn> && failures<UnoccludedPdfMistyped> == 1);
using UnoccludedPdfWithoutScene = Model<TechniqueIs, IsDirac, Sample, Pdf, UnoccludedPdfNoScene>;
static_assert(!SegmentSampler<UnoccludedPdfWithoutScene, Scn> &&
              !detail::HasUnoccludedPdf<UnoccludedPdfWithoutScene, Scn> &&
              failures<UnoccludedPdfWithoutScene> == 1);

// UnconditionalSegmentSampler (algorithms/filtering/techniques.hpp), what a user's technique in
// segment filtering's set must be: 1. a SegmentSampler, 2. whose Technique is
// default-constructible (unconditional), 3. without a Dirac part.
struct TechNeedsArgument {
  explicit TechNeedsArgument(int) {}
};
template <class Tq, bool Dirac>
struct Candidate {
  using Technique = Tq;
  static constexpr bool is_dirac = Dirac;
  template <class Sc>
  std::optional<SegmentSample<typename Sc::Spectrum>> sample(const Sc&, const Tq&, Pcg32&) const noexcept;
  template <class Sc>
  typename Sc::Scalar pdf(const Sc&, const Tq&, const Segment<typename Sc::Scalar>&) const noexcept;
  template <class Sc>
  typename Sc::Scalar unoccluded_pdf(const Sc&, const Tq&, const Segment<typename Sc::Scalar>&) const noexcept;
};
static_assert(UnconditionalSegmentSampler<Candidate<Tech, false>, Scn> && UnconditionalSegmentSampler<Ok, Scn>);
static_assert(UnconditionalSegmentSampler<arch::SegmentSamplerArchetype, Scn>);
static_assert(!UnconditionalSegmentSampler<NoPdf, Scn> && !UnconditionalSegmentSampler<NoUnoccludedPdf, Scn>);  // 1.
static_assert(SegmentSampler<Candidate<TechNeedsArgument, false>, Scn> &&
              !UnconditionalSegmentSampler<Candidate<TechNeedsArgument, false>, Scn>);  // 2.
static_assert(SegmentSampler<Candidate<Tech, true>, Scn> && !UnconditionalSegmentSampler<Candidate<Tech, true>, Scn>);  // 3.
}  // namespace sampler

// ---------------------------------------------------------------------------------------
// ContributionSink and Estimator (concepts/estimator.hpp).

namespace sink {
struct Add {
  void add(std::uint32_t, const float&) noexcept;
};
struct AddOtherSpectrum {
  void add(std::uint32_t, const Rgb<float>&) noexcept;
};
struct Drop {
  void drop(DropReason) noexcept;
};
struct DropInt {
  void drop(int) noexcept;
};
static_assert(ContributionSink<Model<Add, Drop>, float>);
static_assert(!ContributionSink<Model<Drop>, float>);
static_assert(!ContributionSink<Model<AddOtherSpectrum, Drop>, float>);
static_assert(!ContributionSink<Model<Add>, float>);
static_assert(!ContributionSink<Model<Add, DropInt>, float>);
}  // namespace sink

namespace estimator {
using Scn = arch::SceneArchetype<float>;
struct NoEstimate {};
struct EstimateMutable {
  template <class Sc, class Sink>
  void estimate(const Sc&, const EstimateQuery&, Pcg32&, Sink&) noexcept;
};
struct EstimateOneSinkOnly {
  template <class Sc>
  void estimate(const Sc&, const EstimateQuery&, Pcg32&, std::vector<float>&) const noexcept;
};
struct EstimateNeedsMutableScene {
  void estimate(Scn&, const EstimateQuery&, Pcg32&, detail::SinkArchetype<float>&) const noexcept;
};
static_assert(Estimator<arch::EstimatorArchetype, Scn>);
static_assert(!Estimator<arch::EstimatorArchetype, arch::ManifoldArchetype<float>>);
static_assert(!Estimator<NoEstimate, Scn>);
static_assert(!Estimator<EstimateMutable, Scn>);
static_assert(!Estimator<EstimateOneSinkOnly, Scn>);
static_assert(!Estimator<EstimateNeedsMutableScene, Scn>);
}  // namespace estimator

// ---------------------------------------------------------------------------------------
// UniformSource (core/rng.hpp).

struct UniformSourceArchetype {
  template <Real T>
  T uniform() noexcept {
    return T(0);
  }
};
struct UniformAlwaysDouble {
  template <Real T>
  double uniform() noexcept;
};
static_assert(UniformSource<Pcg32, float> && UniformSource<Pcg32, double>);
static_assert(UniformSource<UniformSourceArchetype, float> &&
              UniformSource<UniformSourceArchetype, double>);
static_assert(!UniformSource<UniformAlwaysDouble, float> && !UniformSource<Pcg32, int>);

/// Records what an estimator hands to its sink.
template <class S>
struct RecordingSink {
  std::vector<std::uint32_t> pixels;
  std::vector<S> values;
  std::vector<DropReason> drops;
  void add(std::uint32_t pixel, const S& value) {
    pixels.push_back(pixel);
    values.push_back(value);
  }
  void drop(DropReason reason) { drops.push_back(reason); }
};

template <Real T>
Segment<T> segment_between(const Vec3<T>& x, const Vec3<T>& nx, const Vec3<T>& y,
                           const Vec3<T>& ny) {
  return Segment<T>{SurfacePoint<T>::on_surface(x, nx), SurfacePoint<T>::on_surface(y, ny)};
}

}  // namespace

TEMPLATE_TEST_CASE("archetype members are callable and return their trivial values", "[concepts]",
                   float, double) {
  using T = TestType;
  const arch::SceneArchetype<T, Rgb<T>> scene;
  const auto point = SurfacePoint<T>::on_surface(Vec3<T>(0, 0, 0), Vec3<T>(0, 0, 1));

  CHECK(scene.area() == T(1));
  CHECK_FALSE(scene.sample_area(AreaSampleQuery<T>{Vec2<T>(T(0.5), T(0.5))}).has_value());
  CHECK_FALSE(scene.intersect(IntersectQuery<T>{Ray<T>{}}).has_value());
  CHECK(scene.visible(VisibilityQuery<T>{point, point}));

  const BsdfQuery<T> bq{point, Vec3<T>(0, 0, 1), Vec3<T>(0, 0, 1)};
  CHECK(scene.bsdf().eval(bq) == Rgb<T>(T(1)));
  CHECK(scene.bsdf().pdf(bq) == T(0));
  CHECK_FALSE(
      scene.bsdf().sample(BsdfSampleQuery<T>{point, Vec3<T>(0, 0, 1), Vec2<T>(0, 0)}).has_value());

  CHECK(scene.emitter().radiance(EmissionQuery<T>{point, Vec3<T>(0, 0, 1)}) == Rgb<T>(T(1)));
  CHECK_FALSE(scene.emitter().sample_emission(EmissionSampleQuery<T>{}).has_value());
  CHECK(scene.emitter().pdf_emission(EmissionPdfQuery<T>{point, Vec3<T>(0, 0, 1)}).position ==
        T(0));
  CHECK_FALSE(
      scene.emitter().sample_towards(EmitterTowardsQuery<T>{point, Vec2<T>(0, 0)}).has_value());
  CHECK(scene.emitter().pdf_towards(EmitterPdfTowardsQuery<T>{point, point}) == T(0));

  CHECK(scene.sensor().pixel_count() == 1u);
  CHECK_FALSE(scene.sensor().sample_ray(SensorSampleQuery<T>{}).has_value());
  const auto response = scene.sensor().importance(SensorQuery<T>{point, Vec3<T>(0, 0, 1)});
  REQUIRE(response.has_value());
  CHECK(response->pixel == 0u);
  CHECK(response->importance == T(1));
  CHECK(scene.sensor().pdf(SensorQuery<T>{point, Vec3<T>(0, 0, 1)}).direction == T(0));

  const arch::KernelArchetype<T> kernel;
  const Segment<T> s{point, point};
  static_assert(!arch::KernelArchetype<T>::is_dirac);
  CHECK(kernel.eval(KernelQuery<T>{s, s}) == T(0));
  CHECK(kernel.pdf(KernelQuery<T>{s, s}) == T(0));
  CHECK_FALSE(kernel.sample(KernelSampleQuery<T>{s, Vec2<T>(0, 0)}).has_value());
  CHECK(kernel.support_radius(KernelSupportQuery<T>{point}) == T(0));

  Pcg32 rng(7, 11);
  const arch::SegmentSamplerArchetype sampler;
  CHECK_FALSE(sampler.sample(scene, {}, rng).has_value());
  CHECK(sampler.pdf(scene, {}, s) == T(0));
  CHECK(sampler.unoccluded_pdf(scene, {}, s) == T(0));

  RecordingSink<Rgb<T>> sink;
  arch::EstimatorArchetype{}.estimate(scene, EstimateQuery{3, 0}, rng, sink);
  REQUIRE(sink.pixels.size() == 1);
  CHECK(sink.pixels[0] == 3u);
  CHECK(is_black(sink.values[0]));
  CHECK(sink.drops.empty());
}

TEMPLATE_TEST_CASE("Pcg32 models UniformSource and draws in [0, 1)", "[concepts]", float, double) {
  using T = TestType;
  static_assert(UniformSource<Pcg32, T>);
  Pcg32 rng(1, 2);
  for (int i = 0; i < 1000; ++i) {
    const T u = rng.uniform<T>();
    REQUIRE(u >= T(0));
    REQUIRE(u < T(1));
  }
}

TEMPLATE_TEST_CASE("path_contribution accepts the archetype scene with a Dirac kernel",
                   "[concepts]", float, double) {
  using T = TestType;
  // s1 from the sensor end at the origin up to z = 2, s2 from there down to z = -1; facing
  // normals, so G(s1) = 1/4 and G(s2) = 1/9. W, f_r and L_e of the archetypes are 1.
  const Vec3<T> up(0, 0, 1);
  const Vec3<T> down(0, 0, -1);
  SegmentPath<T, 4> path;
  path.push_back(segment_between<T>(Vec3<T>(0, 0, 0), up, Vec3<T>(0, 0, 2), down));
  path.push_back(segment_between<T>(Vec3<T>(0, 0, 2), down, Vec3<T>(0, 0, -1), up));

  const arch::SceneArchetype<T> scene;
  const auto joined = path_contribution(scene, DiracKernel<T>{}, path);
  REQUIRE(joined.has_value());
  CHECK(joined->pixel == 0u);
  CHECK(joined->value == Approx(T(1) / T(36)));

  // The same path through the archetype kernel, whose eval is 0: the contribution vanishes.
  const auto through_archetype = path_contribution(scene, arch::KernelArchetype<T>{}, path);
  REQUIRE(through_archetype.has_value());
  CHECK(through_archetype->value == T(0));

  // A gap between the segments: the Dirac kernel does not join them.
  SegmentPath<T, 4> gapped;
  gapped.push_back(path[0]);
  gapped.push_back(segment_between<T>(Vec3<T>(0, 0, T(1.5)), down, Vec3<T>(0, 0, -1), up));
  const auto apart = path_contribution(scene, DiracKernel<T>{}, gapped);
  REQUIRE(apart.has_value());
  CHECK(apart->value == T(0));

  // Rgb and the user-defined archetype spectrum go through the same function.
  const auto rgb = path_contribution(arch::SceneArchetype<T, Rgb<T>>{}, DiracKernel<T>{}, path);
  REQUIRE(rgb.has_value());
  CHECK(rgb->value.g == Approx(T(1) / T(36)));
  const auto custom = path_contribution(arch::SceneArchetype<T, arch::SpectrumArchetype<T>>{},
                                        DiracKernel<T>{}, path);
  REQUIRE(custom.has_value());
  CHECK(custom->value == arch::SpectrumArchetype<T>(T(0)));

  CHECK_FALSE(path_contribution(scene, DiracKernel<T>{}, SegmentPath<T, 4>{}).has_value());
}
