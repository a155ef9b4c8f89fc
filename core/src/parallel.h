// Spreading independent jobs (logs, folds) over the machine's cores, with the
// results of one thread.
//
// parallel_for(count, workers, task) runs task(i, worker) for every i in
// [0, count) on up to `workers` threads; `worker` is the thread's index in
// [0, workers), so a caller may give each thread its own state (a bank). The
// jobs must not depend on each other; each writes only its own result slot,
// so results come out in index order whatever the threads did.
//
// Errors are those of one thread too: if jobs throw, the exception of the
// lowest index is rethrown once every job below it has run, and no job above
// it is started after it failed: the error a command reports does not depend
// on how many threads ran it or how they were scheduled.
//
// worker_count() is how many threads the commands use: SKIDIMM_THREADS if set
// (1 runs everything on the calling thread), at most the machine's cores.
#ifndef SKIDIMM_CORE_SRC_PARALLEL_H_
#define SKIDIMM_CORE_SRC_PARALLEL_H_

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace skidimm {

inline int worker_count() {
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  if (const char* given = std::getenv("SKIDIMM_THREADS")) {
    const int n = std::atoi(given);
    if (n >= 1) return std::min(n, cores);  // more threads than cores only wait
  }
  return cores;
}

inline void parallel_for(int count, int workers, const std::function<void(int, int)>& task) {
  std::atomic<int> next{0};
  std::atomic<int> first_failure{count};  // lowest failed index so far
  std::vector<std::exception_ptr> failures(static_cast<std::size_t>(std::max(count, 0)));
  auto work = [&](int worker) {
    while (true) {
      const int i = next++;
      if (i >= count || i > first_failure.load()) return;
      try {
        task(i, worker);
      } catch (...) {
        failures[static_cast<std::size_t>(i)] = std::current_exception();
        int lowest = first_failure.load();
        while (i < lowest && !first_failure.compare_exchange_weak(lowest, i)) {
        }
      }
    }
  };
  std::vector<std::thread> threads;
  for (int w = 1; w < std::min(workers, count); ++w) threads.emplace_back(work, w);
  work(0);
  for (std::thread& t : threads) t.join();
  const int failed = first_failure.load();
  if (failed < count) std::rethrow_exception(failures[static_cast<std::size_t>(failed)]);
}

}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_PARALLEL_H_
