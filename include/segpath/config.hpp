// Version, the user-overridable assertion macro and inlining hints.
#pragma once

#include <cstdio>
#include <cstdlib>

#define SEGPATH_VERSION_MAJOR 0
#define SEGPATH_VERSION_MINOR 1
#define SEGPATH_VERSION_PATCH 0

// SEGPATH_ASSERT(condition, message): internal invariant checks. Define it before
// including segpath to route failures into your own error handling; by default it
// aborts with the message in debug builds and is compiled out when NDEBUG is set.
#ifndef SEGPATH_ASSERT
#  ifdef NDEBUG
#    define SEGPATH_ASSERT(condition, message) ((void)0)
#  else
#    define SEGPATH_ASSERT(condition, message)                                               \
      ((condition) ? (void)0                                                                 \
                   : (std::fprintf(stderr, "segpath assertion failed at %s:%d: %s (%s)\n",   \
                                   __FILE__, __LINE__, message, #condition),                 \
                      std::abort()))
#  endif
#endif

#if defined(__GNUC__) || defined(__clang__)
#  define SEGPATH_FORCE_INLINE inline __attribute__((always_inline))
#  define SEGPATH_LIKELY(x) __builtin_expect(!!(x), 1)
#  define SEGPATH_UNLIKELY(x) __builtin_expect(!!(x), 0)
#else
#  define SEGPATH_FORCE_INLINE inline
#  define SEGPATH_LIKELY(x) (x)
#  define SEGPATH_UNLIKELY(x) (x)
#endif
