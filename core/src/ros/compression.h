// The compressions of MCAP chunks and rosbag2 messages: "zstd" (a Zstandard
// frame, libzstd) and "lz4" (an LZ4 frame, liblz4's frame format, not a raw
// block), and "" for none.
#ifndef SKIDIMM_CORE_SRC_ROS_COMPRESSION_H_
#define SKIDIMM_CORE_SRC_ROS_COMPRESSION_H_

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace skidimm {
namespace ros {

// Why bytes could not be decompressed (corrupt data, a size that does not
// match, an unknown compression). Callers add the file and record.
class CompressionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Whether `compression` is one this code reads ("", "zstd", "lz4").
bool is_supported_compression(std::string_view compression);

// Decompresses `size` bytes of `compression` into *out, which is resized to
// `expected_size`, the size the container recorded. Throws CompressionError
// unless the data decompresses to exactly that many bytes. Never allocates
// more than `expected_size` (a corrupt size field is checked by the caller
// against the file's size).
void decompress(std::string_view compression, const std::uint8_t* data, std::size_t size, std::size_t expected_size,
                std::vector<std::uint8_t>* out);

// Compresses [data, data + size) with "zstd" (at `level`) or "lz4" into *out.
void compress(std::string_view compression, const std::uint8_t* data, std::size_t size, int level,
              std::vector<std::uint8_t>* out);

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_COMPRESSION_H_
