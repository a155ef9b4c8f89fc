// What a table or a figure counts time from. A log stamped by a clock (epoch
// seconds, a ROS 2 bag's header.stamp) is shown from its first time, which
// the table or the axis names: from 0, its minutes would be a sliver at the
// end of 1.7e9 s, and their digits would fill a table and hide the durations.
#ifndef SKIDIMM_TIME_ORIGIN_H_
#define SKIDIMM_TIME_ORIGIN_H_

#include <string>

namespace skidimm {

// `first_t` where it is a clock's time (above a day), else 0.
double time_origin(double first_t);

// The origin with every digit a person needs to find it in the log
// (1718000000.5, where the shortest text would be 1.7180000005e+09).
std::string time_origin_text(double origin);

}  // namespace skidimm

#endif  // SKIDIMM_TIME_ORIGIN_H_
