// Constants of the MCAP format (https://mcap.dev/spec), shared by the reader
// and the writer.
#ifndef SKIDIMM_CORE_SRC_ROS_MCAP_FORMAT_H_
#define SKIDIMM_CORE_SRC_ROS_MCAP_FORMAT_H_

#include <cstdint>

namespace skidimm {
namespace ros {
namespace mcap {

// "\x89MCAP0\r\n": at the start and at the end of every file.
constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
constexpr std::size_t kRecordPrefix = 9;  // opcode (1) and content length (8)
constexpr std::size_t kFooterContent = 20;  // summary_start, summary_offset_start, summary_crc

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

}  // namespace mcap
}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_MCAP_FORMAT_H_
