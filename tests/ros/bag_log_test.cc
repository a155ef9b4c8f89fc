// A bag as the tables of a log (bag_log.h): the topics a bank's columns
// name, their fields by path, the time by header stamp or log time, and the
// errors a user meets, on bags written by the npm packages.
#include "ros/bag_log.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>

#include "core/temp_files.h"
#include "ros/crc32.h"
#include "ros/ros_fixtures.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/log_reader.h"
#include "skidimm/io/ros/bag_info.h"
#include "skidimm/io/ros/bag_reader.h"

namespace skidimm {
namespace ros {
namespace {

using skidimm_test::read_expected;
using skidimm_test::ros_fixture;
using skidimm_test::same_double;
using skidimm_test::test_directory;
using skidimm_test::write_file;

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const LogError& e) {
    return e.what();
  }
  return "";
}

TEST(BagLog, ATableOfTheTopicABankNamesReadsItsFieldsAndTime) {
  const auto expected = read_expected(ros_fixture("all_types.expected"));
  auto tables = open_bag_tables(ros_fixture("all_types.mcap"), {"mean(/all_types.f64)", "/all_types.velocity[left]"});
  ASSERT_EQ(tables.size(), 1u);
  LogTable& t = *tables[0];
  EXPECT_EQ(t.name(), "all_types.mcap:/all_types");
  EXPECT_EQ(t.column("/other.x"), -1);
  EXPECT_EQ(t.column("time"), -1);
  const int log_time = t.column("log_time");
  const int stamp = t.column("header.stamp");  // the type has no header: its log time
  const int f64 = t.column("/all_types.f64");
  const int left = t.column("/all_types.velocity[left]");
  const int label = t.column("/all_types.inner[1].label");
  long n = 0;
  while (t.next_row()) {
    ++n;
    double value = 0.0;
    ASSERT_EQ(t.number(log_time, &value), LogTable::Cell::kNumber);
    // The nearest double to 1700000000 + n/100 s, as a CSV's decimal text would read.
    char decimal[40];
    std::snprintf(decimal, sizeof(decimal), "%ld.%02ld", 1700000000L + n / 100, n % 100);
    EXPECT_EQ(value, std::strtod(decimal, nullptr)) << decimal;
    double same = 0.0;
    t.number(stamp, &same);
    EXPECT_EQ(same, value);
    const auto& want = expected.at(n);
    const LogTable::Cell cell = t.number(f64, &value);
    EXPECT_TRUE(same_double(value, want.at("f64").number));
    EXPECT_EQ(cell, LogTable::Cell::kNumber);
    const LogTable::Cell named = t.number(left, &value);
    EXPECT_TRUE(same_double(value, want.at("velocity[left]").number));
    EXPECT_EQ(named, std::isnan(want.at("velocity[left]").number) ? LogTable::Cell::kMissing : LogTable::Cell::kNumber);
    EXPECT_EQ(t.text(label), want.at("inner[1].label").text);
  }
  EXPECT_EQ(n, 120);
}

TEST(BagLog, TheTimeOfATypeWithAHeaderIsItsStamp) {
  // The Imu's stamps differ from its log times (2 s + 10 ms steps).
  auto mcap_tables = open_bag_tables(ros_fixture("mixed.mcap"), {"/imu/data.angular_velocity.z"});
  ASSERT_EQ(mcap_tables.size(), 1u);
  const int z = mcap_tables[0]->column("/imu/data.angular_velocity.z");
  const int t = mcap_tables[0]->column("header.stamp");
  const auto expected = read_expected(ros_fixture("mixed_imu.expected"));
  long n = 0;
  while (mcap_tables[0]->next_row()) {
    ++n;
    double value = 0.0;
    mcap_tables[0]->number(z, &value);
    EXPECT_TRUE(same_double(value, expected.at(n).at("angular_velocity.z").number));
    mcap_tables[0]->number(t, &value);
    EXPECT_TRUE(same_double(value, expected.at(n).at("header.stamp").number)) << value;
  }
  EXPECT_EQ(n, 4);
}

TEST(BagLog, ErrorsNameTheBagTheTopicAndWhatExists) {
  const auto dir = test_directory();
  // A topic the bag does not have.
  std::string message = error_of([] { open_bag_tables(ros_fixture("mixed.mcap"), {"/imu/dta.angular_velocity.z"}); });
  EXPECT_NE(message.find("mixed.mcap: the bank's column \"/imu/dta.angular_velocity.z\" names topic /imu/dta, which "
                         "this bag does not have; its topics: /imu/data (sensor_msgs/msg/Imu)"),
            std::string::npos)
      << message;
  // No topic at all (a CSV bank on a bag).
  message = error_of([] { open_bag_tables(ros_fixture("mixed.mcap"), {"velL", "mean(wz)"}); });
  EXPECT_NE(message.find("no column of the bank names a topic of this bag"), std::string::npos) << message;
  // A field the type lacks: the paths it has.
  message = error_of([] {
    auto tables = open_bag_tables(ros_fixture("mixed.mcap"), {"/imu/data.angular_velocity.w"});
    tables[0]->column("/imu/data.angular_velocity.w");
  });
  EXPECT_NE(message.find("mixed.mcap: topic /imu/data: no column '/imu/data.angular_velocity.w'"), std::string::npos)
      << message;
  EXPECT_NE(message.find("Its columns: /imu/data.header.stamp, /imu/data.header.frame_id"), std::string::npos)
      << message;
  // Messages not in CDR.
  message = error_of([] { open_bag_tables(ros_fixture("mixed.mcap"), {"/json.data"}); });
  EXPECT_NE(message.find("topic /json (std_msgs/msg/String): messages encoded as 'json'; skidimm reads ROS 2 "
                         "messages in CDR"),
            std::string::npos)
      << message;
  // A definition stored in a form skidimm does not read, for a type it does not bundle.
  message = error_of([] { open_bag_tables(ros_fixture("idl.mcap"), {"/custom.data"}); });
  EXPECT_NE(message.find("topic /custom (my_msgs/msg/Custom): the bag stores its definition as 'ros2idl', which "
                         "skidimm does not read"),
            std::string::npos)
      << message;
  // ... while a bundled type is read with the bundled definition.
  EXPECT_EQ(open_bag_tables(ros_fixture("idl.mcap"), {"/imu/data.angular_velocity.z"}).size(), 1u);
  // A .db3 without its metadata.yaml.
  const auto lone = dir / "lone";
  std::filesystem::create_directories(lone);
  write_file(lone / "drive_0.db3", "");
  message = error_of([&] { BagReader::open(lone / "drive_0.db3"); });
  EXPECT_NE(message.find("drive_0.db3: no metadata.yaml beside this .db3 file"), std::string::npos) << message;
  EXPECT_NE(message.find("ros2 bag reindex"), std::string::npos) << message;
  // ... and its directory, as a recording stopped hard leaves it: said as such, where it read as a folder of runs.
  EXPECT_NE(BagReader::unfinished_recording(lone).find("it holds a bag's files (drive_0.db3) but no metadata.yaml"),
            std::string::npos);
  message = error_of([&] { CsvReader reader(lone); });
  EXPECT_NE(message.find("lone: is a directory, not a ROS 2 bag: it holds a bag's files (drive_0.db3)"),
            std::string::npos)
      << message;
  EXPECT_EQ(BagReader::unfinished_recording(dir), "") << "no bag files in it";
  // A split the metadata does not list (written after it): refused, where the bag read as listed ended early.
  const auto split = dir / "split";
  std::filesystem::create_directories(split);
  std::filesystem::copy_file(ros_fixture("all_types.mcap"), split / "split_0.mcap");
  std::filesystem::copy_file(ros_fixture("all_types.mcap"), split / "split_1.mcap");
  write_file(split / "metadata.yaml",
             "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n"
             "  relative_file_paths: [split_0.mcap]\n  compression_format: \"\"\n  compression_mode: \"\"\n");
  message = error_of([&] { BagReader::open(split); });
  EXPECT_NE(message.find("metadata.yaml: does not list split_1.mcap, a bag file in its directory"), std::string::npos)
      << message;
  write_file(split / "metadata.yaml",
             "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n"
             "  relative_file_paths: [split_0.mcap, split_1.mcap]\n  compression_format: \"\"\n"
             "  compression_mode: \"\"\n");
  EXPECT_NE(BagReader::open(split), nullptr);
}

// A bag's stamps are read in seconds: a bank whose CSV time column is in
// another unit (columns.time_unit) is refused on a bag, naming both.
TEST(BagLog, ATimeUnitOtherThanSecondsIsRefusedOnABag) {
  BankConfig bank;
  bank.file = "bank.yaml";
  bank.columns.time = "header.stamp";
  bank.columns.time_units_per_second = 1e3;
  bank.columns.time_unit_name = "ms";
  std::string message;
  try {
    LogReader reader(bank, {LogFile{ros_fixture("mixed.mcap")}}, bank.sampling);
  } catch (const Error& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("bank.yaml: columns.time_unit: ms is the unit of a CSV file's time column; "),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("mixed.mcap is a ROS 2 bag, whose stamps are read in seconds"), std::string::npos) << message;
}

TEST(BagLog, AMessageThatDoesNotDecodeEndsItsTopicAfterTheRowsBeforeIt) {
  const auto dir = test_directory();
  std::string bytes = skidimm_test::read_file(ros_fixture("mixed.mcap"));
  // The third marker's string length: make it run past its message.
  const auto at = bytes.find("SKIDIMM_MARKER_2");
  ASSERT_NE(at, std::string::npos);
  bytes[at - 2] = '\x7f';
  // Its chunk (uncompressed) records a CRC of its records: recompute it, so
  // that the message itself is what is wrong.
  std::size_t chunk = 0;
  for (const auto& [opcode, offset] : skidimm_test::records_of(bytes)) {
    if (opcode == 6 && offset < at) chunk = offset;
  }
  ASSERT_GT(chunk, 0u);
  std::uint64_t records_size = 0;
  std::memcpy(&records_size, &bytes[chunk + 9 + 28 + 4], 8);  // after the fixed fields and an empty compression
  const std::uint32_t crc = crc32(0, &bytes[chunk + 9 + 28 + 4 + 8], records_size);
  std::memcpy(&bytes[chunk + 9 + 24], &crc, 4);
  write_file(dir / "bad_message.mcap", bytes);
  long rows = 0;
  const std::string message = error_of([&] {
    auto tables = open_bag_tables(dir / "bad_message.mcap", {"/marker.data"});
    tables[0]->column("log_time");
    const int data = tables[0]->column("/marker.data");
    while (tables[0]->next_row()) {
      EXPECT_EQ(tables[0]->text(data), "SKIDIMM_MARKER_" + std::to_string(rows));
      ++rows;
    }
  });
  EXPECT_EQ(rows, 2) << "the rows before the bad message";
  EXPECT_NE(message.find("bad_message.mcap: topic /marker, message 3 (log time 2.020000001 s, std_msgs/msg/String): "
                         "cannot decode its CDR: the message ends at byte"),
            std::string::npos)
      << message;
}

// A bank of one state, read from a bag: the wheel input and the state's
// measurement from the columns given, time from header.stamp.
BankConfig one_state_bank(const std::string& input, const std::string& measurement) {
  BankConfig bank;
  bank.file = "bank.yaml";
  bank.state_names = {"x"};
  bank.input_names = {"wheel"};
  bank.measurement.names = {"x"};
  bank.columns.time = "header.stamp";
  bank.columns.inputs = {input};
  bank.columns.measurements = {measurement};
  return bank;
}

// An input read from a sequence's entry selected by a name no message has
// (a joint name of another robot): the log gives no step, and the reader
// says which column never had a value and where the names are listed. It
// said only that no step came.
TEST(BagLog, AnInputSelectedByANameNoMessageHasIsNamed) {
  BankConfig bank = one_state_bank("/all_types.velocity[front_left_wheel]", "/all_types.f64");
  LogReader reader(bank, {LogFile{ros_fixture("all_types.mcap")}});
  LogSample sample;
  try {
    reader.next(&sample);
    ADD_FAILURE() << "expected an error";
  } catch (const LogError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("all_types.mcap: no step: column '/all_types.velocity[front_left_wheel]' (input wheel) had "
                           "no value in any of the log's 120 row(s), and a step needs every input (a sequence's "
                           "entry selected by name, [NAME], has a value only in messages that have that name: "
                           "`skidimm bag FILE` lists the names the bag has)"),
              std::string::npos)
        << message;
  }
  // A name the messages have gives steps.
  bank.columns.inputs = {"/all_types.velocity[left]"};
  LogReader named(bank, {LogFile{ros_fixture("all_types.mcap")}});
  EXPECT_TRUE(named.next(&sample));
}

// A topic that several publishers share (a JointState of the wheels, and
// one of an arm whose clock runs ahead): a message with none of the fields
// the bank reads from the topic is not a row of it. As an empty row it
// stopped the log, its stamp going back from the arm's to the wheels'.
TEST(BagLog, AMessageOfAnotherPublisherWithNoneOfTheFieldsReadIsNotARow) {
  BankConfig bank = one_state_bank("/joint_states.velocity[left]", "/joint_states.effort[left]");
  const auto expected = read_expected(ros_fixture("two_publishers.expected"));
  ASSERT_EQ(expected.size(), 20u);
  LogReader reader(bank, {LogFile{ros_fixture("two_publishers.mcap")}});
  LogSample sample;
  long k = 0;
  while (reader.next(&sample)) {
    ++k;
    ASSERT_LE(k, 20);
    const auto& row = expected.at(k);
    EXPECT_TRUE(same_double(sample.t, row.at("header.stamp").number)) << k;
    EXPECT_TRUE(same_double(sample.u[0], row.at("velocity[left]").number)) << k;
    EXPECT_TRUE(same_double(sample.z[0], row.at("effort[left]").number)) << k;
  }
  EXPECT_EQ(k, 20) << "every wheel message a step, no arm message one";
  // Every field named by a joint no message has: the messages are there, the name is not (not "no message").
  bank.columns.inputs = {"/joint_states.velocity[front_left_wheel]"};
  bank.columns.measurements = {"/joint_states.effort[front_left_wheel]"};
  const std::string misnamed = error_of([&] {
    LogReader named(bank, {LogFile{ros_fixture("two_publishers.mcap")}});
    named.next(&sample);
  });
  EXPECT_NE(misnamed.find("two_publishers.mcap: topic /joint_states: none of its 40 message(s) has a field the bank "
                          "reads from it (/joint_states.velocity[front_left_wheel], "
                          "/joint_states.effort[front_left_wheel])"),
            std::string::npos)
      << misnamed;
  EXPECT_NE(misnamed.find("`skidimm bag FILE` lists the names the bag has"), std::string::npos) << misnamed;
  // `skidimm bag` lists every publisher's joints, not the first message's alone (the arm's).
  const BagInfo info = describe_bag(ros_fixture("two_publishers.mcap"));
  ASSERT_EQ(info.topics.size(), 1u);
  const std::vector<std::string>& columns = info.topics[0].columns;
  for (const char* column :
       {"/joint_states.velocity[arm_joint]", "/joint_states.velocity[left]", "/joint_states.effort[right]"}) {
    EXPECT_NE(std::find(columns.begin(), columns.end(), column), columns.end()) << column;
  }
}

// A topic whose stamps are on another clock than the others' (a driver that
// stamps from its own start beside one in Unix time) is said as what it most
// likely is, with the bank setting that reads every topic by one clock; the
// time offset of a file, which moves the whole bag, cannot mend it.
// skidimm bag says how a file is read: through its chunk index, or by a scan
// where a summary has no chunk to index (a bag without a message, messages
// outside chunks), which is not a file that lost its summary.
TEST(BagInfo, SaysWhetherTheFileHasASummary) {
  EXPECT_EQ(describe_bag(ros_fixture("all_types.mcap")).storage, "mcap (zstd chunks, indexed)");
  EXPECT_EQ(describe_bag(ros_fixture("all_types_no_summary.mcap")).storage,
            "mcap (zstd chunks, no summary (read by a scan))");
  EXPECT_EQ(describe_bag(ros_fixture("all_types_unchunked.mcap")).storage,
            "mcap (no chunks, with a summary, read by a scan)");
  const BagInfo empty = describe_bag(ros_fixture("empty.mcap"));
  EXPECT_EQ(empty.storage, "mcap (no chunks, with a summary, read by a scan)");
  EXPECT_EQ(empty.messages, 0u);
  EXPECT_TRUE(empty.problem.empty()) << empty.problem;
}

TEST(BagLog, ATopicOnAnotherClockNamesItAndTheRecordersClock) {
  BankConfig bank = one_state_bank("/joint_states.velocity[left]", "/imu/data.angular_velocity.z");
  const std::string message = error_of([&] {
    LogReader reader(bank, {LogFile{ros_fixture("two_clocks.mcap")}});
    LogSample sample;
    while (reader.next(&sample)) {
    }
  });
  EXPECT_NE(message.find("two_clocks.mcap: topic /imu/data: none of its 20 row(s) was used"), std::string::npos)
      << message;
  EXPECT_NE(message.find("columns.time: log_time reads every topic by the recorder's clock"), std::string::npos)
      << message;
  EXPECT_EQ(message.find("FILE@OFFSET"), std::string::npos) << message;
  // A topic without a message is said in a bag's terms (it was a CSV file's "header but no data rows").
  const std::string silent = error_of([&] {
    LogReader reader(bank, {LogFile{ros_fixture("silent_topic.mcap")}});
    LogSample sample;
    while (reader.next(&sample)) {
    }
  });
  EXPECT_NE(silent.find("silent_topic.mcap: topic /imu/data: the topic has no message: its columns "
                        "/imu/data.angular_velocity.z, which the bank uses, would never have a value"),
            std::string::npos)
      << silent;
  // By the recorder's clock the same bag reads.
  bank.columns.time = "log_time";
  LogReader reader(bank, {LogFile{ros_fixture("two_clocks.mcap")}});
  LogSample sample;
  long steps = 0;
  while (reader.next(&sample)) ++steps;
  EXPECT_GT(steps, 10);
}

}  // namespace
}  // namespace ros
}  // namespace skidimm
