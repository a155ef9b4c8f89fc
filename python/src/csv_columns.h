// A CSV file as columns for Python: what skidimm.read_csv, skidimm.simulate
// and skidimm.simulate_models return.
#ifndef SKIDIMM_PYTHON_CSV_COLUMNS_H_
#define SKIDIMM_PYTHON_CSV_COLUMNS_H_

#include <filesystem>
#include <string>
#include <vector>

namespace skidimm {
namespace python {

// A CSV file as columns: numbers (NaN where empty or nan), or text where a
// column has any other cell. Exact (std::from_chars).
struct CsvColumns {
  std::vector<std::string> names;
  std::vector<std::vector<double>> numbers;    // per column; empty for a text column
  std::vector<std::vector<std::string>> text;  // per column; empty for a numeric column
  std::vector<bool> is_text;
};
CsvColumns read_csv_columns(const std::filesystem::path& file);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_CSV_COLUMNS_H_
