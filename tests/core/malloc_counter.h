// Counts every heap allocation in the process by interposing malloc and
// friends (glibc): operator new, Eigen's aligned allocator and code in
// loaded plugins all end up here. Include in exactly one file of a test or
// benchmark executable.
//
// Under a sanitizer (ASan, TSan, MSan), which owns malloc itself, nothing is
// replaced: memory from glibc's allocator freed through the sanitizer's would
// be a false report or a crash. SKIDIMM_MALLOC_COUNTED is then 0 and the
// tests that count skip themselves (SKIDIMM_SKIP_UNLESS_MALLOC_COUNTED).
#ifndef SKIDIMM_TESTS_CORE_MALLOC_COUNTER_H_
#define SKIDIMM_TESTS_CORE_MALLOC_COUNTER_H_

#include "core/sanitizer.h"

#if SKIDIMM_SANITIZED
#define SKIDIMM_MALLOC_COUNTED 0
#else
#define SKIDIMM_MALLOC_COUNTED 1
#endif

// In a GoogleTest body: skips the test, saying why, when allocations are not counted.
#define SKIDIMM_SKIP_UNLESS_MALLOC_COUNTED()                                                          \
  if (!SKIDIMM_MALLOC_COUNTED) GTEST_SKIP() << "built with a sanitizer, which replaces malloc itself: " \
                                               "allocations are not counted"

#include <atomic>
#include <cstddef>
#include <cstdlib>  // glibc's declarations first, which ours must match

extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
}

namespace skidimm_test {
inline std::atomic<long> g_malloc_calls{0};
inline std::atomic<long> g_malloc_bytes{0};
}  // namespace skidimm_test

#if SKIDIMM_MALLOC_COUNTED
extern "C" {
void* malloc(std::size_t size) noexcept {
  ++skidimm_test::g_malloc_calls;
  skidimm_test::g_malloc_bytes += static_cast<long>(size);
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) noexcept {
  ++skidimm_test::g_malloc_calls;
  skidimm_test::g_malloc_bytes += static_cast<long>(count * size);
  return __libc_calloc(count, size);
}
void* realloc(void* p, std::size_t size) noexcept {
  ++skidimm_test::g_malloc_calls;
  skidimm_test::g_malloc_bytes += static_cast<long>(size);
  return __libc_realloc(p, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) noexcept {
  ++skidimm_test::g_malloc_calls;
  skidimm_test::g_malloc_bytes += static_cast<long>(size);
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) noexcept {
  ++skidimm_test::g_malloc_calls;
  skidimm_test::g_malloc_bytes += static_cast<long>(size);
  *out = __libc_memalign(alignment, size);
  return *out == nullptr ? 12 /* ENOMEM */ : 0;
}
}
#endif  // SKIDIMM_MALLOC_COUNTED

#endif  // SKIDIMM_TESTS_CORE_MALLOC_COUNTER_H_
