// Pcg32::for_sample: distinct streams for distinct (seed, pixel, sample), reproducible, uniform.
#include <segpath/core/rng.hpp>

#include <cmath>
#include <cstdint>
#include <set>
#include <utility>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

/// The first four outputs of a stream: two streams that agree on them are taken as equal.
std::vector<std::uint32_t> head(Pcg32 rng) {
  std::vector<std::uint32_t> out(4);
  for (auto& v : out) v = rng.next_u32();
  return out;
}

}  // namespace

// Every iteration of every method draws from for_sample(seed, pixel or path, iteration-dependent
// index): if the index were ignored, every iteration would repeat the first one's image.
TEST_CASE("Pcg32::for_sample gives a distinct stream per seed, pixel and sample index", "[core]") {
  std::set<std::vector<std::uint32_t>> seen;
  std::size_t streams = 0;
  for (std::uint64_t seed : {0ULL, 1ULL, 5ULL})
    for (std::uint64_t pixel = 0; pixel < 64; ++pixel)
      for (std::uint64_t sample = 0; sample < 32; ++sample) {
        seen.insert(head(Pcg32::for_sample(seed, pixel, sample)));
        ++streams;
      }
  CHECK(seen.size() == streams);
  // Reproducible: the same triple gives the same stream.
  CHECK(head(Pcg32::for_sample(5, 17, 3)) == head(Pcg32::for_sample(5, 17, 3)));
}

TEST_CASE("Pcg32::for_sample streams are uniform across sample indices", "[core]") {
  // The first uniform of pixel 0's stream over 4096 sample indices: its mean is 1/2 within
  // 5 standard errors (1 / sqrt(12 n)).
  const std::uint64_t n = 4096;
  double sum = 0;
  for (std::uint64_t i = 0; i < n; ++i) {
    Pcg32 rng = Pcg32::for_sample(1, 0, i);
    sum += rng.uniform<double>();
  }
  CHECK(std::abs(sum / double(n) - 0.5) < 5.0 / std::sqrt(12.0 * double(n)));
}
