// The Husky geometry the STC plugin tests build their banks and expected
// values from (the r and b of configs/stc_*.yaml).
#ifndef SKIDIMM_TESTS_PLUGINS_HUSKY_GEOMETRY_H_
#define SKIDIMM_TESTS_PLUGINS_HUSKY_GEOMETRY_H_

namespace skidimm_test {

constexpr double kHuskyWheelRadius = 0.165;  // m
constexpr double kHuskyTrack = 0.555;        // m, between the treads' centres

}  // namespace skidimm_test

#endif  // SKIDIMM_TESTS_PLUGINS_HUSKY_GEOMETRY_H_
