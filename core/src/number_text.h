// Doubles to text and back, the way std::to_chars / std::from_chars do it,
// faster for the numbers logs are made of. Private to core (log_io.cc,
// csv_table.cc); tests/benchmarks/number_text_test.cc compares both with the
// standard functions on tens of millions of values.
//
//  * shortest_to_chars: what std::to_chars(first, last, value) writes (the
//    shortest text that reads back to the same double, fixed or scientific,
//    whichever is shorter, fixed on a tie), character for character. The
//    digits come from Ryu (Ulf Adams, "Ryu: fast float-to-string conversion",
//    PLDI 2018; libstdc++'s to_chars uses the same algorithm), for
//    1e-300 <= |value| < 2^53, where only the negative-exponent half of Ryu
//    is needed and a fixed form is always exact; zero, NaN, infinities and
//    everything else go to std::to_chars.
//  * parse_plain_decimal: -?digits[.digits] (or -?.digits) with a mantissa
//    below 2^53 and at most 22 decimals is m / 10^k, one correctly rounded
//    division of exact operands (Clinger's fast path): exactly what
//    std::from_chars returns. Returns false for anything else (exponents,
//    long mantissas, inf, nan, junk): the caller then uses parse_general.
//  * parse_general: std::from_chars, with subnormal values read as values
//    (see below).
#ifndef SKIDIMM_CORE_SRC_NUMBER_TEXT_H_
#define SKIDIMM_CORE_SRC_NUMBER_TEXT_H_

#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <vector>

namespace skidimm {
namespace number_text {

namespace internal {

__extension__ typedef unsigned __int128 Uint128;  // GCC and Clang; -Wpedantic otherwise objects

constexpr int kPow5Bitcount = 125;  // Ryu's DOUBLE_POW5_BITCOUNT
constexpr int kPow5TableSize = 326;

// ceil(log2(5^e)) for 0 <= e <= 3528 (Ryu's pow5bits).
inline int pow5bits(int e) { return static_cast<int>(((static_cast<std::uint32_t>(e) * 1217359u) >> 19) + 1); }
// floor(log10(5^e)) for 0 <= e <= 2620 (Ryu's log10Pow5).
inline std::uint32_t log10_pow5(int e) { return (static_cast<std::uint32_t>(e) * 732923u) >> 20; }

// Ryu's DOUBLE_POW5_SPLIT: 5^i as its top 125 bits (low word, high word),
// computed once from exact powers of five.
struct Pow5Table {
  std::array<std::array<std::uint64_t, 2>, kPow5TableSize> split;
  Pow5Table() {
    std::vector<std::uint32_t> power{1};  // little-endian 32-bit limbs of 5^i
    for (int i = 0; i < kPow5TableSize; ++i) {
      int bits = 32 * static_cast<int>(power.size() - 1);
      for (std::uint32_t top = power.back(); top != 0; top >>= 1) ++bits;
      // floor(5^i / 2^(bits - 125)), or 5^i << (125 - bits) when shorter.
      const int shift = bits - kPow5Bitcount;
      Uint128 value = 0;
      for (int b = kPow5Bitcount - 1; b >= 0; --b) {
        const int source = b + shift;  // bit of 5^i that lands at bit b
        const bool set = source >= 0 && ((power[static_cast<std::size_t>(source / 32)] >> (source % 32)) & 1u) != 0;
        value = (value << 1) | (set ? 1u : 0u);
      }
      split[static_cast<std::size_t>(i)] = {static_cast<std::uint64_t>(value),
                                            static_cast<std::uint64_t>(value >> 64)};
      std::uint64_t carry = 0;
      for (std::uint32_t& limb : power) {
        const std::uint64_t product = static_cast<std::uint64_t>(limb) * 5u + carry;
        limb = static_cast<std::uint32_t>(product);
        carry = product >> 32;
      }
      if (carry != 0) power.push_back(static_cast<std::uint32_t>(carry));
    }
  }
};

inline const Pow5Table& pow5_table() {
  static const Pow5Table table;
  return table;
}

// (m * mul) >> j for a 125-bit multiplier, j >= 64.
inline std::uint64_t mul_shift(std::uint64_t m, const std::array<std::uint64_t, 2>& mul, int j) {
  const Uint128 low = static_cast<Uint128>(m) * mul[0];
  const Uint128 high = static_cast<Uint128>(m) * mul[1];
  const Uint128 sum = high + (low >> 64);
  return static_cast<std::uint64_t>(sum >> (j - 64));
}

// Digits of v < 10^17 (Ryu's decimalLength17): most outputs have 15 to 17.
inline int decimal_length(std::uint64_t v) {
  if (v >= 10000000000000000ull) return 17;
  if (v >= 1000000000000000ull) return 16;
  if (v >= 100000000000000ull) return 15;
  if (v >= 10000000000000ull) return 14;
  if (v >= 1000000000000ull) return 13;
  if (v >= 100000000000ull) return 12;
  if (v >= 10000000000ull) return 11;
  if (v >= 1000000000ull) return 10;
  if (v >= 100000000ull) return 9;
  if (v >= 10000000ull) return 8;
  if (v >= 1000000ull) return 7;
  if (v >= 100000ull) return 6;
  if (v >= 10000ull) return 5;
  if (v >= 1000ull) return 4;
  if (v >= 100ull) return 3;
  if (v >= 10ull) return 2;
  return 1;
}

// The `length` digits of v, two at a time, into out[0, length).
inline void write_digits(std::uint64_t v, int length, char* out) {
  static constexpr char kPairs[] =
      "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
      "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
      "8081828384858687888990919293949596979899";
  char* p = out + length;
  // Above 8 digits, peel 8 at a time in 32-bit arithmetic.
  while (v >= 100000000u) {
    const std::uint64_t upper = v / 100000000u;
    std::uint32_t lower = static_cast<std::uint32_t>(v - upper * 100000000u);
    for (int pair = 0; pair < 4; ++pair) {
      const std::uint32_t two = lower % 100u;
      lower /= 100u;
      p -= 2;
      std::memcpy(p, kPairs + 2 * two, 2);
    }
    v = upper;
  }
  std::uint32_t rest = static_cast<std::uint32_t>(v);
  while (rest >= 100u) {
    const std::uint32_t two = rest % 100u;
    rest /= 100u;
    p -= 2;
    std::memcpy(p, kPairs + 2 * two, 2);
  }
  if (rest >= 10u) {
    p -= 2;
    std::memcpy(p, kPairs + 2 * rest, 2);
  } else {
    *--p = static_cast<char>('0' + rest);
  }
}

}  // namespace internal

// What std::to_chars(first, last, value) writes; last - first >= 32.
inline char* shortest_to_chars(char* first, char* last, double value) {
  const double magnitude = std::fabs(value);
  if (!(magnitude >= 1e-300 && magnitude < 9007199254740992.0)) return std::to_chars(first, last, value).ptr;
  std::uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof(bits));
  const bool negative = (bits >> 63) != 0;
  const std::uint64_t ieee_mantissa = bits & ((1ull << 52) - 1);
  const std::uint32_t ieee_exponent = static_cast<std::uint32_t>((bits >> 52) & 0x7ffu);

  // Ryu's d2d, the e2 < 0 half (every value below 2^53 has e2 <= -2).
  const int e2 = static_cast<int>(ieee_exponent) - 1023 - 52 - 2;
  const std::uint64_t m2 = (1ull << 52) | ieee_mantissa;
  const bool accept_bounds = (m2 & 1) == 0;
  const std::uint64_t mv = 4 * m2;
  const std::uint32_t mm_shift = ieee_mantissa != 0 || ieee_exponent <= 1;
  const std::uint32_t q = internal::log10_pow5(-e2) - (-e2 > 1);
  const int e10 = static_cast<int>(q) + e2;
  const int i = -e2 - static_cast<int>(q);
  const int k = internal::pow5bits(i) - internal::kPow5Bitcount;
  const int j = static_cast<int>(q) - k;
  const auto& mul = internal::pow5_table().split[static_cast<std::size_t>(i)];
  std::uint64_t vr = internal::mul_shift(4 * m2, mul, j);
  std::uint64_t vp = internal::mul_shift(4 * m2 + 2, mul, j);
  std::uint64_t vm = internal::mul_shift(4 * m2 - 1 - mm_shift, mul, j);
  bool vm_trailing_zeros = false, vr_trailing_zeros = false;
  if (q <= 1) {
    vr_trailing_zeros = true;
    if (accept_bounds) {
      vm_trailing_zeros = mm_shift == 1;
    } else {
      --vp;
    }
  } else if (q < 63) {
    vr_trailing_zeros = (mv & ((1ull << q) - 1)) == 0;
  }
  int removed = 0;
  std::uint64_t output = 0;
  if (vm_trailing_zeros || vr_trailing_zeros) {
    std::uint32_t last_removed = 0;
    while (vp / 10 > vm / 10) {
      vm_trailing_zeros &= vm % 10 == 0;
      vr_trailing_zeros &= last_removed == 0;
      last_removed = static_cast<std::uint32_t>(vr % 10);
      vr /= 10;
      vp /= 10;
      vm /= 10;
      ++removed;
    }
    if (vm_trailing_zeros) {
      while (vm % 10 == 0) {
        vr_trailing_zeros &= last_removed == 0;
        last_removed = static_cast<std::uint32_t>(vr % 10);
        vr /= 10;
        vp /= 10;
        vm /= 10;
        ++removed;
      }
    }
    if (vr_trailing_zeros && last_removed == 5 && vr % 2 == 0) last_removed = 4;  // round half to even
    output = vr + ((vr == vm && (!accept_bounds || !vm_trailing_zeros)) || last_removed >= 5);
  } else {
    bool round_up = false;
    if (vp / 100 > vm / 100) {
      round_up = vr % 100 >= 50;
      vr /= 100;
      vp /= 100;
      vm /= 100;
      removed += 2;
    }
    while (vp / 10 > vm / 10) {
      round_up = vr % 10 >= 5;
      vr /= 10;
      vp /= 10;
      vm /= 10;
      ++removed;
    }
    output = vr + (vr == vm || round_up);
  }
  const int exponent = e10 + removed;  // value = output * 10^exponent

  // std::to_chars's choice: %f or %e, whichever is shorter, %f on a tie.
  const int length = internal::decimal_length(output);
  const int scientific_exponent = exponent + length - 1;
  const int magnitude_digits = std::abs(scientific_exponent) >= 100 ? 3 : 2;
  const int scientific_length = length + (length > 1 ? 1 : 0) + 2 + magnitude_digits;
  const int fixed_length = exponent >= 0 ? length + exponent : (length > -exponent ? length + 1 : 2 - exponent);
  char digits[20];
  internal::write_digits(output, length, digits);
  char* p = first;
  if (negative) *p++ = '-';
  if (fixed_length <= scientific_length) {
    if (exponent >= 0) {
      std::memcpy(p, digits, static_cast<std::size_t>(length));
      p += length;
      for (int z = 0; z < exponent; ++z) *p++ = '0';
    } else if (length > -exponent) {
      const int integer_digits = length + exponent;
      std::memcpy(p, digits, static_cast<std::size_t>(integer_digits));
      p += integer_digits;
      *p++ = '.';
      std::memcpy(p, digits + integer_digits, static_cast<std::size_t>(-exponent));
      p += -exponent;
    } else {
      *p++ = '0';
      *p++ = '.';
      for (int z = 0; z < -exponent - length; ++z) *p++ = '0';
      std::memcpy(p, digits, static_cast<std::size_t>(length));
      p += length;
    }
    return p;
  }
  *p++ = digits[0];
  if (length > 1) {
    *p++ = '.';
    std::memcpy(p, digits + 1, static_cast<std::size_t>(length - 1));
    p += length - 1;
  }
  *p++ = 'e';
  *p++ = scientific_exponent < 0 ? '-' : '+';
  int e = std::abs(scientific_exponent);
  if (e >= 100) {
    *p++ = static_cast<char>('0' + e / 100);
    e %= 100;
  }
  *p++ = static_cast<char>('0' + e / 10);
  *p++ = static_cast<char>('0' + e % 10);
  return p;
}

// Clinger's fast path for -?digits[.digits]; see above. False: not this
// form, or outside the exact range (the caller falls back to from_chars).
inline bool parse_plain_decimal(std::string_view text, double* value) {
  static constexpr double kPowers[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                       1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  const char* p = text.data();
  const char* const end = p + text.size();
  const bool negative = p != end && *p == '-';
  if (negative) ++p;
  std::uint64_t mantissa = 0;
  int digits = 0, decimals = 0;
  bool point = false;
  for (; p != end; ++p) {
    const char c = *p;
    if (c >= '0' && c <= '9') {
      if (mantissa != 0 || c != '0') ++digits;  // significant digits
      if (digits > 15) return false;            // mantissa may pass 2^53: let from_chars decide
      mantissa = mantissa * 10 + static_cast<std::uint64_t>(c - '0');
      decimals += point ? 1 : 0;
    } else if (c == '.' && !point) {
      point = true;
    } else {
      return false;
    }
  }
  const std::size_t length = static_cast<std::size_t>(end - text.data()) - (negative ? 1u : 0u) - (point ? 1u : 0u);
  if (length == 0 || decimals > 22) return false;  // "", "-", ".", "-."
  const double magnitude = static_cast<double>(mantissa) / kPowers[decimals];
  *value = negative ? -magnitude : magnitude;
  return true;
}

// The fallback for what parse_plain_decimal declines: std::from_chars over
// the whole of `text`, except that a value below the smallest normal double
// (1e-320, say) is read as strtod reads it, the nearest subnormal double (or
// zero), where from_chars reports it out of range. Subnormal cells are legal
// numbers a logger may write; refusing them would make a log unreadable for
// a value that is, to the filter, zero. Returns false for anything that is
// not a number, and for a value too large for a double (1e400): *overflow
// tells the two apart.
inline bool parse_general(std::string_view text, double* value, bool* overflow) {
  *overflow = false;
  const char* const end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, *value);
  if (result.ptr != end) return false;
  if (result.ec == std::errc()) return true;
  if (result.ec != std::errc::result_out_of_range) return false;
  char buffer[400];
  if (text.size() >= sizeof(buffer)) return false;
  std::memcpy(buffer, text.data(), text.size());
  buffer[text.size()] = '\0';
  const double v = std::strtod(buffer, nullptr);
  if (std::isinf(v)) {
    *overflow = true;
    return false;
  }
  *value = v;
  return true;
}

}  // namespace number_text
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_NUMBER_TEXT_H_
