// Embree's ray rate on exactly the rays PT casts: the rays of one PT iteration on Cornell box
// 1 at 512 x 512 are recorded, then replayed on 2 threads (a) through the adapter
// (EmbreeManifold::intersect / visible; on box 1, 22 primitives, that is its direct traversal,
// not Embree's, since session 22), (b) with rtcIntersect1 / rtcOccluded1 directly on
// the manifold's rtc_scene() (its triangle filter and exact sphere callbacks included), and
// (c) on a bare Embree scene of the same geometry (no filter; Embree's own spheres; the
// classic tnear epsilon instead of the adapter's exact self-intersection handling). Prints
// the PT's rays/s (PT logic included) as a fraction of each (issue target: >= 60% of bare).
//   build/bench/renderer/bench_renderer_embree_rays_bench
#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "pt_harness.hpp"

namespace {

using bench::T;
using D3 = segpath::Vec3<double>;

/// One recorded query: the caller's form (for the adapter replay) and the adapter's exact
/// ray (origin, unit direction, t_max, far endpoint of a visibility query).
struct RecordedRay {
  bool occlusion = false;
  segpath::IntersectQuery<T> query{};
  segpath::SurfacePoint<T> from{}, to{};
  D3 origin{}, direction{};
  double t_max = 0;
  bool has_far = false;
  D3 far{};
  bool valid = true;  ///< false for queries the adapter answers without Embree
};

D3 to_d(const segpath::Vec3<T>& v) { return D3(v.x, v.y, v.z); }

/// Records queries, deriving each ray exactly as EmbreeManifold does (visible: from the
/// lexicographically smaller endpoint; a `direction` endpoint: a ray to infinity).
struct RayRecorder {
  std::vector<RecordedRay> rays;
  void intersect(const segpath::IntersectQuery<T>& q) noexcept {
    RecordedRay r;
    r.query = q;
    r.origin = to_d(q.ray.origin);
    const double length = glm::length(to_d(q.ray.direction));
    r.valid = length > 0 && q.t_max > 0;
    r.direction = to_d(q.ray.direction) / length;
    r.t_max = double(q.t_max);
    rays.push_back(r);
  }
  void visible(const segpath::VisibilityQuery<T>& q) noexcept {
    RecordedRay r;
    r.occlusion = true;
    r.from = q.from;
    r.to = q.to;
    const segpath::SurfacePoint<T>* a = &q.from;
    const segpath::SurfacePoint<T>* b = &q.to;
    if (a->kind == segpath::PointKind::direction) std::swap(a, b);
    if (b->kind == segpath::PointKind::direction) {
      r.origin = to_d(a->position);
      r.direction = glm::normalize(to_d(b->position));
      r.t_max = std::numeric_limits<double>::infinity();
    } else {
      if (std::tie(b->position.x, b->position.y, b->position.z) < std::tie(a->position.x, a->position.y, a->position.z))
        std::swap(a, b);
      r.origin = to_d(a->position);
      r.far = to_d(b->position);
      r.has_far = true;
      r.t_max = glm::length(r.far - r.origin);
      r.valid = r.t_max > 0;
      r.direction = (r.far - r.origin) / r.t_max;
    }
    rays.push_back(r);
  }
};

/// The recorded rays of one PT iteration and the PT's own rate, shared by the benchmarks.
struct Recording {
  renderer::RenderScene scene = renderer::make_cornell(1, 512, 512);
  std::vector<RecordedRay> rays;
  Recording() {
    const segpath::PathTracer<bench::ObservedScene<RayRecorder>> pt(
        segpath::PathTracerOptions{renderer::cornell_max_length});
    std::vector<RayRecorder> recorder(1);
    recorder[0].rays.reserve(4'000'000);
    std::vector<bench::Color> image(scene.sensor().pixel_count(), bench::Color(0));
    bench::pt_iteration(scene, pt, 0, recorder, image);
    rays = std::move(recorder[0].rays);
  }
};

Recording& recording() {
  static Recording r;
  return r;
}

/// Runs body(ray) over all rays on `threads` threads, blocks of 4096 rays interleaved.
template <class Body>
void replay(const std::vector<RecordedRay>& rays, unsigned threads, Body body) {
  auto work = [&](unsigned t) {
    for (std::size_t start = std::size_t(t) * 4096; start < rays.size(); start += std::size_t(threads) * 4096)
      for (std::size_t i = start; i < std::min(rays.size(), start + 4096); ++i) body(rays[i]);
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (auto& thread : pool) thread.join();
}

void report(benchmark::State& state, std::uint64_t replays, std::size_t rays) {
  state.counters["rays/s"] = benchmark::Counter(double(replays) * double(rays), benchmark::Counter::kIsRate);
  state.counters["rays"] = double(rays);
}

// ---- (a) through the adapter ------------------------------------------------------------

void adapter_rays(benchmark::State& state) {
  const auto& rec = recording();
  const auto& m = rec.scene.manifold();
  std::uint64_t replays = 0;
  for (auto _ : state) {
    replay(rec.rays, unsigned(state.range(0)), [&](const RecordedRay& r) {
      if (r.occlusion) {
        benchmark::DoNotOptimize(m.visible({r.from, r.to}));
      } else {
        benchmark::DoNotOptimize(m.intersect(r.query));
      }
    });
    ++replays;
  }
  report(state, replays, rec.rays.size());
}

// ---- (b) Embree directly on the manifold's scene ----------------------------------------

/// The adapter's query context and Embree ray for a recorded ray (as EmbreeManifold's
/// private context() and set_ray() build them: a ray from back_off behind the origin).
struct ManifoldRay {
  segpath::detail::EmbreeQueryContext ctx;
  RTCRayHit rayhit;
};

void manifold_ray(const RecordedRay& r, const segpath::detail::EmbreeSceneData<T>& data, ManifoldRay& out) {
  auto& ctx = out.ctx;
  rtcInitIntersectContext(&ctx.base);
  ctx.data = &data;
  ctx.origin = r.origin;
  ctx.direction = r.direction;
  ctx.far_point = r.has_far ? r.far : r.origin;
  ctx.t_max = r.t_max;
  ctx.back_off = 0x1p-16 * std::max(segpath::detail::max_abs(r.origin), data.extent);
  ctx.skip_far_surface = r.has_far;
  RTCRay& ray = out.rayhit.ray;
  const D3 o = r.origin - ctx.back_off * r.direction;
  ray.org_x = float(o.x);
  ray.org_y = float(o.y);
  ray.org_z = float(o.z);
  ray.dir_x = float(r.direction.x);
  ray.dir_y = float(r.direction.y);
  ray.dir_z = float(r.direction.z);
  ray.tnear = 0;
  const double t_far = r.t_max + 2 * ctx.back_off;
  ray.tfar = t_far < double(std::numeric_limits<float>::max()) ? float(t_far) : std::numeric_limits<float>::infinity();
  ray.time = 0;
  ray.mask = ~0u;
  ray.id = 0;
  ray.flags = 0;
  out.rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  out.rayhit.hit.primID = RTC_INVALID_GEOMETRY_ID;
}

const segpath::detail::EmbreeSceneData<T>& manifold_data(RTCScene scene) {
  const auto* data = static_cast<const segpath::detail::EmbreeSceneData<T>*>(
      rtcGetGeometryUserData(rtcGetGeometry(scene, 0)));
  if (data == nullptr || data->triangle_geometry != 0) throw std::runtime_error("unexpected manifold layout");
  return *data;
}

void manifold_scene_rays(benchmark::State& state) {
  const auto& rec = recording();
  const RTCScene scene = rec.scene.manifold().rtc_scene();
  const auto& data = manifold_data(scene);
  std::uint64_t replays = 0;
  for (auto _ : state) {
    replay(rec.rays, unsigned(state.range(0)), [&](const RecordedRay& r) {
      if (!r.valid) return;
      ManifoldRay q;
      manifold_ray(r, data, q);
      if (r.occlusion) {
        rtcOccluded1(scene, &q.ctx.base, &q.rayhit.ray);
        benchmark::DoNotOptimize(q.rayhit.ray.tfar);
      } else {
        rtcIntersect1(scene, &q.ctx.base, &q.rayhit);
        benchmark::DoNotOptimize(q.rayhit.hit.primID);
      }
    });
    ++replays;
  }
  report(state, replays, rec.rays.size());
}

// ---- (c) a bare Embree scene of the same geometry ----------------------------------------

/// A filter that accepts every hit: the cost of Embree calling back at all.
void accept_all(const RTCFilterFunctionNArguments* args) { benchmark::DoNotOptimize(args->valid[0]); }

/// Variants that add the adapter's choices one at a time: the robust (watertight) traversal
/// flag, and a filter callback on the triangles.
enum class Bare { plain, robust, robust_filter };

struct BareScene {
  RTCDevice device = rtcNewDevice(nullptr);
  RTCScene scene = nullptr;
  double epsilon = 0;
  BareScene(const segpath::detail::EmbreeSceneData<T>& data, Bare variant) {
    scene = rtcNewScene(device);
    if (variant != Bare::plain) rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (variant == Bare::robust_filter) {
      rtcSetGeometryIntersectFilterFunction(g, accept_all);
      rtcSetGeometryOccludedFilterFunction(g, accept_all);
    }
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), data.vertices.size()));
    auto* i = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(unsigned), data.triangles.size()));
    for (std::size_t k = 0; k < data.vertices.size(); ++k)
      for (int c = 0; c < 3; ++c) v[3 * k + std::size_t(c)] = float(data.vertices[k][c]);
    for (std::size_t k = 0; k < data.triangles.size(); ++k)
      for (std::size_t c = 0; c < 3; ++c) i[3 * k + c] = data.triangles[k].vertex[c];
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    if (!data.spheres.empty()) {
      RTCGeometry s = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
      auto* p = static_cast<float*>(rtcSetNewGeometryBuffer(s, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                                            4 * sizeof(float), data.spheres.size()));
      for (std::size_t k = 0; k < data.spheres.size(); ++k) {
        p[4 * k] = float(data.spheres[k].center.x);
        p[4 * k + 1] = float(data.spheres[k].center.y);
        p[4 * k + 2] = float(data.spheres[k].center.z);
        p[4 * k + 3] = float(data.spheres[k].radius);
      }
      rtcCommitGeometry(s);
      rtcAttachGeometry(scene, s);
      rtcReleaseGeometry(s);
    }
    rtcCommitScene(scene);
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) throw std::runtime_error("bare Embree scene failed");
    epsilon = 1e-4 * data.extent;  // SmallVCM-style ray offsets
  }
  ~BareScene() {
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
  }
};

void bare_rays(benchmark::State& state, Bare variant) {
  const auto& rec = recording();
  const BareScene bare(manifold_data(rec.scene.manifold().rtc_scene()), variant);
  std::uint64_t replays = 0;
  for (auto _ : state) {
    replay(rec.rays, unsigned(state.range(0)), [&](const RecordedRay& r) {
      if (!r.valid) return;
      RTCIntersectContext ctx;
      rtcInitIntersectContext(&ctx);
      RTCRayHit rh;
      rh.ray.org_x = float(r.origin.x);
      rh.ray.org_y = float(r.origin.y);
      rh.ray.org_z = float(r.origin.z);
      rh.ray.dir_x = float(r.direction.x);
      rh.ray.dir_y = float(r.direction.y);
      rh.ray.dir_z = float(r.direction.z);
      rh.ray.tnear = float(bare.epsilon);
      const double t_far = r.has_far ? r.t_max - bare.epsilon : r.t_max;
      rh.ray.tfar = t_far < double(std::numeric_limits<float>::max()) ? float(t_far)
                                                                       : std::numeric_limits<float>::infinity();
      rh.ray.time = 0;
      rh.ray.mask = ~0u;
      rh.ray.id = 0;
      rh.ray.flags = 0;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      if (r.occlusion) {
        rtcOccluded1(bare.scene, &ctx, &rh.ray);
        benchmark::DoNotOptimize(rh.ray.tfar);
      } else {
        rtcIntersect1(bare.scene, &ctx, &rh);
        benchmark::DoNotOptimize(rh.hit.primID);
      }
    });
    ++replays;
  }
  report(state, replays, rec.rays.size());
}

// ---- the path tracer itself, for the ratio ------------------------------------------------

void pt_rays(benchmark::State& state) {
  const auto& scene = recording().scene;
  const auto threads = static_cast<std::uint32_t>(state.range(0));
  using Scene = bench::ObservedScene<bench::RayCounter>;
  const segpath::PathTracer<Scene> pt(segpath::PathTracerOptions{renderer::cornell_max_length});
  std::vector<bench::Color> image(scene.sensor().pixel_count(), bench::Color(0));
  std::vector<bench::RayCounter> counters(threads);
  std::uint64_t iteration = 0;
  for (auto _ : state) bench::pt_iteration(scene, pt, iteration++, counters, image);
  std::uint64_t rays = 0;
  for (const auto& c : counters) rays += c.rays;
  state.counters["rays/s"] = benchmark::Counter(double(rays), benchmark::Counter::kIsRate);
  state.counters["it/s"] = benchmark::Counter(double(iteration), benchmark::Counter::kIsRate);
}

/// Prints the usual table and keeps each benchmark's rays/s for the ratios.
class RateReporter : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> rate;
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& run : runs) {
      const auto it = run.counters.find("rays/s");
      if (it != run.counters.end()) rate[run.benchmark_name()] = it->second.value;
    }
    ConsoleReporter::ReportRuns(runs);
  }
};

}  // namespace

// Arg = threads. With 1 thread rates are per CPU second of that thread (robust to other load
// on the machine); with 2 threads per wall-clock second.
BENCHMARK_CAPTURE(bare_rays, plain, Bare::plain)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(bare_rays, robust, Bare::robust)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(bare_rays, robust_filter, Bare::robust_filter)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(manifold_scene_rays)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(adapter_rays)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(pt_rays)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(3.0);
BENCHMARK_CAPTURE(bare_rays, plain, Bare::plain)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(manifold_scene_rays)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(adapter_rays)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(pt_rays)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RateReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  std::printf("recorded rays of one PT iteration: %zu (%.1f%% occlusion)\n", recording().rays.size(),
              100.0 * double(std::count_if(recording().rays.begin(), recording().rays.end(),
                                           [](const RecordedRay& r) { return r.occlusion; })) /
                  double(recording().rays.size()));
  for (const char* threads : {"/1", "/2"}) {
    const auto find = [&](const std::string& prefix) {
      for (const auto& [name, value] : reporter.rate)
        if (name.rfind(prefix + threads, 0) == 0) return value;
      return 0.0;
    };
    const double pt = find("pt_rays"), bare = find("bare_rays/plain"), scene = find("manifold_scene_rays"),
                 adapter = find("adapter_rays");
    std::printf("%s thread(s):\n", threads + 1);
    if (pt > 0 && bare > 0) std::printf("  PT rays/s / bare Embree rays/s       = %.3f (target >= 0.60)\n", pt / bare);
    if (pt > 0 && scene > 0) std::printf("  PT rays/s / Embree on manifold scene = %.3f\n", pt / scene);
    if (pt > 0 && adapter > 0) std::printf("  PT rays/s / adapter calls            = %.3f\n", pt / adapter);
    if (bare > 0 && scene > 0) std::printf("  manifold scene / bare Embree         = %.3f\n", scene / bare);
  }
  benchmark::Shutdown();
  return 0;
}
