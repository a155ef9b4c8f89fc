// How much memory a fit takes beyond its logs: it must not grow with their
// length (a fit on a million rows then runs in the memory of the data).
// Counts the live heap by interposing malloc and free (glibc), so this is an
// executable of its own.
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <random>

#include "core/sanitizer.h"
#include "skidimm/fitting/bank_fit.h"

#if !SKIDIMM_SANITIZED
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
void __libc_free(void* p);
}

namespace {
std::atomic<long> g_live{0};
std::atomic<long> g_peak{0};

void* counted(void* p) {
  if (p != nullptr) {
    const long live = g_live += static_cast<long>(malloc_usable_size(p));
    long peak = g_peak.load();
    while (live > peak && !g_peak.compare_exchange_weak(peak, live)) {
    }
  }
  return p;
}
}  // namespace

extern "C" {
void* malloc(std::size_t size) noexcept { return counted(__libc_malloc(size)); }
void* calloc(std::size_t count, std::size_t size) noexcept { return counted(__libc_calloc(count, size)); }
void* realloc(void* p, std::size_t size) noexcept {
  if (p != nullptr) g_live -= static_cast<long>(malloc_usable_size(p));
  void* out = __libc_realloc(p, size);
  if (out == nullptr && p != nullptr && size > 0) return counted(p);  // failed: p is still live
  return counted(out);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) noexcept {
  return counted(__libc_memalign(alignment, size));
}
void* memalign(std::size_t alignment, std::size_t size) noexcept { return counted(__libc_memalign(alignment, size)); }
int posix_memalign(void** out, std::size_t alignment, std::size_t size) noexcept {
  *out = counted(__libc_memalign(alignment, size));
  return *out == nullptr ? 12 /* ENOMEM */ : 0;
}
void free(void* p) noexcept {
  if (p != nullptr) g_live -= static_cast<long>(malloc_usable_size(p));
  __libc_free(p);
}
}
#endif  // !SKIDIMM_SANITIZED

namespace skidimm {
namespace fitting {
namespace {

// `rows` steps of the ltc_linear asphalt mode of configs/ltc_terrains.yaml
// at 50 Hz, both states measured with its R, wheels driven richly.
Trajectory simulated(const Bank& bank, int rows) {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  const sdk::MotionModel& model = *bank.models[0];
  Trajectory t;
  t.source = "simulated";
  t.u.resize(2, rows);
  t.z.resize(2, rows);
  t.truth.assign(static_cast<std::size_t>(rows), "");
  Eigen::VectorXd x = Eigen::VectorXd::Zero(2), next(2);
  const double dt = 0.02;
  for (int k = 0; k < rows; ++k) {
    const double time = k * dt;
    t.t.push_back(time);
    t.u.col(k) = Eigen::Vector2d(4.0 + 3.0 * std::sin(0.9 * time) + std::sin(3.1 * time), 4.0 + 3.0 * std::cos(0.6 * time));
    t.z.col(k) = x + Eigen::Vector2d(0.05 * normal(rng), 0.02 * normal(rng));
    model.predict(x, t.u.col(k), dt, next);
    x = next + Eigen::Vector2d(0.01 * normal(rng), 0.01 * normal(rng));
  }
  return t;
}

// The most memory live at once during a fit of `rows` rows, beyond what was
// live when it started (the bank and the log).
long peak_beyond_the_log(Objective objective, int rows, long condense_above) {
  Bank bank = Bank::load(std::string(SKIDIMM_SOURCE_DIR) + "/configs/ltc_terrains.yaml", {SKIDIMM_PLUGIN_DIR});
  const std::vector<ModeLogs> data{{0, {simulated(bank, rows)}}};
  BankFitOptions options;
  options.objective = objective;
  options.window.condense_above = condense_above;
#if SKIDIMM_SANITIZED
  // The sanitizer's allocator is not counted (the test is skipped there).
  fit_bank(&bank, data, options);
  return 0;
#else
  const long before = g_live.load();
  g_peak = before;
  fit_bank(&bank, data, options);
  return g_peak.load() - before;
#endif
}

TEST(FitMemory, DoesNotGrowWithTheLog) {
  if (SKIDIMM_SANITIZED) GTEST_SKIP() << "built with a sanitizer, which replaces malloc itself";
  // 8000 and 16000 rows: 16000 and 32000 residuals, past the size above
  // which the window objective condenses its windows, here 10000
  // (FitOptions::condense_above, 100000 by default: the same path, reached
  // with a tenth of the rows); the likelihood objective starts from that fit.
  // Just under a power of two: what grows with the log (its bounded sample)
  // doubles its capacity, so the measure is of whole doublings.
  const int rows = 8000;
  const long condense_above = 10000;
  for (Objective objective : {Objective::kWindow, Objective::kLikelihood}) {
    SCOPED_TRACE(to_string(objective));
    const long once = peak_beyond_the_log(objective, rows, condense_above);
    const long twice = peak_beyond_the_log(objective, 2 * rows, condense_above);
    // A log of 8000 rows holds 8000 x (8 + 2 x 8 + 2 x 8 + 32) bytes (time,
    // inputs, measurements, truth labels): 576 kB. One block per window
    // holds each window's Jacobian (2 x 8 doubles) and more: over 1 MB.
    // What the fit adds for 8000 more rows must stay below two doubles a
    // row (128 kB): a bounded sample, not a copy of the log or a value per
    // residual and parameter.
    EXPECT_GT(once, 0);
    EXPECT_LT(twice - once, rows * 16) << "fit memory " << once << " bytes for " << rows << " rows, " << twice
                                       << " for " << 2 * rows;
  }
  // Not condensed, the windows' blocks grow with the log: the measure sees it.
  const long once = peak_beyond_the_log(Objective::kWindow, rows, 1000000);
  const long twice = peak_beyond_the_log(Objective::kWindow, 2 * rows, 1000000);
  EXPECT_GT(twice - once, rows * 16) << "uncondensed fit memory " << once << " bytes, " << twice;
}

}  // namespace
}  // namespace fitting
}  // namespace skidimm
