#include "skidimm/time_origin.h"

#include <charconv>
#include <cmath>

#include "skidimm/io/csv.h"

namespace skidimm {

double time_origin(double first_t) {
  constexpr double kClockTime = 86400.0;  // s: times above a day are a clock's, not time from a log's start
  return first_t > kClockTime ? first_t : 0.0;
}

std::string time_text(double t) {
  if (!std::isfinite(t) || std::abs(t) >= 1e15) return CsvWriter::format(t);
  char buffer[64];
  const auto written = std::to_chars(buffer, buffer + sizeof(buffer), t, std::chars_format::fixed);
  return written.ec == std::errc() ? std::string(buffer, written.ptr) : CsvWriter::format(t);
}

}  // namespace skidimm
