#include "skidimm/time_origin.h"

#include <cstdio>

namespace skidimm {

double time_origin(double first_t) {
  constexpr double kClockTime = 86400.0;  // s: times above a day are a clock's, not time from a log's start
  return first_t > kClockTime ? first_t : 0.0;
}

std::string time_origin_text(double origin) {
  char text[40];
  std::snprintf(text, sizeof(text), "%.15g", origin);
  return text;
}

}  // namespace skidimm
