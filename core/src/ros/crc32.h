// CRC-32 as MCAP checks its chunks, data section and summary with it: the
// IEEE 802.3 polynomial (reflected 0xEDB88320), initial value and final XOR
// 0xFFFFFFFF, the checksum zlib's crc32() and gzip compute.
#ifndef SKIDIMM_CORE_SRC_ROS_CRC32_H_
#define SKIDIMM_CORE_SRC_ROS_CRC32_H_

#include <cstddef>
#include <cstdint>

namespace skidimm {
namespace ros {

// Continues `crc` (the value returned for the bytes before, 0 to start) over
// [data, data + size). crc32(crc32(0, a), b) == crc32 of a followed by b.
std::uint32_t crc32(std::uint32_t crc, const void* data, std::size_t size);

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_CRC32_H_
