// The renderer's segpath::ParallelFor: oneTBB's parallel_for, run inside the caller's
// tbb::task_arena (which fixes the thread count).
#pragma once

#include <segpath/core/parallel.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstddef>

namespace renderer {

/// pf(n, body): body(i) for every i in [0, n), one index per task (grain 1: rows and chunks
/// are already coarse). Call it inside tbb::task_arena::execute to bound the threads.
struct TbbFor {
  template <class Body>
  void operator()(std::size_t n, Body&& body) const {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t i = r.begin(); i != r.end(); ++i) body(i);
    });
  }
};

static_assert(segpath::ParallelFor<TbbFor>);

}  // namespace renderer
