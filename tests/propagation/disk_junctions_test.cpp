// The disk support of propagation: the neighbour lists are exactly the (end, start) pairs
// within r with agreeing normals, in both directions and for any thread count, and
// propagation over them equals the naive recursion (N39) with the disk kernel (N19).
#include <segpath/propagation/disk_junctions.hpp>
#include <segpath/propagation/propagate.hpp>
#include <segpath/testing/two_threads.hpp>

#include <thread>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

/// Ends scattered in a 2 x 2 x 0.5 box with normals from three directions (two of them
/// agreeing within 60 degrees, one opposite), some off the manifold.
std::vector<Segment<double>> random_segments(Pcg32& rng, std::size_t n) {
  auto point = [&] {
    if (rng.uniform<double>() < 0.08) return SurfacePoint<double>::at_point({0, 0, -5});
    const double u = rng.uniform<double>();
    const Vec3<double> normal = u < 0.45 ? Vec3<double>(0, 0, 1) : u < 0.8 ? glm::normalize(Vec3<double>(0.5, 0, 1)) : Vec3<double>(0, 0, -1);
    return SurfacePoint<double>::on_surface({rng.uniform<double>() * 2, rng.uniform<double>() * 2, rng.uniform<double>() * 0.5}, normal);
  };
  std::vector<Segment<double>> segments;
  for (std::size_t i = 0; i < n; ++i) segments.push_back({point(), point()});
  return segments;
}

/// The support predicate written out: x within r of y, normals within 60 degrees (a segment
/// never joins itself: the callers skip s' == s).
bool joined(const Segment<double>& s, const Segment<double>& sp, double r) {
  if (s.y.kind != PointKind::surface || sp.x.kind != PointKind::surface) return false;
  const Vec3<double> d = sp.x.position - s.y.position;
  return glm::dot(d, d) < r * r && glm::dot(s.y.normal, sp.x.normal) >= 0.5 - 1e-12;
}

const auto identity = [](const SurfacePoint<double>& p) { return p.position; };

}  // namespace

TEST_CASE("disk junctions are exactly the pairs within r with agreeing normals", "[propagation]") {
  Pcg32 rng(77, 1);
  for (const double r : {0.1, 0.35, 1.0}) {
    const auto segments = random_segments(rng, 5000);
    DiskJunctions<double> serial, threaded;
    serial.build(r, std::span<const Segment<double>>(segments), identity);
    threaded.build(r, std::span<const Segment<double>>(segments), identity, 0.5, segpath::testing::TwoThreadFor{});
    CHECK(serial.kernel() == Approx(1 / (pi<double> * r * r)));
    std::size_t pairs = 0;
    std::vector<std::vector<std::uint32_t>> ending(segments.size());
    for (std::uint32_t s = 0; s < segments.size(); ++s) {
      std::vector<std::uint32_t> expected;
      for (std::uint32_t sp = 0; sp < segments.size(); ++sp)
        if (sp != s && joined(segments[s], segments[sp], r)) {
          expected.push_back(sp);
          ending[sp].push_back(s);
        }
      const auto got = serial.starting_near(s), got2 = threaded.starting_near(s);
      REQUIRE(std::vector<std::uint32_t>(got.begin(), got.end()) == expected);
      REQUIRE(std::vector<std::uint32_t>(got2.begin(), got2.end()) == expected);
      pairs += expected.size();
    }
    for (std::uint32_t sp = 0; sp < segments.size(); ++sp) {
      const auto got = serial.ending_near(sp);
      REQUIRE(std::vector<std::uint32_t>(got.begin(), got.end()) == ending[sp]);
    }
    CHECK(serial.junction_count() == pairs);
    CHECK(pairs > segments.size() / 10);  // the lists are not trivially empty
  }
}

TEST_CASE("disk junctions reject a bad radius or normal threshold", "[propagation]") {
  const std::vector<Segment<double>> none;
  DiskJunctions<double> j;
  CHECK_THROWS_AS(j.build(0.0, std::span<const Segment<double>>(none)), std::invalid_argument);
  CHECK_THROWS_AS(j.build(-1.0, std::span<const Segment<double>>(none)), std::invalid_argument);
  CHECK_THROWS_AS(j.build(std::numeric_limits<double>::infinity(), std::span<const Segment<double>>(none)), std::invalid_argument);
  CHECK_THROWS_AS(j.build(0.1, std::span<const Segment<double>>(none), identity, 1.5), std::invalid_argument);
  CHECK_NOTHROW(j.build(0.1, std::span<const Segment<double>>(none)));
  CHECK(j.segment_count() == 0);
}

namespace {

/// (N39) with the disk kernel, by brute force over every pair.
double naive(const std::vector<Segment<double>>& segments, const std::vector<double>& emitted,
             const std::vector<double>& weighted_geometry, const std::vector<double>& link, double r, std::uint32_t s,
             int depth) {
  double value = emitted[s];
  if (depth == 0) return value;
  double sum = 0;
  for (std::uint32_t sp = 0; sp < segments.size(); ++sp)
    if (sp != s && joined(segments[s], segments[sp], r))
      sum += link[s * segments.size() + sp] * naive(segments, emitted, weighted_geometry, link, r, sp, depth - 1) *
             weighted_geometry[sp];
  return value + sum / (pi<double> * r * r);
}

}  // namespace

TEST_CASE("propagation over disks equals the naive recursive MMIS estimator on 300 random pools", "[propagation][estimators]") {
  Pcg32 rng(2026, 7);
  int compared = 0, nontrivial = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const std::size_t n = 4 + rng.next_u32() % 9;
    const auto segments = random_segments(rng, n);
    std::vector<double> emitted, weighted_geometry, link(n * n);
    for (std::size_t i = 0; i < n; ++i) {
      emitted.push_back(rng.uniform<double>() < 0.5 ? 0.0 : rng.uniform<double>() * 3);
      weighted_geometry.push_back(rng.uniform<double>() < 0.1 ? 0.0 : rng.uniform<double>());
    }
    for (auto& l : link) l = rng.uniform<double>() * 0.8;
    const double r = 0.6 + rng.uniform<double>();
    DiskJunctions<double> junctions;
    junctions.build(r, std::span<const Segment<double>>(segments));
    auto link_of = [&](std::uint32_t s, std::uint32_t sp) { return link[s * n + sp]; };
    const PropagationInputs<double, decltype(link_of), DiskJunctions<double>> inputs{junctions, emitted, weighted_geometry, link_of};
    const int depth = 1 + int(rng.next_u32() % 4);
    std::vector<double> radiance, scratch, threaded;
    propagate(inputs, depth, radiance, scratch);
    propagate(inputs, depth, threaded, scratch, segpath::testing::TwoThreadFor{});
    // The order of the sums: per segment, its neighbours in increasing id order,
    // sum += f_r (L G w)(s'), then L_e + sum K; bit for bit.
    std::vector<double> current(emitted), next(n);
    for (int k = 0; k < depth; ++k, std::swap(current, next))
      for (std::uint32_t s = 0; s < n; ++s) {
        double sum = 0;
        for (const std::uint32_t sp : junctions.starting_near(s))
          if (weighted_geometry[sp] != 0) sum += link_of(s, sp) * (current[sp] * weighted_geometry[sp]);
        next[s] = emitted[s] + sum * junctions.kernel();
      }
    CHECK(radiance == current);
    CHECK(threaded == radiance);
    for (std::uint32_t s = 0; s < n; ++s) {
      const double reference = naive(segments, emitted, weighted_geometry, link, r, s, depth);
      CHECK(radiance[s] == Approx(reference).epsilon(1e-12).margin(1e-300));
      ++compared;
      nontrivial += reference != emitted[s];
    }
  }
  CHECK(nontrivial > compared / 4);
}
