#include "skidimm/io/output_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>

#include "skidimm/errors.h"

namespace skidimm {

namespace fs = std::filesystem;

namespace {

// Written in place: standard output, devices, FIFOs, and anything reached
// through /dev or /proc (/dev/stdout may resolve to a regular file, but
// renaming over it would replace the link, not write to the descriptor).
bool writes_to_device(const fs::path& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) return false;
  const std::string text = path.string();
  return !fs::is_regular_file(status) || text.rfind("/dev/", 0) == 0 || text.rfind("/proc/", 0) == 0;
}

}  // namespace

bool OutputFile::writes_directly(const fs::path& path) { return path.string() == "-" || writes_to_device(path); }

namespace {

std::string reason(int error) { return error != 0 ? std::strerror(error) : "unknown error"; }

// Creates "<path><suffix>", or, when that exists (another run writing the
// same output, or one killed before it finished), "<path><suffix>.<pid>-<n>",
// exclusively (O_EXCL), so no two writers ever share a file. Returns its
// descriptor, or -1 with errno set; *created names the last file tried.
int create_exclusively(const fs::path& path, const std::string& suffix, fs::path* created) {
  for (int attempt = 0;; ++attempt) {
    *created =
        attempt == 0
            ? fs::path(path.string() + suffix)
            : fs::path(path.string() + suffix + "." + std::to_string(::getpid()) + "-" + std::to_string(attempt));
    errno = 0;
    const int fd = ::open(created->c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0 || errno != EEXIST || attempt >= 1000) return fd;
  }
}

// Makes a rename in `path`'s directory durable. Best effort: the file is
// complete either way, and some file systems cannot sync a directory.
void sync_directory_of(const fs::path& path) {
  const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
  const int fd = ::open(parent.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

OutputFile::OutputFile(const fs::path& path, const std::string& suffix) : path_(path) {
  if (path.string() == "-") {
    direct_ = standard_output_ = true;
    written_ = "standard output";
    out_ = stdout;
    return;
  }
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    throw Error(path.string() + ": is a directory; give the name of a file to write");
  }
  direct_ = writes_to_device(path);
  if (direct_) {
    written_ = path;
    errno = 0;
    out_ = std::fopen(written_.c_str(), "wb");
    if (out_ == nullptr) throw Error(written_.string() + ": cannot open for writing: " + reason(errno));
    std::setvbuf(out_, nullptr, _IONBF, 0);
    return;
  }
  // A temporary file of this writer's own: each renames only the file it created.
  const int fd = create_exclusively(path, suffix, &written_);
  if (fd < 0) {
    const int error = errno;
    // The temporary file's name means nothing to the user; the path given does.
    const fs::path folder = path.has_parent_path() ? path.parent_path() : fs::path(".");
    if (error == ENOENT && !fs::exists(folder, ec)) {
      throw Error(path.string() + ": cannot write it: the directory " + folder.string() +
                  " does not exist; make it first, or give a path in a directory that does");
    }
    throw Error(path.string() + ": cannot write it (its temporary file " + written_.string() + "): " + reason(error));
  }
  out_ = ::fdopen(fd, "wb");
  if (out_ == nullptr) {
    const int error = errno;
    ::close(fd);
    fs::remove(written_, ec);
    throw Error(written_.string() + ": cannot open for writing: " + reason(error));
  }
  std::setvbuf(out_, nullptr, _IONBF, 0);  // callers hand whole blocks
}

OutputFile::~OutputFile() {
  if (committed_) return;
  if (out_ != nullptr && !standard_output_) std::fclose(out_);
  if (standard_output_ && out_ != nullptr) std::fflush(out_);
  out_ = nullptr;
  if (!direct_ && (!keep_partial_ || write_failed_)) {
    std::error_code ec;
    fs::remove(written_, ec);
  }
}

void OutputFile::close_for_failure() {
  write_failed_ = true;
  if (out_ != nullptr && !standard_output_) std::fclose(out_);
  out_ = nullptr;
  if (!direct_) {
    std::error_code ec;
    fs::remove(written_, ec);
  }
}

void OutputFile::fail(const char* what, int error) {
  close_for_failure();
  throw Error(written_.string() + ": cannot " + what + ": " + reason(error) +
              (direct_ ? "" : " (nothing was written to " + path_.string() + ")"));
}

int OutputFile::descriptor() const { return out_ != nullptr ? ::fileno(out_) : -1; }

void OutputFile::write(std::string_view bytes) {
  if (out_ == nullptr) throw Error(written_.string() + ": write after the file was closed");
  if (bytes.empty()) return;
  errno = 0;
  if (std::fwrite(bytes.data(), 1, bytes.size(), out_) != bytes.size()) fail("write", errno);
  // Standard output keeps its own buffer: hand the bytes on now, so a reader
  // of a pipe sees every block as it is written.
  if (standard_output_ && std::fflush(out_) != 0) fail("write", errno);
}

void OutputFile::seek(long offset) {
  errno = 0;
  if (out_ == nullptr || std::fseek(out_, offset, SEEK_SET) != 0) {
    const int error = errno;
    close_for_failure();
    throw Error(written_.string() + ": cannot seek (" + reason(error) +
                "): this output must be a regular file or a device, not a pipe or standard output");
  }
}

void OutputFile::seek_end() {
  errno = 0;
  if (out_ == nullptr || std::fseek(out_, 0, SEEK_END) != 0) fail("seek", errno);
}

void OutputFile::commit() {
  if (committed_) return;
  if (out_ == nullptr) throw Error(written_.string() + ": commit after a failed write");
  errno = 0;
  if (std::fflush(out_) != 0) fail("write", errno);
  if (!direct_) {
    // The bytes reach the disk before the name does: after a power cut the
    // final name holds the whole file or the old one, never a hole.
    errno = 0;
    if (::fsync(::fileno(out_)) != 0 && errno != EINVAL && errno != EROFS) fail("sync", errno);
  }
  if (!standard_output_) {
    // close() reports what a network or full file system only notices then.
    errno = 0;
    const int closed = std::fclose(out_);
    out_ = nullptr;
    if (closed != 0) fail("close", errno);
  } else if (std::ferror(out_)) {
    fail("write", EIO);
  }
  out_ = nullptr;
  if (!direct_) {
    std::error_code ec;
    fs::rename(written_, path_, ec);
    if (ec) {
      close_for_failure();
      throw Error(path_.string() + ": cannot rename " + written_.string() + " to it: " + ec.message());
    }
    sync_directory_of(path_);
  }
  committed_ = true;
}

void write_file_atomically(const fs::path& path, std::string_view text,
                           const std::function<void(const fs::path&)>& check, const std::string& suffix) {
  OutputFile out(path, suffix);
  out.write(text);
  // The stream is unbuffered: the bytes are in the file when it is checked.
  if (check && !out.direct()) check(out.written_path());
  out.commit();
}

void check_output_path(const fs::path& path, const std::string& option) {
  const std::string named = option + " " + path.string();
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw Error(named + ": is a directory; give the name of a file to write");
  if (OutputFile::writes_directly(path)) return;
  fs::path probe;
  const int fd = create_exclusively(path, ".probe", &probe);
  if (fd < 0) {
    const int error = errno;
    throw Error(named + ": cannot write there: " + reason(error));
  }
  ::close(fd);
  fs::remove(probe, ec);
}

}  // namespace skidimm
