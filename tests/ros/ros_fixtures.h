// The bags written for the reader tests by tests/ros/write_fixture_bags.cjs
// (@mcap/core and @foxglove/rosmsg2-serialization), in the directory the
// ctest fixture RosFixtureBags fills, and the values they hold.
#ifndef SKIDIMM_TESTS_ROS_ROS_FIXTURES_H_
#define SKIDIMM_TESTS_ROS_ROS_FIXTURES_H_

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace skidimm_test {

inline std::filesystem::path ros_fixture(const std::string& name) {
  return std::filesystem::path(SKIDIMM_ROS_FIXTURE_DIR) / name;
}

// One expected field of one message: a number (NaN: the message lacks it) or a text.
struct ExpectedValue {
  bool is_text = false;
  double number = 0.0;
  std::string text;
};

// message (1-based) -> path -> value, from a ".expected" file.
inline std::map<long, std::map<std::string, ExpectedValue>> read_expected(const std::filesystem::path& file) {
  std::map<long, std::map<std::string, ExpectedValue>> out;
  std::ifstream in(file);
  EXPECT_TRUE(in) << file;
  std::string line;
  while (std::getline(in, line)) {
    const auto tab1 = line.find('\t');
    const auto tab2 = line.find('\t', tab1 + 1);
    if (tab1 == std::string::npos || tab2 == std::string::npos) continue;
    ExpectedValue v;
    const std::string value = line.substr(tab2 + 1);
    if (value.rfind("text:", 0) == 0) {
      v.is_text = true;
      v.text = value.substr(5);
    } else if (value == "nan") {
      v.number = std::nan("");
    } else {
      v.number = std::strtod(value.c_str(), nullptr);  // correctly rounded, as JavaScript printed it
    }
    out[std::stol(line.substr(0, tab1))][line.substr(tab1 + 1, tab2 - tab1 - 1)] = v;
  }
  return out;
}

// Bit for bit: the same double (NaN equal to NaN, -0 not equal to 0).
inline bool same_double(double a, double b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  return a == b && std::signbit(a) == std::signbit(b);
}

// The top-level records of an MCAP file: (opcode, offset), walked by their
// length fields (the test's own reading of the format, kept minimal).
inline std::vector<std::pair<int, std::size_t>> records_of(const std::string& bytes) {
  std::vector<std::pair<int, std::size_t>> out;
  std::size_t at = 8;
  while (at + 9 <= bytes.size()) {
    std::uint64_t length = 0;
    std::memcpy(&length, &bytes[at + 1], 8);
    out.emplace_back(static_cast<unsigned char>(bytes[at]), at);
    if (length > bytes.size() - at - 9) break;
    at += 9 + length;
  }
  return out;
}

inline std::size_t first_record(const std::string& bytes, int opcode) {
  for (const auto& [op, at] : records_of(bytes)) {
    if (op == opcode) return at;
  }
  ADD_FAILURE() << "no record of opcode " << opcode;
  return 0;
}

}  // namespace skidimm_test

#endif  // SKIDIMM_TESTS_ROS_ROS_FIXTURES_H_
