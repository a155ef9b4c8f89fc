#include "skidimm/io/estimates_writer.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string_view>
#include <system_error>
#include <unordered_map>

#include "check.h"
#include "ros/estimates_mcap_writer.h"
#include "skidimm/errors.h"
#include "skidimm/io/output_file.h"
#include "skidimm/printable.h"

namespace skidimm {

namespace fs = std::filesystem;

std::vector<std::string> EstimatesWriter::header(const BankConfig& config, bool with_truth) {
  std::vector<std::string> header{"t"};
  for (const ModeConfig& mode : config.modes) header.push_back("mu_" + mode.name);
  if (config.unknown.enabled()) header.push_back("unknown_probability");
  for (const std::string& s : config.state_names) header.push_back(s);
  for (const std::string& s : config.state_names) header.push_back("var_" + s);
  header.push_back("mode");
  header.push_back("decision");
  if (with_truth) header.push_back("truth_mode");
  header.push_back("status");
  header.push_back("reason");
  return header;
}

void describe_step(const ImmEstimate& e, const std::vector<std::string>& mode_names, std::string* out) {
  out->clear();
  for (std::size_t j = 0; j < e.mode_failures.size(); ++j) {
    const ModeFailure failure = e.mode_failures[j];
    if (failure == ModeFailure::kNone) continue;
    if (!out->empty()) out->append("; ");
    out->append(mode_names[j]);
    out->append(": ");
    switch (failure) {
      case ModeFailure::kModel:
        out->append("model failed, reset: ");
        out->append(e.failure_reasons[j]);
        break;
      case ModeFailure::kNotFinite:
        out->append("model returned non-finite values, reset");
        break;
      case ModeFailure::kUpdate:
        out->append("update failed, reset");
        break;
      case ModeFailure::kDiverged:
        out->append("diverged, reset");
        break;
      case ModeFailure::kGated: {
        char nis[48];
        std::snprintf(nis, sizeof nis, "gated (NIS %.4g)", e.nis[static_cast<Eigen::Index>(j)]);
        out->append(nis);
        break;
      }
      case ModeFailure::kNone:
        break;
    }
  }
}

namespace {

// `text` as a JSON string literal. Valid UTF-8 is kept as it is; a byte that
// is not part of valid UTF-8 (a plugin's message may hold any bytes) becomes
// the code point of the same value, so the file stays JSON.
void append_json_string(std::string_view text, std::string* out) {
  static const char kHex[] = "0123456789abcdef";
  out->push_back('"');
  std::size_t i = 0;
  while (i < text.size()) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '"' || c == '\\') {
      out->push_back('\\');
      out->push_back(static_cast<char>(c));
      ++i;
      continue;
    }
    if (c < 0x20 || c == 0x7f) {
      out->append("\\u00");
      out->push_back(kHex[c >> 4]);
      out->push_back(kHex[c & 15]);
      ++i;
      continue;
    }
    if (c < 0x80) {
      out->push_back(static_cast<char>(c));
      ++i;
      continue;
    }
    // A UTF-8 sequence: its lead byte says how long, every other byte 10xxxxxx,
    // no overlong forms, no surrogates, nothing above U+10FFFF.
    std::size_t length = c >= 0xc2 && c <= 0xdf ? 2 : c >= 0xe0 && c <= 0xef ? 3 : c >= 0xf0 && c <= 0xf4 ? 4 : 0;
    if (length != 0 && i + length <= text.size()) {
      const auto second = static_cast<unsigned char>(text[i + 1]);
      bool valid = (second & 0xc0) == 0x80;
      if (c == 0xe0) valid = valid && second >= 0xa0;
      if (c == 0xed) valid = valid && second < 0xa0;
      if (c == 0xf0) valid = valid && second >= 0x90;
      if (c == 0xf4) valid = valid && second < 0x90;
      for (std::size_t k = 2; k < length; ++k) {
        valid = valid && (static_cast<unsigned char>(text[i + k]) & 0xc0) == 0x80;
      }
      if (valid) {
        out->append(text.substr(i, length));
        i += length;
        continue;
      }
    }
    out->append("\\u00");
    out->push_back(kHex[c >> 4]);
    out->push_back(kHex[c & 15]);
    ++i;
  }
  out->push_back('"');
}

}  // namespace

fs::path EstimatesWriter::reasons_path(const fs::path& npy) {
  fs::path reasons = npy;
  return reasons.replace_extension(".reasons.json");
}

bool EstimatesWriter::is_npy(const fs::path& path) { return path.extension() == ".npy"; }

// ---------------------------------------------------------------- .npy

// The texts of a .npy file's reason column (the "table" beside its codes): a
// JSON array written to <name>.reasons.json as new texts come, text k at
// index k, "" at 0. A text seen before gets its code again, for the first
// kRemembered distinct texts; past them (a log gated on every row, each with
// its own NIS) every new text is appended without being remembered, so the
// memory stays bounded and every code still maps to its text. Not in an
// anonymous namespace: EstimatesWriter::Npy, which has external linkage, holds
// one, and a member of internal linkage in it is what gcc's
// -Wsubobject-linkage warns about in a unity build.
namespace internal {

class NpyReasonTable {
 public:
  explicit NpyReasonTable(const fs::path& path) : out_(path) {
    buffer_.reserve(1 << 16);
    buffer_ = "[\n\"\"";
  }

  ~NpyReasonTable() {
    if (out_.committed()) return;
    try {
      finish();
    } catch (const Error&) {
    }
  }

  std::uint32_t code(const std::string& text) {
    if (text.empty()) return 0;
    const auto known = codes_.find(text);
    if (known != codes_.end()) return known->second;
    if (next_ == std::numeric_limits<std::uint32_t>::max()) {
      throw Error(out_.written_path().string() + ": more than 2^32 - 1 distinct reasons; write CSV instead");
    }
    const std::uint32_t code = next_++;
    if (codes_.size() < kRemembered) codes_.emplace(text, code);
    buffer_.append(",\n");
    append_json_string(text, &buffer_);
    if (buffer_.size() >= (1 << 16)) write_buffer();
    return code;
  }

  void keep_partial() { out_.keep_partial(); }

  void commit() {
    finish();
    out_.commit();
  }

 private:
  static constexpr std::size_t kRemembered = 1 << 16;

  void write_buffer() {
    out_.write(buffer_);
    buffer_.clear();
  }

  void finish() {
    if (finished_) return;
    finished_ = true;
    buffer_.append("\n]\n");
    write_buffer();
  }

  OutputFile out_;
  std::string buffer_;
  std::unordered_map<std::string, std::uint32_t> codes_;
  std::uint32_t next_ = 1;
  bool finished_ = false;
};

}  // namespace internal

// A NumPy .npy file of records (numpy/lib/format.py): magic, version, a
// Python-literal header padded to 64 bytes, then the records back to back.
// The row count is written as the header's shape when the file is closed.
class EstimatesWriter::Npy {
 public:
  // Columns: `numbers` doubles, then a text column of each of `text_widths`
  // bytes, then one unsigned 32-bit code.
  Npy(const fs::path& path, const std::vector<std::string>& names, std::size_t numbers,
      const std::vector<std::size_t>& text_widths)
      : text_widths_(text_widths) {
    std::uint16_t probe = 1;
    unsigned char first = 0;
    std::memcpy(&first, &probe, 1);
    const std::string order = first == 1 ? "<" : ">";
    std::string descr = "[";
    for (std::size_t i = 0; i < names.size(); ++i) {
      descr += (i ? ", (" : "(") + python_string(names[i]) + ", ";
      if (i < numbers) {
        descr += "'" + order + "f8'";
      } else if (i < numbers + text_widths.size()) {
        descr += "'S" + std::to_string(text_widths[i - numbers]) + "'";
      } else {
        descr += "'" + order + "u4'";
      }
      descr += ")";
    }
    descr += "]";
    std::string dict = "{'descr': " + descr + ", 'fortran_order': False, 'shape': (";
    shape_offset_ = dict.size();
    dict += std::string(kShapeDigits, ' ') + "0,), }";
    // magic (6) + version (2) + header length (2 or 4) + dict + padding + '\n', a multiple of 64.
    const bool version2 = dict.size() + 11 > 65535;
    const std::size_t prefix = version2 ? 12 : 10;
    const std::size_t total = (prefix + dict.size() + 1 + 63) / 64 * 64;
    dict += std::string(total - prefix - dict.size() - 1, ' ') + "\n";
    std::string head = "\x93NUMPY";
    head += static_cast<char>(version2 ? 2 : 1);
    head += '\0';
    const std::size_t length = dict.size();
    for (std::size_t b = 0; b < (version2 ? 4u : 2u); ++b) head += static_cast<char>((length >> (8 * b)) & 0xff);
    shape_offset_ += head.size();
    head += dict;
    out_ = std::make_unique<OutputFile>(path);  // output_file.h
    reasons_ = std::make_unique<internal::NpyReasonTable>(EstimatesWriter::reasons_path(path));
    buffer_.reserve(1 << 16);
    buffer_ = head;
    write_buffer();
    // The row count is written into the header at the end: fail now on a pipe.
    out_->seek(static_cast<long>(head.size()));
  }

  ~Npy() {
    if (out_->committed()) return;
    // Keep what was computed in the .partial files, loadable.
    if (rows_ > 0) {
      out_->keep_partial();
      reasons_->keep_partial();
    }
    try {
      finish();
    } catch (const Error&) {
    }
  }

  void add_number(double value) {
    char bytes[8];
    std::memcpy(bytes, &value, 8);
    buffer_.append(bytes, 8);
  }

  void add_code(std::uint32_t code) {
    char bytes[4];
    std::memcpy(bytes, &code, 4);
    buffer_.append(bytes, 4);
  }

  // Where the row being written starts in the buffer: a row refused
  // midway is taken back whole, so the .partial file kept holds the rows
  // its header counts and nothing after them.
  void begin_row() { row_start_ = buffer_.size(); }

  void add_text(std::string_view text, std::size_t column, const char* what) {
    const std::size_t width = text_widths_[column];
    if (text.size() > width) {
      buffer_.resize(row_start_);
      throw Error(partial_path().string() + ": row " + std::to_string(rows_ + 1) + ": the " + what + " '" +
                  printable(std::string(text)) + "' is longer than the " + std::to_string(width) +
                  " bytes of its .npy column (the longest mode or class name, and at least 64 bytes for a truth "
                  "label); write CSV instead");
    }
    buffer_.append(text);
    buffer_.append(width - text.size(), '\0');
  }

  void end_row() {
    if (++rows_ % 1000 == 0) write_buffer();
  }

  void add_reason(const std::string& text) { add_code(reasons_->code(text)); }

  // The table first: a .npy under its final name always has its table.
  void commit() {
    reasons_->commit();
    finish();
    out_->commit();
  }

  const fs::path& partial_path() const { return out_->written_path(); }

 private:
  static constexpr std::size_t kShapeDigits = 20;

  // A Python string literal for literal_eval.
  static std::string python_string(const std::string& s) {
    std::string out = "'";
    for (unsigned char c : s) {
      if (c == '\\' || c == '\'') {
        out += '\\';
        out += static_cast<char>(c);
      } else if (c < 32 || c >= 127) {
        static const char kHex[] = "0123456789abcdef";
        out += "\\x";
        out += kHex[c >> 4];
        out += kHex[c & 15];
      } else {
        out += static_cast<char>(c);
      }
    }
    return out + "'";
  }

  void write_buffer() {
    if (buffer_.empty()) return;
    out_->write(buffer_);
    buffer_.clear();
  }

  // The rows so far, and their count in the header.
  void finish() {
    write_buffer();
    std::string count = std::to_string(rows_);
    count.insert(0, kShapeDigits + 1 - count.size(), ' ');
    out_->seek(static_cast<long>(shape_offset_));
    out_->write(count);
    out_->seek_end();
  }

  std::unique_ptr<OutputFile> out_;
  std::unique_ptr<internal::NpyReasonTable> reasons_;
  std::string buffer_;
  std::vector<std::size_t> text_widths_;
  std::size_t shape_offset_ = 0;
  std::size_t row_start_ = 0;
  long rows_ = 0;
};

// ---------------------------------------------------------------- writer

EstimatesWriter::EstimatesWriter(const fs::path& path, const BankConfig& config, bool with_truth)
    : with_truth_(with_truth), with_unknown_(config.unknown.enabled()) {
  for (const ModeConfig& mode : config.modes) mode_names_.push_back(mode.name);
  std::vector<std::string> names = header(config, with_truth);
  if (ros::EstimatesMcapWriter::is_mcap(path)) {
    mcap_ = std::make_unique<ros::EstimatesMcapWriter>(path, config, with_truth);
    return;
  }
  if (!is_npy(path)) {
    csv_ = std::make_unique<CsvWriter>(path, names);
    return;
  }
  // "unknown": the decision's, and the most likely hypothesis' when the bank has one.
  std::size_t longest_mode = with_unknown_ ? 7 : 1, longest_class = 7;
  for (const std::string& m : mode_names_) longest_mode = std::max(longest_mode, m.size());
  for (const std::string& c : config.class_names()) longest_class = std::max(longest_class, c.size());
  std::vector<std::size_t> widths{longest_mode, longest_class};
  if (with_truth) widths.push_back(std::max<std::size_t>(64, std::max(longest_mode, longest_class)));
  widths.push_back(18);          // "all_modes_rejected"
  names.back() = "reason_code";  // into the table of reasons_path()
  npy_ = std::make_unique<Npy>(path, names, names.size() - widths.size() - 1, widths);
}

EstimatesWriter::~EstimatesWriter() = default;

const fs::path& EstimatesWriter::partial_path() const {
  if (mcap_) return mcap_->partial_path();
  return csv_ ? csv_->partial_path() : npy_->partial_path();
}

void EstimatesWriter::copy_topics(const fs::path& bag, const std::vector<std::string>& column_texts) {
  if (!mcap_) throw Error("--copy-topics copies a bag's topics into an MCAP output (--output ending in .mcap)");
  mcap_->copy_topics(bag, column_texts);
}

void EstimatesWriter::flush_each_row() {
  if (!csv_) throw Error("--flush writes CSV rows as they are computed; a .npy or .mcap file is complete only at the end");
  csv_->set_flush_each_row(true);
}

bool EstimatesWriter::write_rows_on_a_crash() {
  if (!csv_) return false;
  csv_->write_rows_on_a_crash();
  return true;
}

void EstimatesWriter::commit() {
  if (mcap_) {
    mcap_->commit();
  } else if (csv_) {
    csv_->commit();
  } else {
    npy_->commit();
  }
}

void EstimatesWriter::write(double t, const ImmEstimate& e, const std::string& decision, const std::string& truth) {
  if (observer_) observer_(t, e, decision, truth);
  if (mcap_) {
    mcap_->write(t, e, decision, truth);
    return;
  }
  static const std::string kUnknown = "unknown";
  const std::string& mode =
      with_unknown_ && e.unknown_is_most_likely() ? kUnknown : mode_names_[static_cast<std::size_t>(e.most_likely_mode)];
  const Eigen::Index n = e.state.size();
  if (csv_) {
    CsvWriter& w = *csv_;
    w.add_number(t);
    for (Eigen::Index j = 0; j < e.mode_probabilities.size(); ++j) w.add_number(e.mode_probabilities[j]);
    if (with_unknown_) w.add_number(e.unknown_probability);
    for (Eigen::Index i = 0; i < n; ++i) w.add_number(e.state[i]);
    for (Eigen::Index i = 0; i < n; ++i) w.add_number(e.covariance(i, i));
    w.add_text(mode);
    w.add_text(decision);
    if (with_truth_) w.add_text(truth);
    w.add_text(to_string(e.status));
    describe_step(e, mode_names_, &reason_);
    w.add_text(reason_);
    w.end_row();
    return;
  }
  Npy& w = *npy_;
  w.begin_row();
  w.add_number(t);
  for (Eigen::Index j = 0; j < e.mode_probabilities.size(); ++j) w.add_number(e.mode_probabilities[j]);
  if (with_unknown_) w.add_number(e.unknown_probability);
  for (Eigen::Index i = 0; i < n; ++i) w.add_number(e.state[i]);
  for (Eigen::Index i = 0; i < n; ++i) w.add_number(e.covariance(i, i));
  std::size_t column = 0;
  w.add_text(mode, column++, "mode");
  w.add_text(decision, column++, "decision");
  if (with_truth_) w.add_text(truth, column++, "truth label");
  w.add_text(to_string(e.status), column, "status");
  describe_step(e, mode_names_, &reason_);
  w.add_reason(reason_);
  w.end_row();
}

}  // namespace skidimm
