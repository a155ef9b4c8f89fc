#include "skidimm/io/output_file.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <fstream>
#include <string>
#include <vector>

#include "core/temp_files.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace {

using ::testing::HasSubstr;
using skidimm_test::read_file;
using skidimm_test::test_directory;
using skidimm_test::write_file;
namespace fs = std::filesystem;

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "<no error>";
}

// Every write to a regular file fails with EFBIG while one lives, as writes
// onto a full disk fail with ENOSPC.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &saved_);
    previous_ = std::signal(SIGXFSZ, SIG_IGN);
    rlimit limit = saved_;
    limit.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &limit);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &saved_);
    std::signal(SIGXFSZ, previous_);
  }

 private:
  rlimit saved_{};
  void (*previous_)(int) = nullptr;
};

TEST(OutputFile, ARegularFileAppearsWholeOnCommitOnly) {
  const fs::path dir = test_directory();
  {
    OutputFile out(dir / "a.txt");
    EXPECT_FALSE(out.direct());
    EXPECT_EQ(out.written_path(), dir / "a.txt.partial");
    out.write("hello ");
    out.write("world");
    EXPECT_FALSE(fs::exists(dir / "a.txt"));
    out.commit();
  }
  EXPECT_EQ(read_file(dir / "a.txt"), "hello world");
  EXPECT_FALSE(fs::exists(dir / "a.txt.partial"));
  {
    OutputFile abandoned(dir / "b.txt");
    abandoned.write("half");
  }
  EXPECT_FALSE(fs::exists(dir / "b.txt")) << "not committed: nothing under the final name";
  EXPECT_FALSE(fs::exists(dir / "b.txt.partial")) << "and no leftover";
  {
    OutputFile kept(dir / "c.txt");
    kept.write("rows so far");
    kept.keep_partial();
  }
  EXPECT_EQ(read_file(dir / "c.txt.partial"), "rows so far");
}

// Two writers of one output (two runs with the same --output) never share a
// temporary file: each creates its own exclusively and renames only it.
TEST(OutputFile, WritersOfOneOutputEachHaveTheirOwnTemporaryFile) {
  const fs::path dir = test_directory();
  {
    OutputFile first(dir / "out.csv");
    OutputFile second(dir / "out.csv");
    EXPECT_EQ(first.written_path(), dir / "out.csv.partial");
    EXPECT_NE(second.written_path(), first.written_path());
    EXPECT_THAT(second.written_path().string(), HasSubstr("out.csv.partial." + std::to_string(::getpid()) + "-"));
    first.write("first, whole\n");
    second.write("second, whole\n");
    first.write("first, end\n");
    second.commit();
    EXPECT_EQ(read_file(dir / "out.csv"), "second, whole\n");
    first.commit();
  }
  EXPECT_EQ(read_file(dir / "out.csv"), "first, whole\nfirst, end\n") << "the last commit wins, never a mix";
  // A temporary file left by a killed run is neither truncated nor renamed.
  write_file(dir / "left.csv.partial", "a killed run's rows");
  {
    OutputFile out(dir / "left.csv");
    EXPECT_NE(out.written_path(), dir / "left.csv.partial");
    out.write("new");
    out.commit();
  }
  EXPECT_EQ(read_file(dir / "left.csv"), "new");
  EXPECT_EQ(read_file(dir / "left.csv.partial"), "a killed run's rows");
  // A symlink at the temporary name is not followed.
  fs::create_symlink(dir / "elsewhere.txt", dir / "link.csv.partial");
  {
    OutputFile out(dir / "link.csv");
    out.write("x");
    out.commit();
  }
  EXPECT_FALSE(fs::exists(dir / "elsewhere.txt"));
  EXPECT_EQ(read_file(dir / "link.csv"), "x");
  // A directory is not a file to write.
  EXPECT_THAT(error_of([&] { OutputFile out(dir); }), HasSubstr(dir.string() + ": is a directory"));
}

TEST(OutputFile, AFailedWriteNamesTheReasonAndLeavesNoFile) {
  const fs::path dir = test_directory();
  write_file(dir / "old.txt", "the previous content");
  {
    const FileSizeLimit limit(4);
    OutputFile out(dir / "old.txt");
    out.keep_partial();  // even so: a file cut at a write failure is not kept
    EXPECT_EQ(error_of([&] { out.write("more than four bytes"); }),
              (dir / "old.txt.partial").string() + ": cannot write: File too large (nothing was written to " +
                  (dir / "old.txt").string() + ")");
    EXPECT_THAT(error_of([&] { out.commit(); }), HasSubstr("commit after a failed write"));
  }
  EXPECT_EQ(read_file(dir / "old.txt"), "the previous content");
  EXPECT_FALSE(fs::exists(dir / "old.txt.partial"));
  const FileSizeLimit limit(0);
  EXPECT_THAT(error_of([&] { write_file_atomically(dir / "new.yaml", "a: 1\n"); }),
              HasSubstr("new.yaml.partial: cannot write: File too large"));
  EXPECT_FALSE(fs::exists(dir / "new.yaml"));
  EXPECT_FALSE(fs::exists(dir / "new.yaml.partial"));
}

TEST(OutputFile, DevicesAndFifosAreWrittenInPlace) {
  {
    OutputFile null("/dev/null");
    EXPECT_TRUE(null.direct());
    null.write("discarded");
    null.commit();
  }
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  EXPECT_FALSE(fs::exists("/dev/null.partial"));
  OutputFile full("/dev/full");
  EXPECT_EQ(error_of([&] { full.write("x"); }), "/dev/full: cannot write: No space left on device");
  EXPECT_TRUE(fs::is_character_file("/dev/full"));
  EXPECT_TRUE(OutputFile::writes_directly("-"));
  const fs::path dir = test_directory();
  EXPECT_FALSE(OutputFile::writes_directly(dir / "new.csv"));
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  EXPECT_TRUE(OutputFile::writes_directly(dir / "fifo"));
}

TEST(OutputFile, ACheckThatThrowsLeavesTheOldFileAndNoTemporary) {
  const fs::path dir = test_directory();
  write_file(dir / "bank.yaml", "old");
  EXPECT_EQ(error_of([&] {
              write_file_atomically(
                  dir / "bank.yaml", "new",
                  [](const fs::path& written) {
                    EXPECT_EQ(read_file(written), "new") << "the bytes are in the file when it is checked";
                    throw Error("invalid");
                  },
                  ".tmp");
            }),
            "invalid");
  EXPECT_EQ(read_file(dir / "bank.yaml"), "old");
  EXPECT_FALSE(fs::exists(dir / "bank.yaml.tmp"));
}

// The path the user gave, not the temporary file's, and what to do.
TEST(OutputFile, AMissingDirectoryIsNamedAsTheUserGaveIt) {
  EXPECT_EQ(error_of([] { OutputFile out("/nonexistent-directory/x.csv"); }),
            "/nonexistent-directory/x.csv: cannot write it: the directory /nonexistent-directory does not exist; "
            "make it first, or give a path in a directory that does");
  const fs::path file = test_directory() / "a_file";
  std::ofstream(file) << "not a directory";
  EXPECT_THAT(error_of([&] { OutputFile out(file / "x.csv"); }),
              HasSubstr((file / "x.csv").string() + ": cannot write it (its temporary file " +
                        (file / "x.csv.partial").string() + "): Not a directory"));
}

TEST(OutputFile, AnOutputPathIsCheckedWithoutLeavingAFileOrTouchingTheOldOne) {
  const fs::path dir = test_directory();
  const fs::path missing = dir / "missing" / "x.yaml";
  EXPECT_EQ(error_of([&] { check_output_path(missing, "--output-bank"); }),
            "--output-bank " + missing.string() + ": cannot write there: No such file or directory");
  EXPECT_EQ(error_of([&] { check_output_path(dir, "--table"); }),
            "--table " + dir.string() + ": is a directory; give the name of a file to write");
  // A file in a directory that cannot hold one (root may write anywhere else).
  EXPECT_THAT(error_of([&] { check_output_path("/proc/skidimm.yaml", "--output-bank"); }),
              HasSubstr("--output-bank /proc/skidimm.yaml: cannot write there: "));
  write_file(dir / "old.yaml", "old");
  check_output_path(dir / "old.yaml", "--output-bank");
  check_output_path(dir / "new.yaml", "--output-bank");
  check_output_path("-", "--output");
  check_output_path("/dev/null", "--output");
  // A FIFO without a reader: opened, it would block; it is taken as it is.
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  check_output_path(dir / "fifo", "--output");
  EXPECT_EQ(read_file(dir / "old.yaml"), "old");
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"fifo", "old.yaml"}));
}

}  // namespace
}  // namespace skidimm
