#include "skidimm/log_io.h"

#include <charconv>
#include <cmath>
#include <limits>
#include <system_error>

#include "skidimm/check.h"
#include "skidimm/errors.h"

namespace skidimm {

namespace fs = std::filesystem;

// ---------------------------------------------------------------- CsvReader

CsvReader::CsvReader(const fs::path& path) : path_(path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw LogError(path.string(), 0, "no such log file");
  file_size_ = fs::file_size(path, ec);
  in_.open(path, std::ios::binary);
  if (!in_) throw LogError(path.string(), 0, "cannot open for reading");
  if (!read_record(&header_)) throw LogError(path.string(), 1, "empty file: expected a header row of column names");
  if (!header_.empty() && header_[0].size() >= 3 && header_[0].compare(0, 3, "\xEF\xBB\xBF") == 0) {
    header_[0].erase(0, 3);  // UTF-8 byte-order mark from spreadsheet exports
  }
  for (std::size_t i = 0; i < header_.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (header_[i] == header_[j] && !header_[i].empty()) {
        throw LogError(path.string(), 1, "column '" + header_[i] + "' appears twice in the header");
      }
    }
  }
}

int CsvReader::column(const std::string& name) const {
  for (std::size_t i = 0; i < header_.size(); ++i) {
    if (header_[i] == name) return static_cast<int>(i);
  }
  return -1;
}

bool CsvReader::read_record(std::vector<std::string>* fields) {
  fields->clear();
  std::string line;
  while (true) {
    if (!std::getline(in_, line)) return false;
    line_ = next_line_++;
    bytes_read_ += line.size() + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!line.empty()) break;
  }
  std::string field;
  bool in_quotes = false;
  std::size_t i = 0;
  while (true) {
    if (i == line.size()) {
      if (!in_quotes) break;
      // A quoted field continues on the next physical line.
      std::string more;
      if (!std::getline(in_, more)) throw LogError(path_.string(), line_, "unterminated quoted field");
      ++next_line_;
      bytes_read_ += more.size() + 1;
      if (!more.empty() && more.back() == '\r') more.pop_back();
      field += '\n';
      line = more;
      i = 0;
      continue;
    }
    const char c = line[i++];
    if (in_quotes) {
      if (c == '"') {
        if (i < line.size() && line[i] == '"') {
          field += '"';
          ++i;
        } else {
          in_quotes = false;
        }
      } else {
        field += c;
      }
    } else if (c == '"') {
      in_quotes = true;
    } else if (c == ',') {
      fields->push_back(std::move(field));
      field.clear();
    } else {
      field += c;
    }
  }
  fields->push_back(std::move(field));
  return true;
}

bool CsvReader::next(std::vector<std::string>* fields) {
  if (!read_record(fields)) return false;
  if (fields->size() != header_.size()) {
    throw LogError(path_.string(), line_,
                   "expected " + std::to_string(header_.size()) + " fields like the header, got " +
                       std::to_string(fields->size()));
  }
  return true;
}

// ---------------------------------------------------------------- CsvWriter

namespace {

std::string quote(const std::string& cell) {
  if (cell.find_first_of(",\"\n") == std::string::npos) return cell;
  std::string out = "\"";
  for (char c : cell) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

}  // namespace

CsvWriter::CsvWriter(const fs::path& path, const std::vector<std::string>& header)
    : path_(path), partial_(path.string() + ".partial"), columns_(header.size()) {
  out_.open(partial_, std::ios::binary | std::ios::trunc);
  if (!out_) throw LogError(partial_.string(), 0, "cannot open for writing");
  write_row(header);
  rows_ = 0;
}

CsvWriter::~CsvWriter() {
  if (!committed_ && out_.is_open()) out_.flush();  // keep what was computed in the .partial file
}

void CsvWriter::write_row(const std::vector<std::string>& cells) {
  SKIDIMM_CHECK(cells.size() == columns_, "a row must have one cell per header column");
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (i) out_ << ',';
    out_ << quote(cells[i]);
  }
  out_ << '\n';
  // Flush regularly so an interrupted run leaves its rows on disk.
  if (++rows_ % 1000 == 0) out_.flush();
  if (!out_) throw LogError(partial_.string(), rows_ + 1, "write failed (disk full?)");
}

void CsvWriter::commit() {
  out_.flush();
  out_.close();
  if (!out_) throw LogError(partial_.string(), 0, "write failed when closing");
  std::error_code ec;
  fs::rename(partial_, path_, ec);
  if (ec) throw LogError(path_.string(), 0, "cannot rename " + partial_.string() + ": " + ec.message());
  committed_ = true;
}

std::string CsvWriter::format(double value) {
  if (std::isnan(value)) return "nan";
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

}  // namespace skidimm
