// LiveLog: a log that arrives while it is read, row by row from the program
// that records it (a robot's sensor callbacks, a ROS 2 node), made into the
// filter's steps exactly as LogReader (log_reader.h) makes them from the same
// rows in files.
//
// A live log is a set of tables, one per sensor stream, each with its own
// columns, the bank's time column among them: the files of a multi-rate log
// (sampling.join: time), e.g. wheel speeds and currents at 6.5 Hz in one and
// the IMU at 100 Hz in another. The program pushes each table's rows as they
// come, in time order within the table (the tables need not be pushed in
// time order with each other), and takes the steps the rows so far complete:
//
//   LiveLog live(bank, {{"wheels", {"time", "velL", "velR", "curL", "curR"}},
//                       {"imu", {"time", "ax", "ay", "az", "wx", "wy", "wz"}}});
//   const int imu = live.table("imu");
//   // in the IMU's callback:
//   live.push(imu, {t, ax, ay, az, wx, wy, wz});
//   LogSample step;
//   while (live.next(&step)) imm.step(step.t, step.u, step.z);
//
// Every step is the one LogReader gives for the same rows in files, bit for
// bit: the same grid (sampling.rate), aggregates (mean(wz), log(std(az))),
// held inputs, gaps, statistics and errors. So a step is complete only when
// every table not yet closed has a row at or after it: it waits for the
// slowest sensor's next row (with a rate, a step comes at most one period of
// the slowest sensor after its time). close(table) says a sensor has ended;
// close() ends the log and gives its last steps. Once every table feeding an
// input is closed no step follows, but the log ends when the others are
// closed too (their rows after the end are counted, as a file's are).
//
// The reader runs on a thread of its own, which waits for rows, so push()
// returns at once (but at max_queued_rows(), below, where it first waits for
// the reader). next() and the other queries return once it has taken every
// row pushed so far that it can, so what every member gives or throws
// depends only on the rows pushed, never on timing. One thread at a time may
// call a LiveLog's members.
//
// Errors: a row of the wrong length, or pushed to a closed table, is an
// Error at push(). A row the reader refuses (a time that does not increase,
// an infinite value) is a LogError naming the table, the row and the column,
// thrown by next() once every step before it has been taken, and by every
// next() after (rows pushed after it are not read). A table holding more
// than max_queued_rows() rows the reader has not taken (it waits for a row of
// another table: a sensor that stopped without close(); waiting_for() names
// it sooner) is an Error at push() naming the table waited for.
#ifndef SKIDIMM_IO_LIVE_LOG_H_
#define SKIDIMM_IO_LIVE_LOG_H_

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/io/log_reader.h"
#include "skidimm/io/sample_source.h"

namespace skidimm {

// One table of a live log: its name (for messages), its columns in the order
// push() takes a row's values, and the offset added to its times (s).
struct LiveTable {
  std::string name;
  std::vector<std::string> columns;
  double time_offset = 0.0;
};

class LiveLog {
 public:
  static constexpr std::size_t kDefaultMaxQueuedRows = 1000000;

  // Resolves every column and expression of the bank against the tables'
  // columns, as LogReader does against files' headers (errors name the bank
  // file and field, or the table). `sampling` overrides the bank's.
  LiveLog(const BankConfig& bank, std::vector<LiveTable> tables, const SamplingConfig& sampling);
  LiveLog(const BankConfig& bank, std::vector<LiveTable> tables);
  ~LiveLog();  // stops the reader; rows not yet read are dropped
  LiveLog(const LiveLog&) = delete;
  LiveLog& operator=(const LiveLog&) = delete;

  // The index of the table named `name`; Error naming the tables if none.
  int table(const std::string& name) const;
  int num_tables() const;
  const LiveTable& table_columns(int table) const;

  // Appends a row to `table`: one value per column, in its order; NaN is an
  // empty cell (an input keeps its previous value, a measurement is missing).
  void push(int table, const double* values, std::size_t count);
  void push(int table, const std::vector<double>& values) { push(table, values.data(), values.size()); }
  // No row of `table` follows. A closed table no longer holds steps back.
  void close(int table);
  // No row of any table follows: the log ends.
  void close();

  // The next step the rows pushed so far complete. False when they complete
  // none (push more rows), or when the log has ended (ended()).
  bool next(LogSample* sample);
  // Every table is closed (or the reader stopped at an error) and every step
  // has been taken by next().
  bool ended() const;

  // The table whose next row the reader waits for, once it has taken every
  // row pushed so far that it can: what holds the next step back. A sensor
  // that stopped without close() shows here, with the time of its last row,
  // while the others' rows pile up: a node can tell a late sensor from a dead
  // one, and close() it.
  struct Waiting {
    int table = -1;          // -1: none (the log has ended, or the reader stopped at an error)
    long rows = 0;           // the table's rows pushed so far
    double last_time = 0.0;  // of its last row pushed (with rows > 0), in s with the table's offset
  };
  Waiting waiting_for() const;

  // What the reader did with the rows so far (log_reader.h).
  LogStats stats() const;
  std::string describe_stats() const;
  std::vector<std::string> unmeasured() const;

  std::size_t max_queued_rows() const;
  void set_max_queued_rows(std::size_t rows);

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace skidimm

#endif  // SKIDIMM_IO_LIVE_LOG_H_
