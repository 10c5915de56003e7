// resize_for_overwrite: scratch vectors that grow without a doubling copy.
#include <segpath/core/scratch_vector.hpp>

#include <cstddef>
#include <vector>

#include "support/catch.hpp"

TEST_CASE("resize_for_overwrite grows with 1/8 to spare and never shrinks the buffer", "[core]") {
  std::vector<int> v(100, 7);
  const std::size_t grown_from = v.capacity();
  segpath::resize_for_overwrite(v, 800);
  CHECK(v.size() == 800);
  CHECK(v.capacity() == 900);  // not resize()'s doubling of the old size, nor exactly 800
  CHECK(grown_from < 800);
  const int* buffer = v.data();
  segpath::resize_for_overwrite(v, 850);  // within the spare: no new buffer
  CHECK(v.size() == 850);
  CHECK(v.data() == buffer);
  segpath::resize_for_overwrite(v, 10);  // smaller: the buffer is kept for the next iteration
  CHECK(v.size() == 10);
  CHECK(v.capacity() == 900);
  CHECK(v.data() == buffer);
  segpath::resize_for_overwrite(v, 1800);
  CHECK(v.size() == 1800);
  CHECK(v.capacity() == 2025);
}
