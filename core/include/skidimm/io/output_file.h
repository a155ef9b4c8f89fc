// OutputFile: how every file skidimm writes reaches its name.
//
// Where the bytes go depends on what the path is:
//  * a regular file, or a path that does not exist yet: "<path><suffix>"
//    (".partial" unless told otherwise) is written, and renamed to <path> by
//    commit() once every byte is written, synced to the disk (fsync) and the
//    file closed without error; the directory is then synced too. A file
//    under the final name is therefore always complete: never empty, never
//    cut short by a full disk, a kill or a power cut. The temporary file is
//    created exclusively (O_EXCL): when "<path><suffix>" exists (another
//    process writing the same output, or one killed before it finished),
//    "<path><suffix>.<pid>-<n>" is used instead. No two writers share a
//    file, and each renames only its own.
//  * a directory: an Error at once.
//  * "-": standard output, written directly (`run --output -`).
//  * an existing file that is not a regular file (a device such as /dev/null
//    or /dev/full, a FIFO, /dev/stdout): written directly. Renaming a
//    temporary file over a device node would replace the node itself.
//
// Every failure (open, write, flush, sync, close, rename) throws skidimm::Error
// naming the file and the operating system's reason (strerror), e.g.
// "out.yaml.partial: cannot write: No space left on device".
//
// If an OutputFile is destroyed without commit(), the temporary file is
// removed, unless keep_partial() was called (CsvWriter keeps the rows
// computed before an error). After a failed write it is always removed: its
// end is cut at an arbitrary byte.
//
// The stream is unbuffered: callers hand it whole blocks (CsvWriter buffers
// 1000 rows), so a write() is one system call and fails where it happens.
#ifndef SKIDIMM_IO_OUTPUT_FILE_H_
#define SKIDIMM_IO_OUTPUT_FILE_H_

#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

namespace skidimm {

class OutputFile {
 public:
  // Opens the file to write (see above). Throws Error.
  explicit OutputFile(const std::filesystem::path& path, const std::string& suffix = ".partial");
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  // Writes all of `bytes`. Throws Error with the OS reason.
  void write(std::string_view bytes);
  // Seeks to an absolute byte offset (the .npy writer rewrites its header);
  // throws Error when the output cannot seek (a pipe, standard output).
  void seek(long offset);
  void seek_end();
  // Checks the close, then renames the temporary file to the final name.
  // Throws Error; the final name is then untouched.
  void commit();
  // Not committed: keep the temporary file instead of removing it.
  void keep_partial() { keep_partial_ = true; }

  const std::filesystem::path& path() const { return path_; }
  // The file being written: the temporary one, or the path itself when direct.
  const std::filesystem::path& written_path() const { return written_; }
  bool direct() const { return direct_; }
  // The file descriptor written to (-1 once closed).
  int descriptor() const;
  // Whether `path` would be written directly (no temporary file, no rename).
  static bool writes_directly(const std::filesystem::path& path);
  bool committed() const { return committed_; }

 private:
  [[noreturn]] void fail(const char* what, int error);
  void close_for_failure();

  std::filesystem::path path_;
  std::filesystem::path written_;
  std::FILE* out_ = nullptr;
  bool direct_ = false;
  bool standard_output_ = false;
  bool keep_partial_ = false;
  bool write_failed_ = false;
  bool committed_ = false;
};

// Writes `text` as the whole content of `path` through an OutputFile with
// `suffix`; `check`, when given, is called on the written temporary file
// before the rename (bank_writer loads it as a bank) and may throw, in which
// case nothing is renamed and the temporary file is removed.
void write_file_atomically(const std::filesystem::path& path, std::string_view text,
                           const std::function<void(const std::filesystem::path&)>& check = nullptr,
                           const std::string& suffix = ".partial");

// Checks, before a long computation whose result goes to `path`, that a file
// can be created there as OutputFile would create it (a file is made beside
// it and removed); standard output and devices are taken as they are.
// Throws Error naming `option`, the path and the reason, so that a mistyped
// directory or a read-only disk fails at once, not after the minutes of
// fitting whose result it would then lose. It cannot foresee a disk that
// fills up meanwhile: OutputFile still reports that when it happens.
void check_output_path(const std::filesystem::path& path, const std::string& option);

}  // namespace skidimm

#endif  // SKIDIMM_IO_OUTPUT_FILE_H_
