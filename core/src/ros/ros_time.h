// ROS time stamps (builtin_interfaces/msg/Time: int32 sec, uint32 nanosec;
// bag log times: uint64 nanoseconds) as the seconds skidimm steps on.
//
// Below 2^53 ns (104 days: a clock that starts at zero, as simulated and
// converted logs do) the result is the double nearest to ns / 1e9, exactly
// what reading the same decimal seconds from a CSV gives ("0.01" and 10 ms
// are the same double). Epoch times are rounded through long double, within
// a quarter of a microsecond at today's dates (a double's resolution there).
#ifndef SKIDIMM_CORE_SRC_ROS_ROS_TIME_H_
#define SKIDIMM_CORE_SRC_ROS_ROS_TIME_H_

#include <cstdint>

namespace skidimm {
namespace ros {

inline double seconds_from_nanoseconds(std::int64_t ns) {
  constexpr std::int64_t kExact = std::int64_t{1} << 53;
  if (ns > -kExact && ns < kExact) return static_cast<double>(ns) / 1e9;
  return static_cast<double>(static_cast<long double>(ns) / 1e9L);
}

inline double seconds_from_stamp(std::int32_t sec, std::uint32_t nanosec) {
  return seconds_from_nanoseconds(static_cast<std::int64_t>(sec) * 1000000000 + static_cast<std::int64_t>(nanosec));
}

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_ROS_TIME_H_
