#include "csv_columns.h"

#include <charconv>
#include <limits>
#include <system_error>

#include "skidimm/io/csv.h"

namespace skidimm {
namespace python {

namespace fs = std::filesystem;

CsvColumns read_csv_columns(const fs::path& file) {
  CsvReader reader(file);
  CsvColumns out;
  out.names = reader.header();
  const std::size_t n = out.names.size();
  std::vector<std::vector<std::string>> cells(n);
  out.numbers.assign(n, {});
  out.text.assign(n, {});
  out.is_text.assign(n, false);
  // The text columns of a `skidimm run` output stay text even when every
  // cell is empty (a run's reason column usually is), so a run read back
  // compares equal to the same run done in Python.
  for (std::size_t c = 0; c < n; ++c) {
    for (const char* text : {"mode", "decision", "truth_mode", "status", "reason"}) {
      if (out.names[c] == text) out.is_text[c] = true;
    }
  }
  std::vector<std::string> fields;
  while (reader.next(&fields)) {
    for (std::size_t c = 0; c < n; ++c) {
      const std::string& cell = fields[c];
      if (!out.is_text[c]) {
        double value = std::numeric_limits<double>::quiet_NaN();
        bool number = cell.empty() || cell == "nan" || cell == "NaN" || cell == "NA";
        if (!number) {
          const auto parsed = std::from_chars(cell.data(), cell.data() + cell.size(), value);
          number = parsed.ec == std::errc() && parsed.ptr == cell.data() + cell.size();
        }
        if (number) {
          out.numbers[c].push_back(value);
        } else {
          out.is_text[c] = true;  // from here on, every cell of the column is kept as text
        }
      }
      cells[c].push_back(cell);
    }
  }
  for (std::size_t c = 0; c < n; ++c) {
    if (out.is_text[c]) {
      out.text[c] = std::move(cells[c]);
      out.numbers[c].clear();
    }
  }
  return out;
}

}  // namespace python
}  // namespace skidimm
