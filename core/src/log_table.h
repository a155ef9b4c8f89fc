// LogTable: one time-ordered table of a log, read row by row, as LogReader
// (log_reader.h) merges them: a CSV file, or one topic of a ROS 2 bag
// (ros/bag_log.h), whose messages are its rows and whose field paths are its
// columns.
#ifndef SKIDIMM_CORE_SRC_LOG_TABLE_H_
#define SKIDIMM_CORE_SRC_LOG_TABLE_H_

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "skidimm/errors.h"

namespace skidimm {

class LogTable {
 public:
  virtual ~LogTable() = default;
  LogTable(const LogTable&) = delete;
  LogTable& operator=(const LogTable&) = delete;

  // The file the table is read from.
  virtual const std::filesystem::path& path() const = 0;
  // How messages name the table briefly: "imu_03.csv", "drive.mcap:/imu/data".
  virtual std::string name() const = 0;
  // The columns, for the "columns present" of a message (a bag topic: the
  // paths a bank can use, arrays with their index range).
  virtual std::vector<std::string> columns_present() const = 0;
  // The index of column `name`, or -1 when the table has none. A bag topic
  // resolves field paths when asked (and throws LogError naming the paths it
  // has when `name` is its topic with a field it lacks). Called before the
  // first next_row().
  virtual int column(const std::string& name) = 0;

  // Reads the next row. Returns false at the end. Throws LogError.
  virtual bool next_row() = 0;

  enum class Cell { kNumber, kMissing, kNotANumber };
  // A cell of the current row as a number: kNumber with *value, kMissing
  // (an empty CSV cell, a name a JointState message lacks) with NaN, or
  // kNotANumber (text that is no number; error_at_row(describe_cell) says so).
  virtual Cell number(int column, double* value) const = 0;
  // A cell as text (truth labels), valid until the next row is read.
  virtual std::string_view text(int column) const = 0;

  // An error about a cell of the current row that is not what `expected`
  // says: "<file>:<line>: column 3 ('velL'): expected ..., got 'abc'".
  virtual LogError cell_error(int column, const std::string& expected) const = 0;
  // An error about the current row: "<file>:<line>: message" for a CSV,
  // "<bag>: topic /imu/data, message 17 (log time ... s): message" for a bag.
  virtual LogError error_at_row(const std::string& message) const = 0;
  // An error about the table itself (its header, its columns).
  virtual LogError error(const std::string& message) const = 0;

  // For progress: bytes read so far and in all (0 when unknown, a pipe).
  virtual std::uintmax_t bytes_read() const = 0;
  virtual std::uintmax_t size() const = 0;

  // Records read that are not rows of the table: a bag topic's messages
  // with none of the fields the bank reads from it (another publisher's, or
  // every one when the bank names a field by a name no message has).
  virtual long records_without_fields() const { return 0; }

 protected:
  LogTable() = default;
};

}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_LOG_TABLE_H_
