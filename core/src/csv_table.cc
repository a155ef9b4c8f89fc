#include "csv_table.h"

#include <limits>

#include "number_text.h"
#include "skidimm/config/expression.h"

namespace skidimm {
namespace internal {

std::string_view trim(std::string_view s) {
  const auto begin = s.find_first_not_of(" \t");
  if (begin == std::string_view::npos) return {};
  const auto end = s.find_last_not_of(" \t");
  return s.substr(begin, end - begin + 1);
}

bool parse_number(std::string_view cell, double* value, bool* missing) {
  const auto blank = [](char c) { return c == ' ' || c == '\t'; };
  const std::string_view text = !cell.empty() && (blank(cell.front()) || blank(cell.back())) ? trim(cell) : cell;
  *missing = false;
  if (text.empty() || ((text.front() == 'n' || text.front() == 'N') &&
                       (text == "nan" || text == "NaN" || text == "NAN" || text == "NA"))) {
    *missing = true;
    *value = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  const char* begin = text.data();
  const char* end = text.data() + text.size();
  // One sign: from_chars takes a '-', not a '+', so a '+' is stepped over
  // here, and a sign after it ("+-1") is not a number.
  if (*begin == '+') {
    ++begin;
    if (begin == end || *begin == '-' || *begin == '+') return false;
  }
  // Most cells are plain decimals: exactly from_chars's value, faster (number_text.h).
  if (number_text::parse_plain_decimal(std::string_view(begin, static_cast<std::size_t>(end - begin)), value)) {
    return true;
  }
  bool overflow = false;
  return number_text::parse_general(std::string_view(begin, static_cast<std::size_t>(end - begin)), value, &overflow);
}

std::string bad_number(const CsvReader& reader, int index, std::string_view cell, const std::string& expected) {
  return "column " + std::to_string(index + 1) + " ('" +
         Expression::excerpt(reader.header()[static_cast<std::size_t>(index)]) + "'): expected " + expected +
         ", got '" + std::string(cell.substr(0, 80)) + (cell.size() > 80 ? "...'" : "'");
}

std::string printable_header(const std::vector<std::string>& header, int* listed, std::size_t budget) {
  std::string present;
  for (const std::string& h : header) {
    if (++*listed > 40 || present.size() > budget) {
      present += ", ...";
      break;
    }
    std::string printable;
    for (unsigned char c : h.substr(0, 40)) printable += (c >= 32 && c < 127) ? static_cast<char>(c) : '?';
    // A name with a space at either end (" velL" after "time, ") or none
    // would look like another name in a list: quoted.
    if (printable.empty() || printable.front() == ' ' || printable.back() == ' ') printable = "'" + printable + "'";
    present += (present.empty() ? "" : ", ") + printable;
  }
  return present;
}

}  // namespace internal
}  // namespace skidimm
