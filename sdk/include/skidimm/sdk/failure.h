// Why a plugin's predict(), jacobian() or process_noise() failed.
//
// The plugin virtuals report failure by returning false (no exception crosses
// the boundary, abi.h). The reason travels beside the return value: model code
// calls report_failure("...") before returning false, SizedMotionModel's
// trampolines do it for exceptions thrown by model code, and the engine reads
// it once through MotionModel::failure_reason(), right after the false, on the
// same thread. The text lives in a thread-local buffer of the library that
// reported it, so reporting allocates nothing and models shared by several
// threads do not mix their reasons.
#ifndef SKIDIMM_SDK_FAILURE_H_
#define SKIDIMM_SDK_FAILURE_H_

#include <algorithm>
#include <cstddef>
#include <cstdio>
#include <cstring>

namespace skidimm {
namespace sdk {
namespace internal {

struct FailureBuffer {
  static constexpr std::size_t kCapacity = 512;
  char text[kCapacity] = {};
};

inline FailureBuffer& failure_buffer() noexcept {
  static thread_local FailureBuffer buffer;
  return buffer;
}

}  // namespace internal

// Records why the current call is about to return false; `prefix` and
// `detail` are joined (either may be null), the result is cut at 511 bytes.
inline void report_failure(const char* prefix, const char* detail = nullptr) noexcept {
  char* out = internal::failure_buffer().text;
  std::size_t used = 0;
  for (const char* part : {prefix, detail}) {
    if (part == nullptr) continue;
    const std::size_t room = internal::FailureBuffer::kCapacity - 1 - used;
    const std::size_t length = std::min(std::strlen(part), room);
    std::memcpy(out + used, part, length);
    used += length;
  }
  out[used] = '\0';
}

namespace internal {

// report_failure(), then false: how a generated or sized model refuses a
// step after catching what the author's code threw.
inline bool caught(const char* what, const char* detail) noexcept {
  report_failure(what, detail);
  return false;
}

}  // namespace internal

// A reason with numbers in it, built without allocating (a failing step
// must not allocate either), then reported:
//
//   FailureText why;
//   why << "slip ratio " << s << " outside [0, 1] at V = " << x[kV];
//   why.report();
//
// Numbers are written with 6 significant digits; text past 511 bytes is cut.
class FailureText {
 public:
  FailureText& operator<<(const char* text) noexcept {
    for (; text != nullptr && *text != '\0' && used_ + 1 < internal::FailureBuffer::kCapacity; ++text) {
      text_[used_++] = *text;
    }
    text_[used_] = '\0';
    return *this;
  }
  FailureText& operator<<(double value) noexcept {
    char number[32];
    std::snprintf(number, sizeof(number), "%.6g", value);
    return *this << number;
  }
  FailureText& operator<<(int value) noexcept {
    char number[16];
    std::snprintf(number, sizeof(number), "%d", value);
    return *this << number;
  }
  // "[a, b, c]".
  FailureText& list(const double* values, int count) noexcept {
    *this << "[";
    for (int i = 0; i < count; ++i) *this << (i > 0 ? ", " : "") << values[i];
    return *this << "]";
  }
  const char* text() const noexcept { return text_; }
  void report() const noexcept { report_failure(text_); }

 private:
  char text_[internal::FailureBuffer::kCapacity] = {};
  std::size_t used_ = 0;
};

// The reason last reported on this thread ("" if none), which is then cleared.
// The pointer stays valid until the next report_failure() on this thread.
inline const char* take_failure() noexcept {
  internal::FailureBuffer& buffer = internal::failure_buffer();
  static thread_local char taken[internal::FailureBuffer::kCapacity];
  std::memcpy(taken, buffer.text, internal::FailureBuffer::kCapacity);
  buffer.text[0] = '\0';
  return taken;
}

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_FAILURE_H_
