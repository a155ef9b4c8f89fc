// SKIDIMM_CHECK: programmer errors (wrong vector sizes passed to the API, a
// broken invariant) abort with a message instead of corrupting an estimate.
// Always on: the checks sit outside inner loops and cost nanoseconds.
#ifndef SKIDIMM_CORE_SRC_CHECK_H_
#define SKIDIMM_CORE_SRC_CHECK_H_

#include <cstdio>
#include <cstdlib>

#define SKIDIMM_CHECK(condition, message)                                                             \
  do {                                                                                                \
    if (!(condition)) {                                                                               \
      std::fprintf(stderr, "%s:%d: check failed: %s: %s\n", __FILE__, __LINE__, #condition, message); \
      std::abort();                                                                                   \
    }                                                                                                 \
  } while (false)

#endif  // SKIDIMM_CORE_SRC_CHECK_H_
