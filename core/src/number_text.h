// Doubles to text and back, the way std::to_chars / std::from_chars do it,
// faster for the numbers logs are made of. Private to core (csv.cc,
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

// The 8 digits of x < 10^8, leading zeros included, into out[0, 8): all
// eight at once in one 64-bit word (SWAR), the two halves of x, then the two
// pairs of each half, then the two digits of each pair, each split by a
// multiplication that cannot carry between lanes. The lanes' order in the
// word is the digits' order on a little-endian machine.
inline void write_eight_digits(std::uint32_t x, char* out) {
  if (__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__) {
    // [x / 10^4, x % 10^4] in 32-bit lanes.
    std::uint64_t lanes = (x / 10000u) | static_cast<std::uint64_t>(x % 10000u) << 32;
    // Each y < 10^4 to [y / 100, y % 100] in 16-bit lanes: y * 10486 >> 20 = y / 100.
    std::uint64_t high = ((lanes * 10486u) >> 20) & 0x0000007f0000007full;
    lanes = high | (lanes - 100u * high) << 16;
    // Each z < 100 to [z / 10, z % 10] in bytes: z * 103 >> 10 = z / 10.
    high = ((lanes * 103u) >> 10) & 0x000f000f000f000full;
    lanes = high | (lanes - 10u * high) << 8;
    lanes |= 0x3030303030303030ull;
    std::memcpy(out, &lanes, 8);
    return;
  }
  for (int k = 7; k >= 0; --k) {
    out[k] = static_cast<char>('0' + x % 10u);
    x /= 10u;
  }
}

// The `length` digits of v (length = decimal_length(v) <= 17) into
// out[0, length): eight at a time from the end, the leading ones from the
// last eight-digit block's end.
inline void write_digits(std::uint64_t v, int length, char* out) {
  char* p = out + length;
  while (length > 8) {
    const std::uint64_t upper = v / 100000000u;
    p -= 8;
    write_eight_digits(static_cast<std::uint32_t>(v - upper * 100000000u), p);
    v = upper;
    length -= 8;
  }
  char block[8];
  write_eight_digits(static_cast<std::uint32_t>(v), block);
  std::memcpy(out, block + 8 - length, static_cast<std::size_t>(length));
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
