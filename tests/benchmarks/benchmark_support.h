// What the benchmarks share with their main (benchmark_main.cc): the process's
// heap counters (tests/core/malloc_counter.h is included there, once).
#ifndef SKIDIMM_TESTS_BENCHMARKS_BENCHMARK_SUPPORT_H_
#define SKIDIMM_TESTS_BENCHMARKS_BENCHMARK_SUPPORT_H_

namespace skidimm_bench {

long malloc_calls();  // heap allocations so far in this process
long malloc_bytes();  // bytes they asked for

}  // namespace skidimm_bench

#endif  // SKIDIMM_TESTS_BENCHMARKS_BENCHMARK_SUPPORT_H_
