#include "skidimm/io/csv.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <system_error>
#include <unordered_set>

#include "check.h"
#include "number_text.h"
#include "skidimm/errors.h"
#include "skidimm/io/ros/bag_reader.h"
#include "skidimm/stop_request.h"
#include "unwritten_rows.h"

namespace skidimm {

namespace fs = std::filesystem;

// ---------------------------------------------------------------- CsvReader

namespace {

// The message for a file whose lines end in CR alone: it reads as one line.
const char* const kLinesEndedByCr =
    "its lines end in a carriage return alone (CR, not LF or CR LF), so the whole file reads as one line: convert "
    "it first, e.g. `tr '\\r' '\\n' < in.csv > out.csv`";

// Whether `text` holds a carriage return that neither ends it nor comes
// before a line feed: a line break of a file whose lines end in CR alone.
bool holds_a_lone_carriage_return(std::string_view text) {
  for (std::size_t cr = text.find('\r'); cr != std::string_view::npos; cr = text.find('\r', cr + 1)) {
    if (cr + 1 < text.size() && text[cr + 1] != '\n') return true;
  }
  return false;
}

constexpr std::size_t kReadBlock = 1 << 16;
// No log has lines this long; a binary file, or a stream without line
// breaks, has: refused before it fills memory (a 300 MB line on standard
// input took minutes and gigabytes).
constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;

// Bytes of w that are zero get their high bit set (and possibly bytes above
// a zero byte: the lowest flagged byte is always a zero).
inline std::uint64_t zero_bytes(std::uint64_t w) {
  return (w - 0x0101010101010101ull) & ~w & 0x8080808080808080ull;
}
constexpr std::uint64_t kCommas = 0x2c2c2c2c2c2c2c2cull;
constexpr std::uint64_t kNewlines = 0x0a0a0a0a0a0a0a0aull;
constexpr std::uint64_t kQuotes = 0x2222222222222222ull;
// The word scan reads the lowest address as the lowest byte.
constexpr bool kLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

}  // namespace

bool parse_finite_number(std::string_view cell, double* value) {
  const auto begin = cell.find_first_not_of(" \t");
  if (begin == std::string_view::npos) return false;
  cell = cell.substr(begin, cell.find_last_not_of(" \t") - begin + 1);
  if (cell.front() == '+') cell.remove_prefix(1);
  bool overflow = false;
  if (!number_text::parse_plain_decimal(cell, value) && !number_text::parse_general(cell, value, &overflow)) return false;
  return std::isfinite(*value);
}

bool is_standard_input(const fs::path& path) { return path.string() == "-"; }

bool is_rereadable(const fs::path& path) {
  if (is_standard_input(path)) return false;
  std::error_code ec;
  // A directory given as a log is a ROS 2 bag (ros/bag_reader.h): its files are regular.
  return fs::is_regular_file(path, ec) || fs::is_directory(path, ec);
}

CsvReader::CsvReader(const fs::path& path) : path_(path) {
  std::error_code ec;
  if (is_standard_input(path)) {
    path_ = "standard input";
    file_ = stdin;
    owns_file_ = false;
  } else {
    const fs::file_status status = fs::status(path, ec);
    if (ec && ec != std::errc::no_such_file_or_directory) {
      throw LogError(path.string(), 0, "cannot read: " + ec.message());  // a symlink loop, a denied directory
    }
    if (!fs::exists(status)) {
      // run reads one log: a pattern is for the commands that read many.
      const std::string text = path.string();
      throw LogError(text, 0,
                     text.find('*') != std::string::npos
                         ? "no such log file (a pattern with '*' names the runs of fit, tune and eval; run reads one)"
                     : text.find_first_of("?[") != std::string::npos
                         ? "no such log file (a pattern takes '*' alone, not '?' or '[...]')"
                         : "no such log file");
    }
    if (fs::is_directory(status)) {
      const std::string unfinished = ros::BagReader::unfinished_recording(path);
      throw LogError(path.string(), 0,
                     unfinished.empty()
                         ? "is a directory, not a log file (a directory names the runs of fit, tune and eval; run "
                           "reads one)"
                         : "is a directory, not a ROS 2 bag: " + unfinished);
    }
    // Regular files, and pipes, FIFOs, /dev/stdin and <(...): read front to back.
    if (fs::is_regular_file(status)) file_size_ = fs::file_size(path, ec);
    errno = 0;
    file_ = std::fopen(path.c_str(), "rb");
    if (file_ == nullptr) {
      throw LogError(path.string(), 0, std::string("cannot open for reading: ") + std::strerror(errno));
    }
  }
  read_header();
}

CsvReader::CsvReader(const fs::path& path, int open_fifo) : path_(path) {
  // Until the writer has written or gone: a FIFO opened without waiting reads
  // as empty before its writer comes, and Linux's poll() waits for that
  // first writer (it reports a hang-up only once one has come and gone).
  // Polled a fifth of a second at a time, so that a stop request that came
  // just before a wait ends it too.
  constexpr int kPollMilliseconds = 200;
  pollfd wanted{open_fifo, POLLIN, 0};
  int ready = 0;
  int failure = 0;
  while (ready == 0) {
    if (stop_requested()) {
      ::close(open_fifo);
      throw LogError(path.string(), 0,
                     std::string("stopped by ") + signal_name(stop_requested()) + " while waiting for its writer");
    }
    ready = ::poll(&wanted, 1, kPollMilliseconds);
    if (ready < 0 && errno == EINTR) ready = 0;
  }
  if (ready < 0) failure = errno;
  const int flags = failure == 0 ? ::fcntl(open_fifo, F_GETFL) : -1;
  if (failure == 0 && flags < 0) failure = errno;
  if (failure == 0 && ::fcntl(open_fifo, F_SETFL, flags & ~O_NONBLOCK) < 0) failure = errno;
  if (failure == 0 && (file_ = ::fdopen(open_fifo, "rb")) == nullptr) failure = errno;
  if (failure != 0) {
    ::close(open_fifo);
    throw LogError(path.string(), 0, std::string("cannot open for reading: ") + std::strerror(failure));
  }
  read_header();
}

void CsvReader::read_header() {
  // A constructor that throws runs no destructor: every error from here on
  // closes the file itself. (A header with an unterminated quote, thrown from
  // read_record(), leaked the descriptor; the estimates fuzzer ran out of
  // them after ~300,000 inputs.)
  try {
    buffer_.resize(kReadBlock);
    if (!read_record()) throw LogError(path_.string(), 1, "empty file: expected a header row of column names");
    // A NumPy array (`skidimm run --output X.npy`) would otherwise be read as
    // a header of binary junk and refused for a confusing reason.
    if (field_count_ > 0 && fields_[0].compare(0, 6, "\x93NUMPY") == 0) {
      throw LogError(path_.string(), 1,
                     "a NumPy array (.npy), not CSV: this command reads CSV (for a `skidimm run` output, run it "
                     "again with --output X.csv; numpy.load reads the .npy)");
    }
    // Likewise MCAP: a log's bag through a pipe (a bag file is read by its
    // own reader, which seeks: a pipe cannot give it), or a `skidimm run`
    // output in .mcap given to a command that reads estimates as CSV.
    if (field_count_ > 0 && fields_[0].compare(0, 5, "\x89MCAP") == 0) {
      // A file here is one given where CSV is read (estimates); anything else came through a pipe.
      throw LogError(path_.string(), 1,
                     file_size_ > 0
                         ? "an MCAP file, not CSV: this reads CSV here. A bag is read as a log (--input, --log); "
                           "estimates `skidimm run` wrote as .mcap are JSON messages for Foxglove: for eval or plot, "
                           "run again with --output X.csv"
                         : "an MCAP bag through a pipe or standard input: a bag is read from its file, which its "
                           "reader seeks in (give its path to --input)");
    }
    // Binary data (a program, an image, an archive) is said to be such, not
    // read as a header of junk: CSV text holds no NUL byte.
    for (std::size_t f = 0; f < field_count_; ++f) {
      if (fields_[f].find('\0') != std::string::npos) {
        throw LogError(path_.string(), 1,
                       "binary data, not CSV text (its first line holds a NUL byte): this reads CSV with a header "
                       "row of column names");
      }
    }
    // Lines ended by a carriage return alone (classic Mac OS, some data
    // loggers) read as one line, the whole file: said as such, not as a
    // header of odd names. (A header with a quoted CR is followed by rows.)
    const bool whole_file_read = end_of_file_ && begin_ == end_;
    for (std::size_t f = 0; f < field_count_ && whole_file_read; ++f) {
      if (holds_a_lone_carriage_return(fields_[f])) throw LogError(path_.string(), 1, kLinesEndedByCr);
    }
    header_.assign(fields_.begin(), fields_.begin() + static_cast<std::ptrdiff_t>(field_count_));
    if (!header_.empty() && header_[0].size() >= 3 && header_[0].compare(0, 3, "\xEF\xBB\xBF") == 0) {
      header_[0].erase(0, 3);  // UTF-8 byte-order mark from spreadsheet exports
    }
    std::unordered_set<std::string_view> names;
    for (const std::string& name : header_) {
      if (!name.empty() && !names.insert(name).second) {
        throw LogError(
            path_.string(), 1,
            "column '" + name.substr(0, 80) + (name.size() > 80 ? "..." : "") + "' appears twice in the header");
      }
    }
  } catch (...) {
    close();
    throw;
  }
}

CsvReader::~CsvReader() { close(); }

void CsvReader::close() {
  if (file_ != nullptr && owns_file_) std::fclose(file_);
  file_ = nullptr;
}

int CsvReader::column(const std::string& name) const {
  for (std::size_t i = 0; i < header_.size(); ++i) {
    if (header_[i] == name) return static_cast<int>(i);
  }
  return -1;
}

// The next physical line, without its '\n', as std::getline splits them
// (a last line without one counts; none after a final '\n'). The view lives
// until the next call.
void CsvReader::refuse_long_line(long line) const {
  // A log of CR-only lines longer than the bound is one line too: said as such.
  if (line == 1 && holds_a_lone_carriage_return(std::string_view(buffer_.data() + begin_, end_ - begin_))) {
    throw LogError(path_.string(), line, kLinesEndedByCr);
  }
  throw LogError(path_.string(), line,
                 "a line longer than " + std::to_string(kMaxLineBytes) +
                     " bytes: not a CSV log (a binary file, or text without line breaks?)");
}

bool CsvReader::read_line(std::string_view* line) {
  while (true) {
    const char* data = buffer_.data();
    const void* newline = std::memchr(data + begin_, '\n', end_ - begin_);
    if (newline != nullptr) {
      const std::size_t stop = static_cast<std::size_t>(static_cast<const char*>(newline) - data);
      if (stop - begin_ > kMaxLineBytes) refuse_long_line(next_line_);
      *line = std::string_view(data + begin_, stop - begin_);
      begin_ = stop + 1;
      bytes_read_ += line->size() + 1;
      return true;
    }
    if (end_ - begin_ > kMaxLineBytes) refuse_long_line(next_line_);
    if (end_of_file_) {
      if (begin_ == end_) return false;
      *line = std::string_view(data + begin_, end_ - begin_);
      begin_ = end_;
      bytes_read_ += line->size() + 1;
      return true;
    }
    fill();
  }
}

// Keeps the unread part, makes room and reads on.
void CsvReader::fill() {
  if (begin_ > 0) {
    std::memmove(buffer_.data(), buffer_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  if (end_ == buffer_.size()) buffer_.resize(buffer_.size() * 2);
  // read(), not fread(): from a pipe it returns what has arrived instead of
  // waiting for a whole block, so each row is seen as soon as it is written.
  ssize_t got = 0;
  do {
    got = ::read(::fileno(file_), buffer_.data() + end_, buffer_.size() - end_);
    // A stop asked for while waiting for a pipe's next row (stop_request.h):
    // the rows read so far are the log.
    if (got < 0 && errno == EINTR && stop_requested()) {
      throw LogError(path_.string(), next_line_,
                     std::string("stopped by ") + signal_name(stop_requested()) + " while waiting for the next row");
    }
  } while (got < 0 && errno == EINTR);
  if (got < 0) throw LogError(path_.string(), next_line_, std::string("read failed: ") + std::strerror(errno));
  if (got == 0) end_of_file_ = true;
  end_ += static_cast<std::size_t>(got);
}

// RFC 4180 as the original reader had it: a '"' anywhere opens quotes, "" in
// quotes is a quote, a quoted field may span lines; a '\r' ending a physical
// line is dropped; blank lines are skipped.
bool CsvReader::read_record() {
  field_count_ = 0;
  // The usual row, without quotes: one pass over the buffer finds the line's
  // end and its commas; the fields are views into the buffer.
  while (true) {
    const char* const data = buffer_.data();
    const char* const line_begin = data + begin_;
    const char* const stop = data + end_;
    const char* field_begin = line_begin;
    const char* p = line_begin;
    std::size_t count = 0;
    bool quoted = false;
    bool found = false;  // p is at a '\n' or a '"'
    // Eight bytes at a time: the lowest byte flagged by the zero-byte test
    // is always a true match (borrows only run upwards).
    while (kLittleEndian && stop - p >= 8) {
      std::uint64_t word;
      std::memcpy(&word, p, 8);
      const std::uint64_t matches = zero_bytes(word ^ kCommas) | zero_bytes(word ^ kNewlines) | zero_bytes(word ^ kQuotes);
      if (matches == 0) {
        p += 8;
        continue;
      }
      p += __builtin_ctzll(matches) >> 3;
      if (*p != ',') {
        found = true;
        break;
      }
      set_field(count++, field_begin, p);
      field_begin = ++p;
    }
    if (!found) {
      for (; p != stop; ++p) {
        const char c = *p;
        if (c == ',') {
          set_field(count++, field_begin, p);
          field_begin = p + 1;
        } else if (c == '\n' || c == '"') {
          break;
        }
      }
    }
    if (p != stop && *p == '"') quoted = true;
    if (quoted) break;  // the general reader below, from the start of this line
    if (static_cast<std::size_t>(p - line_begin) > kMaxLineBytes) refuse_long_line(next_line_);
    if (p == stop && !end_of_file_) {
      fill();  // no whole line in the buffer yet
      continue;
    }
    if (p == stop && line_begin == stop) return false;  // end of file
    // [line_begin, p) is a physical line (the last one may lack its '\n').
    const std::size_t length = static_cast<std::size_t>(p - line_begin);
    begin_ = static_cast<std::size_t>(p - data) + (p != stop ? 1 : 0);
    bytes_read_ += length + 1;
    line_ = next_line_++;
    const char* line_end = length > 0 && p[-1] == '\r' ? p - 1 : p;
    if (line_end == line_begin) continue;  // blank
    set_field(count++, field_begin < line_end ? field_begin : line_end, line_end);
    field_count_ = count;
    return true;
  }

  std::string_view line;
  while (true) {
    if (!read_line(&line)) return false;
    line_ = next_line_++;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (!line.empty()) break;
  }
  record_.clear();
  field_ends_.clear();
  bool in_quotes = false;
  std::size_t i = 0;
  while (true) {
    if (i == line.size()) {
      if (!in_quotes) break;
      // A quoted field continues on the next physical line.
      if (!read_line(&line)) throw LogError(path_.string(), line_, "unterminated quoted field");
      ++next_line_;
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      record_ += '\n';
      if (record_.size() > kMaxLineBytes) refuse_long_line(line_);
      i = 0;
      continue;
    }
    const char c = line[i++];
    if (in_quotes) {
      if (c == '"') {
        if (i < line.size() && line[i] == '"') {
          record_ += '"';
          ++i;
        } else {
          in_quotes = false;
        }
      } else {
        record_ += c;
      }
    } else if (c == '"') {
      in_quotes = true;
    } else if (c == ',') {
      field_ends_.push_back(record_.size());
    } else {
      record_ += c;
    }
  }
  field_ends_.push_back(record_.size());
  std::size_t begin = 0;
  for (std::size_t end : field_ends_) {
    set_field(field_count_++, record_.data() + begin, record_.data() + end);
    begin = end;
  }
  return true;
}

bool CsvReader::next_row() {
  if (!read_record()) return false;
  if (field_count_ != header_.size()) {
    // A logger killed mid-write leaves a last line without its newline.
    const bool cut_off =
        field_count_ < header_.size() && end_of_file_ && begin_ == end_ && end_ > 0 && buffer_[end_ - 1] != '\n';
    throw LogError(path_.string(), line_,
                   "expected " + std::to_string(header_.size()) + " fields like the header, got " +
                       std::to_string(field_count_) +
                       (cut_off ? "; it is the last line and has no newline: did the writer stop mid-line? "
                                  "(remove that line to read the rows before it)"
                                : ""));
  }
  return true;
}

bool CsvReader::next(std::vector<std::string>* fields) {
  if (!next_row()) return false;
  fields->resize(field_count_);
  for (std::size_t i = 0; i < field_count_; ++i) (*fields)[i].assign(fields_[i]);
  return true;
}

// ---------------------------------------------------------------- CsvWriter

namespace {

bool needs_quotes(std::string_view cell) {
  for (const char c : cell) {
    if (c == ',' || c == '"' || c == '\n') return true;
  }
  return false;
}

void append_quoted(std::string_view cell, std::string* out) {
  if (!needs_quotes(cell)) {
    out->append(cell);
    return;
  }
  *out += '"';
  for (char c : cell) {
    if (c == '"') *out += '"';
    *out += c;
  }
  *out += '"';
}

constexpr long kRowsPerWrite = 1000;

}  // namespace

CsvWriter::CsvWriter(const fs::path& path, const std::vector<std::string>& header)
    : path_(path), out_(std::make_unique<OutputFile>(path)), columns_(header.size()) {
  reserve(1 << 16);
  write_row(header);
  write_buffer();
  rows_ = 0;
}

CsvWriter::~CsvWriter() {
  // Its buffer and file go: a crash later has nothing of this writer to write.
  if (rows_written_on_a_crash_) internal::clear_unwritten_rows();
  if (out_->committed()) return;
  // Keep what was computed in the .partial file (OutputFile removes it when a
  // write failed, its end then being cut anywhere).
  if (rows_ > 0) {
    out_->keep_partial();
    try {
      write_buffer();
    } catch (const Error&) {
    }
  }
}

void CsvWriter::write_row(const std::vector<std::string>& cells) {
  SKIDIMM_CHECK(cells.size() == columns_, "a row must have one cell per header column");
  for (const std::string& cell : cells) add_text(cell);
  end_row();
}

char* CsvWriter::reserve(std::size_t bytes) {
  if (capacity_ - size_ < bytes) {
    const std::size_t capacity = std::max(2 * capacity_, size_ + bytes);
    std::unique_ptr<char[]> grown(new char[capacity]);
    if (size_ > 0) std::memcpy(grown.get(), buffer_.get(), size_);
    // Pointed at the copy before the old buffer goes.
    if (rows_written_on_a_crash_) internal::set_unwritten_rows(out_->descriptor(), grown.get(), whole_rows_size_);
    buffer_ = std::move(grown);
    capacity_ = capacity;
  }
  return buffer_.get() + size_;
}

void CsvWriter::write_rows_on_a_crash() {
  rows_written_on_a_crash_ = true;
  held_rows_are_whole();
}

void CsvWriter::held_rows_are_whole() {
  if (!rows_written_on_a_crash_) return;
  whole_rows_size_ = size_;
  internal::set_unwritten_rows(out_->descriptor(), buffer_.get(), whole_rows_size_);
}

void CsvWriter::add_number(double value) {
  // Straight into the buffer: a separator and at most 32 characters.
  char* const start = reserve(33);
  char* p = start;
  if (cells_++ > 0) *p++ = ',';
  p = format(value, p, p + 32);
  size_ += static_cast<std::size_t>(p - start);
}

void CsvWriter::add_text(std::string_view text) {
  if (!needs_quotes(text)) {
    char* p = reserve(text.size() + 1);
    if (cells_++ > 0) *p++ = ',';
    if (!text.empty()) std::memcpy(p, text.data(), text.size());
    size_ += text.size() + (cells_ > 1 ? 1 : 0);
    return;
  }
  quoted_.clear();
  if (cells_++ > 0) quoted_ += ',';
  append_quoted(text, &quoted_);
  std::memcpy(reserve(quoted_.size()), quoted_.data(), quoted_.size());
  size_ += quoted_.size();
}

void CsvWriter::end_row() {
  SKIDIMM_CHECK(cells_ == columns_, "a row must have one cell per header column");
  *reserve(1) = '\n';
  ++size_;
  cells_ = 0;
  // Hand the rows to the file regularly so an interrupted run leaves them on disk.
  if (++rows_ % kRowsPerWrite == 0 || flush_each_row_) write_buffer();
  held_rows_are_whole();
}

void CsvWriter::write_buffer() {
  if (size_ == 0) return;
  const std::size_t size = size_;
  size_ = 0;
  // Handed over: a crash from now on must not write them again.
  held_rows_are_whole();
  out_->write(std::string_view(buffer_.get(), size));
}

void CsvWriter::commit() {
  write_buffer();
  if (rows_written_on_a_crash_) internal::clear_unwritten_rows();
  out_->commit();
}

char* CsvWriter::format(double value, char* first, char* last) {
  if (std::isnan(value)) {
    std::memcpy(first, "nan", 3);
    return first + 3;
  }
  return number_text::shortest_to_chars(first, last, value);  // std::to_chars's text, faster
}

std::string CsvWriter::format(double value) {
  char buffer[32];
  return std::string(buffer, format(value, buffer, buffer + sizeof(buffer)));
}

}  // namespace skidimm
