// Reading and writing CSV.
//
//  * CsvReader streams one file row by row (RFC 4180 quoting: the Husky
//    joint-state export has a quoted list in its `name` column) and knows the
//    line of every row for error messages.
//  * LogReader (log_reader.h, included here) turns a log's files into the
//    filter's steps with the bank's columns.
//  * CsvWriter writes through an OutputFile (output_file.h): "<path>.partial",
//    renamed to <path> only on commit(), so a file under the final name is
//    always complete; rows computed before an error are kept in the .partial
//    file (unless writing itself failed, or no row was written). Standard
//    output ("-"), devices and FIFOs are written directly.
//
// Both have a path that allocates nothing per row (next_row() and field(),
// add_number()/add_text()/end_row()): the reader splits rows in place in a
// block buffer, the writer formats numbers with std::to_chars into its own;
// every 1000 rows it hands them to the file, as the row-by-row writer flushed.
#ifndef SKIDIMM_IO_CSV_H_
#define SKIDIMM_IO_CSV_H_

#include <Eigen/Core>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>  // kept: includers have relied on it
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/io/log_reader.h"
#include "skidimm/io/output_file.h"

namespace skidimm {

// "-": standard input, as log and estimates arguments name it.
bool is_standard_input(const std::filesystem::path& path);
// Whether a file can be read more than once: a regular file. Standard input,
// pipes, FIFOs and <(...) can be read once, front to back; a command that
// needs a log twice says so instead of reading an empty second copy.
bool is_rereadable(const std::filesystem::path& path);

// A number in a CSV cell, read the way LogReader reads log cells: blanks
// around it ignored, an optional '+', decimal or scientific, locale
// independent; a subnormal value (1e-320) is read as the nearest double
// (number_text.h). False for anything else, including an empty cell, nan,
// inf, and values too large for a double.
bool parse_finite_number(std::string_view cell, double* value);

class CsvReader {
 public:
  // Opens the file and reads its header. "-" is standard input; pipes, FIFOs
  // and /dev/stdin are read like files, once (see is_rereadable). Throws
  // LogError.
  explicit CsvReader(const std::filesystem::path& path);
  // The FIFO at `path` through `open_fifo`, a descriptor of it the caller
  // opened with O_RDONLY | O_NONBLOCK (an open that does not wait for the
  // writer, so that a writer opening several FIFOs in turn gets past this
  // one): waits until the writer has written or closed it, then reads it as
  // the constructor above would. Takes the descriptor, also when it throws.
  CsvReader(const std::filesystem::path& path, int open_fifo);
  ~CsvReader();
  CsvReader(const CsvReader&) = delete;
  CsvReader& operator=(const CsvReader&) = delete;

  const std::filesystem::path& path() const { return path_; }
  const std::vector<std::string>& header() const { return header_; }
  int column(const std::string& name) const;  // -1 if absent

  // Reads the next data row into *fields (one per header column). Returns
  // false at end of file. Blank lines are skipped. Throws LogError on a row
  // with the wrong number of fields, an unterminated quote, or a line (or a
  // quoted record) longer than 1 MiB, which no log has.
  bool next(std::vector<std::string>* fields);
  // The same without copying: the row's fields are read in place, as views
  // valid until the next call to next_row() or next(). Allocates nothing
  // once its buffers have grown to the longest row.
  bool next_row();
  std::string_view field(int index) const { return fields_[static_cast<std::size_t>(index)]; }

  long line() const { return line_; }  // line of the row last read (1-based)
  std::uintmax_t bytes_read() const { return bytes_read_; }
  std::uintmax_t file_size() const { return file_size_; }  // 0 for a pipe

 private:
  void read_header();  // once the file is open; closes it if it throws
  bool read_line(std::string_view* line);
  [[noreturn]] void refuse_long_line(long line) const;
  bool read_record();
  void fill();
  void close();
  void set_field(std::size_t index, const char* begin, const char* end) {
    if (index == fields_.size()) fields_.emplace_back();  // grows to the widest row, once
    fields_[index] = std::string_view(begin, static_cast<std::size_t>(end - begin));
  }

  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  bool owns_file_ = true;  // false for standard input
  std::vector<char> buffer_;  // [begin_, end_) read but not yet consumed
  std::size_t begin_ = 0;
  std::size_t end_ = 0;
  bool end_of_file_ = false;
  std::string record_;                   // a quoted record, unescaped
  std::vector<std::size_t> field_ends_;  // ... and where its fields end
  std::vector<std::string_view> fields_;  // the first field_count_ are the row's
  std::size_t field_count_ = 0;
  std::vector<std::string> header_;
  long line_ = 0;       // line where the current record starts
  long next_line_ = 1;  // line where the next record starts
  std::uintmax_t bytes_read_ = 0;
  std::uintmax_t file_size_ = 0;
};

class CsvWriter {
 public:
  // Creates "<path>.partial" (output_file.h). Throws Error with the OS reason
  // if it cannot be written.
  CsvWriter(const std::filesystem::path& path, const std::vector<std::string>& header);
  ~CsvWriter();
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;

  // One row, one cell per header column (quoted when it holds ',', '"' or a
  // line break).
  void write_row(const std::vector<std::string>& cells);
  // The same a cell at a time, into the writer's buffer, allocating nothing
  // once it has grown: numbers as format() writes them (never quoted), text
  // quoted like write_row's. end_row() checks the count.
  void add_number(double value);
  void add_text(std::string_view text);
  void end_row();
  // Hand every row to the file as soon as it ends (run --flush), instead of
  // every 1000 rows: a program reading a pipe sees each row at once.
  void set_flush_each_row(bool flush) { flush_each_row_ = flush; }
  // From now on, a fatal signal reported by report_fatal_signals()
  // (skidimm/engine/fatal_signal_report.h) writes the whole rows this writer
  // holds to its file before the program ends: a plugin's crash loses no
  // row computed before it. One writer of the process at a time.
  void write_rows_on_a_crash();
  // Flushes, closes and renames to the final path.
  void commit();
  // Where rows are being written: "<path>.partial", or the path itself.
  const std::filesystem::path& partial_path() const { return out_->written_path(); }
  const std::filesystem::path& path() const { return path_; }

  // Shortest text that reads back to exactly the same double ("nan" for NaN).
  static std::string format(double value);
  // The same into [first, last) (32 characters are always enough); returns
  // the end of what was written.
  static char* format(double value, char* first, char* last);

 private:
  void write_buffer();
  // With write_rows_on_a_crash(): the rows the buffer holds now are whole,
  // and what a crash writes.
  void held_rows_are_whole();
  // Room for `bytes` more at the end of the buffer (grown, never shrunk).
  char* reserve(std::size_t bytes);

  std::filesystem::path path_;
  std::unique_ptr<OutputFile> out_;
  std::unique_ptr<char[]> buffer_;  // rows not yet handed to the file
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
  std::string quoted_;  // a cell that needs quotes
  std::size_t columns_ = 0;
  std::size_t cells_ = 0;  // in the row being added
  long rows_ = 0;
  bool flush_each_row_ = false;
  bool rows_written_on_a_crash_ = false;
  std::size_t whole_rows_size_ = 0;  // the bytes of the buffer's whole rows
};

}  // namespace skidimm

#endif  // SKIDIMM_IO_CSV_H_
