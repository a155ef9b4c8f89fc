#include "crc32.h"

#include <array>
#include <cstring>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define SKIDIMM_CRC32_CLMUL 1
#endif

namespace skidimm {
namespace ros {

namespace {

// Slicing by 8 (Intel's "slice-by-8"): eight table lookups consume eight
// bytes, several times faster than the byte-at-a-time loop on the
// megabytes of a recording.
struct Tables {
  std::array<std::array<std::uint32_t, 256>, 8> t{};
  Tables() {
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[0][i] = c;
    }
    for (std::uint32_t i = 0; i < 256; ++i) {
      for (std::size_t s = 1; s < 8; ++s) t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xFFu];
    }
  }
};

const Tables& tables() {
  static const Tables instance;
  return instance;
}

std::uint32_t crc32_tables(std::uint32_t c, const unsigned char* p, std::size_t size);

#ifdef SKIDIMM_CRC32_CLMUL
// Carry-less multiplication folding (Gopal et al., "Fast CRC Computation for
// Generic Polynomials Using PCLMULQDQ Instruction", Intel, 2009), in the
// bit-reflected domain of CRC-32's polynomial: four 128-bit lanes folded 64
// bytes at a time, then into one lane, then 16 bytes at a time; the last
// 128 bits reduced to 64, then to 32 by Barrett reduction. The constants are
// x^(k) mod P(x) for the fold distances (512+64, 512, 128+64, 128, 64) and
// the Barrett pair (P, floor(x^64 / P)), all bit-reflected. About ten times
// the table's speed: a decompressed chunk's CRC costs less than its zstd.
// Folds `x` forward by the distance `k` encodes and adds `next`.
__attribute__((target("pclmul,sse4.1"))) inline __m128i fold(__m128i x, __m128i k, __m128i next) {
  return _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x, k, 0x11), _mm_clmulepi64_si128(x, k, 0x00)), next);
}

__attribute__((target("sse4.1"))) inline __m128i load(const unsigned char* at) {
  return _mm_loadu_si128(reinterpret_cast<const __m128i*>(at));
}

// `c` is the running register (already inverted); size >= 64, a multiple of 16.
__attribute__((target("pclmul,sse4.1"))) std::uint32_t crc32_clmul(std::uint32_t c, const unsigned char* p,
                                                                   std::size_t size) {
  const __m128i fold_64 = _mm_set_epi64x(0x01c6e41596, 0x0154442bd4);
  const __m128i fold_16 = _mm_set_epi64x(0x00ccaa009e, 0x01751997d0);
  const __m128i fold_4 = _mm_set_epi64x(0, 0x0163cd6124);
  const __m128i barrett = _mm_set_epi64x(0x01f7011641, 0x01db710641);
  const __m128i low_32 = _mm_setr_epi32(~0, 0, ~0, 0);
  __m128i x1 = _mm_xor_si128(load(p), _mm_cvtsi32_si128(static_cast<int>(c)));
  __m128i x2 = load(p + 16), x3 = load(p + 32), x4 = load(p + 48);
  p += 64;
  size -= 64;
  while (size >= 64) {
    x1 = fold(x1, fold_64, load(p));
    x2 = fold(x2, fold_64, load(p + 16));
    x3 = fold(x3, fold_64, load(p + 32));
    x4 = fold(x4, fold_64, load(p + 48));
    p += 64;
    size -= 64;
  }
  x1 = fold(x1, fold_16, x2);
  x1 = fold(x1, fold_16, x3);
  x1 = fold(x1, fold_16, x4);
  while (size >= 16) {
    x1 = fold(x1, fold_16, load(p));
    p += 16;
    size -= 16;
  }
  // 128 bits to 64.
  __m128i x2b = _mm_clmulepi64_si128(x1, fold_16, 0x10);
  x1 = _mm_xor_si128(_mm_srli_si128(x1, 8), x2b);
  x2b = _mm_srli_si128(x1, 4);
  x1 = _mm_xor_si128(_mm_clmulepi64_si128(_mm_and_si128(x1, low_32), fold_4, 0x00), x2b);
  // Barrett reduction to 32 bits.
  __m128i t = _mm_clmulepi64_si128(_mm_and_si128(x1, low_32), barrett, 0x10);
  t = _mm_clmulepi64_si128(_mm_and_si128(t, low_32), barrett, 0x00);
  return static_cast<std::uint32_t>(_mm_extract_epi32(_mm_xor_si128(x1, t), 1));
}

bool has_clmul() {
  static const bool supported = __builtin_cpu_supports("pclmul") && __builtin_cpu_supports("sse4.1");
  return supported;
}
#endif

}  // namespace

std::uint32_t crc32(std::uint32_t crc, const void* data, std::size_t size) {
  const auto* p = static_cast<const unsigned char*>(data);
  std::uint32_t c = ~crc;
#ifdef SKIDIMM_CRC32_CLMUL
  if (size >= 64 && has_clmul()) {
    const std::size_t folded = size & ~std::size_t{15};
    c = crc32_clmul(c, p, folded);
    p += folded;
    size -= folded;
  }
#endif
  return ~crc32_tables(c, p, size);
}

namespace {

std::uint32_t crc32_tables(std::uint32_t c, const unsigned char* p, std::size_t size) {
  const auto& t = tables().t;
  while (size >= 8) {
    std::uint32_t low = 0, high = 0;
    std::memcpy(&low, p, 4);  // little-endian hosts only (static_assert in mcap_reader.cc)
    std::memcpy(&high, p + 4, 4);
    low ^= c;
    c = t[7][low & 0xFFu] ^ t[6][(low >> 8) & 0xFFu] ^ t[5][(low >> 16) & 0xFFu] ^ t[4][low >> 24] ^
        t[3][high & 0xFFu] ^ t[2][(high >> 8) & 0xFFu] ^ t[1][(high >> 16) & 0xFFu] ^ t[0][high >> 24];
    p += 8;
    size -= 8;
  }
  while (size-- > 0) c = t[0][(c ^ *p++) & 0xFFu] ^ (c >> 8);
  return c;
}

}  // namespace

}  // namespace ros
}  // namespace skidimm
