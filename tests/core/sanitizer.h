// Whether this test binary is built with a sanitizer (scripts/check.sh):
// SKIDIMM_SANITIZED is then 1. clang says so through __has_feature, gcc
// through __SANITIZE_ADDRESS__ / __SANITIZE_THREAD__.
#ifndef SKIDIMM_TESTS_CORE_SANITIZER_H_
#define SKIDIMM_TESTS_CORE_SANITIZER_H_

#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define SKIDIMM_SANITIZED 1
#endif
#endif
#if !defined(SKIDIMM_SANITIZED) && (defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__))
#define SKIDIMM_SANITIZED 1
#endif
#ifndef SKIDIMM_SANITIZED
#define SKIDIMM_SANITIZED 0
#endif

// For a test whose assertions are statistical or about long runs (parameters
// recovered from thousands of simulated rows, 10^5 steps without underflow):
// skipped under the sanitizers, where it would cost tens of seconds (ASan at
// -O1 runs the fitter 5-20 times slower) and where shorter tests run the same
// code (the likelihood's value and gradient, the window fit, the IMM step); the
// Release suite runs it. Its ctest line says it was skipped, and why.
#define SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL()                                                       \
  do {                                                                                                    \
    if (SKIDIMM_SANITIZED) GTEST_SKIP() << "statistical: run by the Release suite, not under sanitizers"; \
  } while (false)

#endif  // SKIDIMM_TESTS_CORE_SANITIZER_H_
