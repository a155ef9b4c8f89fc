// What a table or a figure counts time from, and how a time is written for a
// person. A log stamped by a clock (epoch
// seconds, a ROS 2 bag's header.stamp) is shown from its first time, which
// the table or the axis names: from 0, its minutes would be a sliver at the
// end of 1.7e9 s, and their digits would fill a table and hide the durations.
#ifndef SKIDIMM_TIME_ORIGIN_H_
#define SKIDIMM_TIME_ORIGIN_H_

#include <string>

namespace skidimm {

// `first_t` where it is a clock's time (above a day), else 0.
double time_origin(double first_t);

// A time with every digit a person needs to find it in the log, never in
// exponent form below 1e15 s: 1718000000.5, where the shortest text would be
// 1.7180000005e+09, and a Unix time in ms (1700000000000, not 1.7e+12)
// written like the next row's 1700000000154. The shortest fixed text that
// reads back to the same double; beyond 1e15 s, or not finite, the
// shortest text.
std::string time_text(double t);

}  // namespace skidimm

#endif  // SKIDIMM_TIME_ORIGIN_H_
