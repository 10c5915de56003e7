// Vectors reused as scratch from iteration to iteration, whose elements are all rewritten each
// time (VCM's light-subpath ends and photon ids, the photon grid's arrays).
#pragma once

#include <cstddef>
#include <vector>

namespace segpath {

/// Makes room for n elements in `v`, whose current elements the caller no longer needs. A vector
/// that must grow frees its buffer before it allocates the new one (reserve() and resize() would
/// hold both while they copy the old elements, and resize() would take twice the old size: the
/// peak of an iteration with a few more items than the last) and takes 1/8 more than it needs,
/// so that the next iterations rarely grow it again. Where it grows, `v` is left empty.
template <class V, class A>
void reserve_without_copy(std::vector<V, A>& v, std::size_t n) {
  if (n <= v.capacity()) return;
  std::vector<V, A>(v.get_allocator()).swap(v);
  v.reserve(n + n / 8);
}

/// Resizes `v` to n elements that the caller is about to overwrite, growing it as
/// reserve_without_copy does. The elements are value-initialised where new (as resize() does),
/// the old ones kept where the buffer did not grow.
template <class V, class A>
void resize_for_overwrite(std::vector<V, A>& v, std::size_t n) {
  reserve_without_copy(v, n);
  v.resize(n);
}

}  // namespace segpath
