// Loads a shared library from a private, in-memory copy of its file.
//
//   std::string error;
//   std::shared_ptr<boost::dll::shared_library> library = load_private_copy(path, &error);
//   if (!library) ...  // error names the file and what is wrong with it
//
// Why: dlopen maps the file itself. If the file is later rewritten in place
// (`cp new.so old.so` truncates and rewrites the same inode) or was truncated
// to begin with (a copy still in progress, a full disk), touching a mapped page
// past the file's new end is SIGBUS: the process dies in the middle of a run,
// or while merely listing plugins. Here the file is read once with read()
// (never mapped), its ELF headers are checked (every loadable segment must lie
// inside the file, so a truncated file is refused with a message instead of
// crashing), and the bytes are loaded from an anonymous memory file
// (memfd_create, /proc/self/fd/N). Nothing done to the original file after
// that can reach the loaded code.
//
// Fallback: where memfd is unavailable, or the copy cannot be loaded (a
// library that finds its own dependencies through $ORIGIN, say), the original
// file is loaded after the same checks; it is then only protected against
// truncation found at load time. Replace plugin files with `mv` or `install`
// (a new inode), never `cp` over them.
//
// The memory file stays open as long as the library is loaded, so its
// /proc/self/fd/N name cannot be reused for another library while this one is
// known to the dynamic loader by that name. Not thread safe, like dlopen's
// name lookup it relies on: load from one thread.
#ifndef SKIDIMM_SDK_PRIVATE_LIBRARY_H_
#define SKIDIMM_SDK_PRIVATE_LIBRARY_H_

#include <dlfcn.h>
#include <elf.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <boost/dll/shared_library.hpp>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

namespace skidimm {
namespace sdk {
namespace internal {

template <typename Header, typename ProgramHeader>
bool check_elf_segments(const std::vector<unsigned char>& bytes, std::string* error) {
  const std::uint64_t size = bytes.size();
  if (size < sizeof(Header)) {
    *error = "the file is " + std::to_string(size) + " bytes long, shorter than an ELF header";
    return false;
  }
  Header header;
  std::memcpy(&header, bytes.data(), sizeof(Header));
  if (header.e_phnum == 0) {
    *error = "the ELF file has no program headers (not a shared library)";
    return false;
  }
  if (header.e_phentsize != sizeof(ProgramHeader)) {
    *error = "the ELF program header size is " + std::to_string(header.e_phentsize) + ", expected " +
             std::to_string(sizeof(ProgramHeader));
    return false;
  }
  const std::uint64_t table_end = std::uint64_t{header.e_phoff} + std::uint64_t{header.e_phnum} * sizeof(ProgramHeader);
  if (header.e_phoff > size || table_end > size) {
    *error = "truncated: its ELF program headers end at byte " + std::to_string(table_end) + " but the file has " +
             std::to_string(size) + " bytes";
    return false;
  }
  for (int i = 0; i < header.e_phnum; ++i) {
    ProgramHeader segment;
    std::memcpy(&segment, bytes.data() + header.e_phoff + std::uint64_t(i) * sizeof(ProgramHeader),
                sizeof(ProgramHeader));
    if (segment.p_type != PT_LOAD && segment.p_type != PT_DYNAMIC) continue;
    const std::uint64_t offset = segment.p_offset, length = segment.p_filesz;
    if (offset > size || length > size - offset) {
      *error = "truncated: its ELF segment " + std::to_string(i) + " needs bytes up to " +
               std::to_string(offset + length) + " but the file has " + std::to_string(size) +
               " (was it copied while being written? replace plugin files with mv or install, not cp)";
      return false;
    }
  }
  return true;
}

// Checks that `bytes` is an ELF shared object of this machine's class and byte
// order whose loadable segments all lie inside the file.
inline bool check_elf_file(const std::vector<unsigned char>& bytes, std::string* error) {
  if (bytes.size() < EI_NIDENT || std::memcmp(bytes.data(), ELFMAG, SELFMAG) != 0) {
    *error = bytes.empty() ? "the file is empty" : "not an ELF file";
    return false;
  }
  const bool little_endian = [] {
    const std::uint16_t one = 1;
    unsigned char first;
    std::memcpy(&first, &one, 1);
    return first == 1;
  }();
  if (bytes[EI_DATA] != (little_endian ? ELFDATA2LSB : ELFDATA2MSB)) {
    *error = "an ELF file of the other byte order";
    return false;
  }
  if (bytes[EI_CLASS] == ELFCLASS64) return check_elf_segments<Elf64_Ehdr, Elf64_Phdr>(bytes, error);
  if (bytes[EI_CLASS] == ELFCLASS32) return check_elf_segments<Elf32_Ehdr, Elf32_Phdr>(bytes, error);
  *error = "an ELF file of unknown class";
  return false;
}

// The whole file by read(): a file truncated meanwhile gives a short read, never SIGBUS.
inline bool read_whole_file(const std::filesystem::path& path, std::vector<unsigned char>* bytes, std::string* error) {
  // O_NONBLOCK: opening a FIFO would otherwise wait for a writer forever; it
  // is then refused by the check below, like any file that is not regular.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (fd < 0) {
    *error = std::string("cannot open: ") + std::strerror(errno);
    return false;
  }
  struct stat status {};
  if (::fstat(fd, &status) != 0 || !S_ISREG(status.st_mode)) {
    ::close(fd);
    *error = "not a regular file";
    return false;
  }
  bytes->clear();
  bytes->reserve(static_cast<std::size_t>(status.st_size));
  unsigned char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      *error = std::string("cannot read: ") + std::strerror(errno);
      ::close(fd);
      return false;
    }
    if (n == 0) break;
    bytes->insert(bytes->end(), buffer, buffer + n);
  }
  ::close(fd);
  return true;
}

inline bool write_all(int fd, const std::vector<unsigned char>& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

// True if the dynamic loader already knows a library by this name.
inline bool name_in_use(const std::string& name) {
  void* handle = ::dlopen(name.c_str(), RTLD_LAZY | RTLD_LOCAL | RTLD_NOLOAD);
  if (handle == nullptr) return false;
  ::dlclose(handle);
  return true;
}

// Boost.DLL's message ends with errno text that has nothing to do with dlopen.
inline std::string load_message(const std::exception& e) {
  std::string message = e.what();
  if (const auto* system = dynamic_cast<const std::system_error*>(&e)) {
    const std::string noise = ": " + system->code().message();
    if (message.size() > noise.size() && message.compare(message.size() - noise.size(), noise.size(), noise) == 0) {
      message.resize(message.size() - noise.size());
    }
  }
  return message;
}

inline bool load_into(boost::dll::shared_library* library, const std::string& name, std::string* error) {
  try {
    library->load(name, boost::dll::load_mode::rtld_now | boost::dll::load_mode::rtld_local);
  } catch (const std::exception& e) {
    *error = load_message(e);
    return false;
  }
  return true;
}

// A memfd holding `bytes`, at a descriptor whose /proc/self/fd name no loaded
// library carries; -1 if memfd is unavailable.
inline int private_memory_file(const std::filesystem::path& path, const std::vector<unsigned char>& bytes) {
#ifdef MFD_CLOEXEC
  const std::string label = "skidimm-plugin:" + path.filename().string();
  int fd = ::memfd_create(label.c_str(), MFD_CLOEXEC);
  if (fd < 0) return -1;
  if (!write_all(fd, bytes)) {
    ::close(fd);
    return -1;
  }
  // A library that could not be unloaded (GNU unique symbols) keeps its name;
  // move to a descriptor number no library is known by.
  for (int attempt = 0; attempt < 64 && name_in_use("/proc/self/fd/" + std::to_string(fd)); ++attempt) {
    const int moved = ::fcntl(fd, F_DUPFD_CLOEXEC, fd + 1);
    ::close(fd);
    if (moved < 0) return -1;
    fd = moved;
  }
  return fd;
#else
  (void)path;
  (void)bytes;
  return -1;
#endif
}

}  // namespace internal

// Loads `path` (RTLD_NOW | RTLD_LOCAL) from a private copy. On failure returns
// nullptr and sets *error to why, naming the file.
inline std::shared_ptr<boost::dll::shared_library> load_private_copy(const std::filesystem::path& path,
                                                                     std::string* error) {
  std::string local_error;
  if (error == nullptr) error = &local_error;
  std::vector<unsigned char> bytes;
  if (!internal::read_whole_file(path, &bytes, error) || !internal::check_elf_file(bytes, error)) {
    *error = path.string() + ": " + *error;
    return nullptr;
  }

  const int fd = internal::private_memory_file(path, bytes);
  if (fd >= 0) {
    const std::string name = "/proc/self/fd/" + std::to_string(fd);
    std::string copy_error;
    auto* copy = new boost::dll::shared_library();
    if (internal::load_into(copy, name, &copy_error)) {
      return std::shared_ptr<boost::dll::shared_library>(copy, [fd, name](boost::dll::shared_library* library) {
        delete library;  // dlclose
        // Still loaded (pinned by GNU unique symbols): the loader still knows
        // it as `name`, so the number must not go to another library.
        if (!internal::name_in_use(name)) ::close(fd);
      });
    }
    delete copy;
    ::close(fd);
  }
  // No memfd, or the copy would not load: the original file, which passed the checks.
  auto original = std::make_shared<boost::dll::shared_library>();
  if (!internal::load_into(original.get(), path.string(), error)) return nullptr;
  return original;
}

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_PRIVATE_LIBRARY_H_
