// The loaders read files, libFuzzer hands out bytes: each input is written to
// a file of this process (on /dev/shm when it exists, so no disk is touched)
// under a name with the loader's extension, and every load reads it back.
#ifndef SKIDIMM_TESTS_FUZZ_FUZZ_INPUT_FILE_H_
#define SKIDIMM_TESTS_FUZZ_FUZZ_INPUT_FILE_H_

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace skidimm_fuzz {

inline std::filesystem::path input_file(const char* extension) {
  std::error_code ec;
  const std::filesystem::path dir =
      std::filesystem::is_directory("/dev/shm", ec) ? std::filesystem::path("/dev/shm") : std::filesystem::temp_directory_path();
  return dir / ("skidimm_fuzz_" + std::to_string(::getpid()) + extension);
}

// Writes the input to `file`; aborts (a harness failure, not a finding) if it
// cannot.
inline void write_input(const std::filesystem::path& file, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) {
    std::fprintf(stderr, "fuzz harness: cannot write %s\n", file.c_str());
    std::abort();
  }
}

}  // namespace skidimm_fuzz

#endif  // SKIDIMM_TESTS_FUZZ_FUZZ_INPUT_FILE_H_
