// A CSV file of a log as a LogTable (log_table.h): the cell parsing and the
// messages LogReader (log_reader.h) uses for CSV files. Private to core/src.
#ifndef SKIDIMM_CORE_SRC_CSV_TABLE_H_
#define SKIDIMM_CORE_SRC_CSV_TABLE_H_

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "log_table.h"
#include "skidimm/io/csv.h"

namespace skidimm {
namespace internal {

// Without the spaces and tabs at either end.
std::string_view trim(std::string_view s);

// Locale-independent parse of a whole cell. Missing: empty, nan, NaN, NA.
bool parse_number(std::string_view cell, double* value, bool* missing);

// What a cell that parse_number refused was expected to be, for the message.
std::string bad_number(const CsvReader& reader, int index, std::string_view cell, const std::string& expected);

// A CSV file as a table of the log (log_table.h): cells parsed as parse_number does.
class CsvTable : public LogTable {
 public:
  explicit CsvTable(const std::filesystem::path& path) : reader_(path) {}
  // A FIFO opened without waiting for its writer (CsvReader).
  CsvTable(const std::filesystem::path& path, int open_fifo) : reader_(path, open_fifo) {}
  const std::filesystem::path& path() const override { return reader_.path(); }
  std::string name() const override { return reader_.path().filename().string(); }
  std::vector<std::string> columns_present() const override { return reader_.header(); }
  int column(const std::string& name) override { return reader_.column(name); }
  bool next_row() override { return reader_.next_row(); }
  Cell number(int column, double* value) const override {
    bool missing = false;
    if (!parse_number(reader_.field(column), value, &missing)) return Cell::kNotANumber;
    return missing ? Cell::kMissing : Cell::kNumber;
  }
  std::string_view text(int column) const override { return reader_.field(column); }
  LogError cell_error(int column, const std::string& expected) const override {
    return error_at_row(bad_number(reader_, column, reader_.field(column), expected));
  }
  LogError error_at_row(const std::string& message) const override {
    return LogError(reader_.path().string(), reader_.line(), message);
  }
  LogError error(const std::string& message) const override { return LogError(reader_.path().string(), 1, message); }
  std::uintmax_t bytes_read() const override { return reader_.bytes_read(); }
  std::uintmax_t size() const override { return reader_.file_size(); }

 private:
  CsvReader reader_;
};

// A header made printable and short: a binary file given by mistake must not
// flood the terminal. A name with a space at either end, or empty, is quoted.
std::string printable_header(const std::vector<std::string>& header, int* listed, std::size_t budget);

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_CSV_TABLE_H_
