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

#endif  // SKIDIMM_TESTS_CORE_SANITIZER_H_
