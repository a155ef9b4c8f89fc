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

// ---------------------------------------------------------------- LogReader

namespace {

std::string trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t");
  if (begin == std::string::npos) return "";
  const auto end = s.find_last_not_of(" \t");
  return s.substr(begin, end - begin + 1);
}

// Locale-independent parse of the whole cell. Missing: empty, nan, NaN, NA.
bool parse_number(const std::string& cell, double* value, bool* missing) {
  const std::string text = trim(cell);
  *missing = false;
  if (text.empty() || text == "nan" || text == "NaN" || text == "NAN" || text == "NA") {
    *missing = true;
    *value = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  const char* begin = text.data();
  if (*begin == '+') ++begin;
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(begin, end, *value);
  return result.ec == std::errc() && result.ptr == end;
}

}  // namespace

LogReader::LogReader(const BankConfig& bank, const std::vector<fs::path>& files) {
  if (files.empty()) throw LogError("", 0, "no input log given");
  for (const fs::path& file : files) {
    readers_.push_back(std::make_unique<CsvReader>(file));
    fields_.emplace_back();
  }
  time_ = resolve(bank.columns.time, "columns.time", true);
  for (std::size_t i = 0; i < bank.columns.inputs.size(); ++i) {
    inputs_.push_back(resolve(bank.columns.inputs[i], "columns.inputs." + bank.input_names[i], true));
  }
  for (std::size_t i = 0; i < bank.columns.measurements.size(); ++i) {
    measurements_.push_back(
        resolve(bank.columns.measurements[i], "columns.measurements." + bank.measurement.names[i], true));
  }
  if (!bank.columns.truth_mode.empty()) truth_ = resolve(bank.columns.truth_mode, "columns.truth_mode", false);
}

LogReader::ColumnRef LogReader::resolve(const std::string& column, const std::string& bank_field, bool required) const {
  for (std::size_t f = 0; f < readers_.size(); ++f) {
    const int index = readers_[f]->column(column);
    if (index >= 0) return ColumnRef{static_cast<int>(f), index, column};
  }
  if (!required) return ColumnRef{};
  // The header as read, made printable and short: a binary file given by
  // mistake must not flood the terminal.
  std::string present;
  int listed = 0;
  for (const auto& reader : readers_) {
    for (const std::string& h : reader->header()) {
      if (++listed > 40 || present.size() > 400) {
        present += ", ...";
        break;
      }
      std::string printable;
      for (unsigned char c : h.substr(0, 40)) printable += (c >= 32 && c < 127) ? static_cast<char>(c) : '?';
      present += (present.empty() ? "" : ", ") + printable;
    }
  }
  throw LogError(readers_[0]->path().string(), 1,
                 "no column '" + column + "' (the bank's " + bank_field + "); columns present: " + present);
}

double LogReader::parse(const ColumnRef& ref, bool allow_missing) const {
  const CsvReader& reader = *readers_[ref.file];
  const std::string& cell = fields_[ref.file][ref.index];
  double value = 0.0;
  bool missing = false;
  if (!parse_number(cell, &value, &missing)) {
    throw LogError(reader.path().string(), reader.line(),
                   "column '" + ref.name + "': expected a number, got '" + cell + "'");
  }
  if (missing && !allow_missing) {
    throw LogError(reader.path().string(), reader.line(), "column '" + ref.name + "': value missing (required)");
  }
  if (!missing && !std::isfinite(value)) {
    throw LogError(reader.path().string(), reader.line(), "column '" + ref.name + "': value is not finite");
  }
  return value;
}

bool LogReader::next(LogSample* sample) {
  std::size_t ended = 0;
  std::size_t an_ended_file = 0;
  std::size_t a_longer_file = 0;
  for (std::size_t f = 0; f < readers_.size(); ++f) {
    if (readers_[f]->next(&fields_[f])) {
      a_longer_file = f;
    } else {
      ++ended;
      an_ended_file = f;
    }
  }
  if (ended == readers_.size()) return false;
  if (ended != 0) {
    throw LogError(readers_[a_longer_file]->path().string(), readers_[a_longer_file]->line(),
                   "files read side by side must match row for row, but " + readers_[an_ended_file]->path().string() +
                       " ended after " + std::to_string(row_) + " data rows");
  }
  ++row_;
  sample->row = row_;
  sample->t = parse(time_, false);
  if (have_last_t_ && !(sample->t > last_t_)) {
    const CsvReader& reader = *readers_[time_.file];
    throw LogError(reader.path().string(), reader.line(),
                   "column '" + time_.name + "': time must increase strictly, but " + CsvWriter::format(sample->t) +
                       " follows " + CsvWriter::format(last_t_));
  }
  have_last_t_ = true;
  last_t_ = sample->t;
  sample->u.resize(static_cast<Eigen::Index>(inputs_.size()));
  for (std::size_t i = 0; i < inputs_.size(); ++i) sample->u[i] = parse(inputs_[i], false);
  sample->z.resize(static_cast<Eigen::Index>(measurements_.size()));
  for (std::size_t i = 0; i < measurements_.size(); ++i) sample->z[i] = parse(measurements_[i], true);
  if (truth_.file >= 0) sample->truth_mode = trim(fields_[truth_.file][truth_.index]);
  return true;
}

double LogReader::progress() const {
  std::uintmax_t done = 0, total = 0;
  for (const auto& reader : readers_) {
    done += reader->bytes_read();
    total += reader->file_size();
  }
  return total == 0 ? 1.0 : std::min(1.0, static_cast<double>(done) / static_cast<double>(total));
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
