// Vectors reused as scratch from iteration to iteration, whose elements are all rewritten each
// time (VCM's light-subpath ends, the photon grid's arrays).
#pragma once

#include <cstddef>
#include <vector>

namespace segpath {

/// Resizes `v` to n elements that the caller is about to overwrite. A vector that must grow frees
/// its buffer before it allocates the new one (resize() would hold both while it copies the old
/// elements, and then grow to twice the size: the peak of an iteration with a few more items
/// than the last) and reserves 1/8 more than it needs, untouched until used, so that the next
/// iterations rarely grow it again. The elements' values are unspecified.
template <class V>
void resize_for_overwrite(std::vector<V>& v, std::size_t n) {
  if (n > v.capacity()) {
    std::vector<V>().swap(v);
    v.reserve(n + n / 8);
  }
  v.resize(n);
}

}  // namespace segpath
