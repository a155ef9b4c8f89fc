// ByteCursor: little-endian fields read from a span of bytes with bounds
// checks, for the binary records of MCAP (mcap_reader.cc) and the Foxglove
// WebSocket protocol. A read past the end throws ByteCursor::Short naming
// the field, which the caller turns into an error naming the file and record.
#ifndef SKIDIMM_CORE_SRC_ROS_BYTE_CURSOR_H_
#define SKIDIMM_CORE_SRC_ROS_BYTE_CURSOR_H_

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

namespace skidimm {
namespace ros {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "MCAP and CDR readers assume a little-endian host");

class ByteCursor {
 public:
  struct Short : std::runtime_error {
    using std::runtime_error::runtime_error;
  };

  ByteCursor(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  std::size_t position() const { return position_; }
  std::size_t remaining() const { return size_ - position_; }
  const std::uint8_t* here() const { return data_ + position_; }

  template <typename T>
  T read(const char* field) {
    need(sizeof(T), field);
    T value;
    std::memcpy(&value, data_ + position_, sizeof(T));
    position_ += sizeof(T);
    return value;
  }
  std::uint8_t u8(const char* field) { return read<std::uint8_t>(field); }
  std::uint16_t u16(const char* field) { return read<std::uint16_t>(field); }
  std::uint32_t u32(const char* field) { return read<std::uint32_t>(field); }
  std::uint64_t u64(const char* field) { return read<std::uint64_t>(field); }
  // A string with a uint32 byte length before it.
  std::string string(const char* field) {
    const std::uint32_t n = u32(field);
    need(n, field);
    std::string out(reinterpret_cast<const char*>(data_ + position_), n);
    position_ += n;
    return out;
  }
  // `n` bytes, as a pointer into the span.
  const std::uint8_t* bytes(std::uint64_t n, const char* field) {
    need(n, field);
    const std::uint8_t* out = data_ + position_;
    position_ += static_cast<std::size_t>(n);
    return out;
  }
  void need(std::uint64_t n, const char* field) const {
    if (n > size_ - position_) {
      throw Short(std::string(field) + " needs " + std::to_string(n) + " bytes, " + std::to_string(size_ - position_) +
                  " left in the record");
    }
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t position_ = 0;
};

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_BYTE_CURSOR_H_
