// Reading and writing CSV.
//
//  * CsvReader streams one file row by row (RFC 4180 quoting: the Husky
//    joint-state export has a quoted list in its `name` column) and knows the
//    line of every row for error messages.
//  * LogReader (log_reader.h, included here) turns a log's files into the
//    filter's steps with the bank's columns.
//  * CsvWriter writes "<path>.partial", flushing as it goes, and renames it to
//    <path> only on commit(): a file under the final name is always complete,
//    and rows computed before an error are kept in the .partial file.
#ifndef SKIDIMM_LOG_IO_H_
#define SKIDIMM_LOG_IO_H_

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "skidimm/bank.h"
#include "skidimm/log_reader.h"

namespace skidimm {

class CsvReader {
 public:
  // Opens the file and reads its header. Throws LogError.
  explicit CsvReader(const std::filesystem::path& path);

  const std::filesystem::path& path() const { return path_; }
  const std::vector<std::string>& header() const { return header_; }
  int column(const std::string& name) const;  // -1 if absent

  // Reads the next data row into *fields (one per header column). Returns
  // false at end of file. Blank lines are skipped. Throws LogError on a row
  // with the wrong number of fields or an unterminated quote.
  bool next(std::vector<std::string>* fields);
  long line() const { return line_; }  // line of the row last read (1-based)
  std::uintmax_t bytes_read() const { return bytes_read_; }
  std::uintmax_t file_size() const { return file_size_; }

 private:
  bool read_record(std::vector<std::string>* fields);

  std::filesystem::path path_;
  std::ifstream in_;
  std::vector<std::string> header_;
  long line_ = 0;       // line where the current record starts
  long next_line_ = 1;  // line where the next record starts
  std::uintmax_t bytes_read_ = 0;
  std::uintmax_t file_size_ = 0;
};

class CsvWriter {
 public:
  // Creates "<path>.partial". Throws LogError if it cannot be written.
  CsvWriter(const std::filesystem::path& path, const std::vector<std::string>& header);
  ~CsvWriter();
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;

  void write_row(const std::vector<std::string>& cells);
  // Flushes, closes and renames to the final path.
  void commit();
  const std::filesystem::path& partial_path() const { return partial_; }
  const std::filesystem::path& path() const { return path_; }

  // Shortest text that reads back to exactly the same double.
  static std::string format(double value);

 private:
  std::filesystem::path path_;
  std::filesystem::path partial_;
  std::ofstream out_;
  std::size_t columns_ = 0;
  long rows_ = 0;
  bool committed_ = false;
};

}  // namespace skidimm

#endif  // SKIDIMM_LOG_IO_H_
