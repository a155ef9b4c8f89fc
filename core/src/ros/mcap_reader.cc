#include "mcap_reader.h"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "byte_cursor.h"
#include "compression.h"
#include "crc32.h"
#include "mcap_format.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace ros {

namespace {

// A chunk may decompress to at most this; more is a corrupt size field (rosbag2
// writes chunks of about 1 MiB).
constexpr std::uint64_t kMaxChunkSize = std::uint64_t{1} << 30;

std::string bytes_text(std::uint64_t n) { return std::to_string(n) + (n == 1 ? " byte" : " bytes"); }

}  // namespace

std::string mcap_opcode_name(std::uint8_t opcode) {
  static const char* const kNames[] = {"?",          "Header",      "Footer",          "Schema",     "Channel",
                                       "Message",    "Chunk",       "MessageIndex",    "ChunkIndex", "Attachment",
                                       "AttachmentIndex", "Statistics", "Metadata",    "MetadataIndex",
                                       "SummaryOffset", "DataEnd"};
  if (opcode >= 1 && opcode <= 0x0F) return kNames[opcode];
  return "unknown opcode " + std::to_string(opcode);
}

void McapReader::fail(std::uint64_t offset, const std::string& what) const {
  throw LogError(path_.string(), 0, "byte " + std::to_string(offset) + ": " + what);
}

McapReader::McapReader(const std::filesystem::path& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "rb");
  if (file_ == nullptr) throw LogError(path.string(), 0, std::string("cannot open: ") + std::strerror(errno));
  try {
    std::error_code ec;
    file_size_ = std::filesystem::file_size(path, ec);
    if (ec) throw LogError(path.string(), 0, "cannot read its size: " + ec.message());
    std::uint8_t magic[8] = {};
    if (file_size_ < sizeof(magic) || std::fread(magic, 1, sizeof(magic), file_) != sizeof(magic) ||
        std::memcmp(magic, mcap::kMagic, sizeof(magic)) != 0) {
      throw LogError(path.string(), 0, "not an MCAP file: it does not start with MCAP's magic bytes (\\x89MCAP0)");
    }
    Record header;
    read_record(sizeof(magic), &header, false);
    if (header.opcode != mcap::kHeader) fail(8, "expected the Header record, found " + mcap_opcode_name(header.opcode));
    try {
      ByteCursor c(header.content.data(), header.content.size());
      profile_ = c.string("Header.profile");
      library_ = c.string("Header.library");
    } catch (const ByteCursor::Short& e) {
      fail(8, std::string("Header record: ") + e.what());
    }
    data_start_ = sizeof(magic) + mcap::kRecordPrefix + header.content.size();
    data_end_ = file_size_;

    // The footer: the last record before the closing magic.
    const std::uint64_t footer_size = mcap::kRecordPrefix + mcap::kFooterContent;
    bool summary_read = false;
    if (file_size_ >= data_start_ + footer_size + sizeof(magic)) {
      const std::uint64_t footer_offset = file_size_ - sizeof(magic) - footer_size;
      std::uint8_t tail[mcap::kRecordPrefix + mcap::kFooterContent + 8];
      if (std::fseek(file_, static_cast<long>(footer_offset), SEEK_SET) == 0 &&
          std::fread(tail, 1, sizeof(tail), file_) == sizeof(tail) &&
          std::memcmp(tail + footer_size, mcap::kMagic, sizeof(magic)) == 0 && tail[0] == mcap::kFooter) {
        ByteCursor c(tail + 1, footer_size - 1);
        const std::uint64_t length = c.u64("Footer.length");
        const std::uint64_t summary_start = c.u64("Footer.summary_start");
        c.u64("Footer.summary_offset_start");
        const std::uint32_t summary_crc = c.u32("Footer.summary_crc");
        if (length != mcap::kFooterContent) {
          fail(footer_offset, "Footer record of " + bytes_text(length) + ", expected " +
                                  bytes_text(mcap::kFooterContent));
        }
        data_end_ = footer_offset;
        footer_found_ = true;
        if (summary_start != 0) {
          if (summary_start < data_start_ || summary_start > footer_offset) {
            fail(footer_offset, "the Footer's summary_start " + std::to_string(summary_start) +
                                    " is outside the file's data (" + std::to_string(data_start_) + " to " +
                                    std::to_string(footer_offset) + ")");
          }
          // A summary that does not read (a byte flipped in it) costs the
          // index, not the data: the chunks are scanned, each checked by its
          // own CRC, instead of refusing a file whose messages are intact.
          try {
            read_summary(summary_start, footer_offset, summary_crc);
            data_end_ = summary_start;
            summary_read = true;
          } catch (const LogError& e) {
            schemas_.clear();
            channels_.clear();
            chunks_.clear();
            statistics_ = McapStatistics{};
            const std::string what = e.what();
            const auto at = what.find("byte ");
            mended_ = "its summary does not read (" + (at == std::string::npos ? what : what.substr(at)) +
                      "): read by a scan";
            // summary_start is among what the failed CRC covers: the scan
            // goes to the Footer, ending at the data section's DataEnd.
            data_end_ = footer_offset;
          }
        }
      }
    }
    has_summary_ = summary_read;
    if (!summary_read || chunks_.empty()) {
      indexed_ = false;
      scan_for_index();
    } else {
      indexed_ = true;
      std::stable_sort(chunks_.begin(), chunks_.end(), [](const ChunkLocation& a, const ChunkLocation& b) {
        return a.start_time != b.start_time ? a.start_time < b.start_time : a.offset < b.offset;
      });
    }
    rewind();
  } catch (...) {
    std::fclose(file_);
    file_ = nullptr;
    throw;
  }
}

McapReader::~McapReader() {
  if (file_ != nullptr) std::fclose(file_);
}

bool McapReader::read_record(std::uint64_t offset, Record* record, bool in_scan) {
  record->offset = offset;
  if (offset + mcap::kRecordPrefix > file_size_) {
    if (offset < file_size_ && std::fseek(file_, static_cast<long>(offset), SEEK_SET) == 0) {
      const int opcode = std::fgetc(file_);  // the record the file ends in, if its opcode is there
      if (opcode != EOF) cut_opcode_ = opcode;
    }
    fail(offset, "the file ends " + bytes_text(file_size_ - offset) +
                     " into a record's 9-byte opcode and length: it was cut short (a recording that was not "
                     "closed?)");
  }
  std::uint8_t prefix[mcap::kRecordPrefix];
  if (std::fseek(file_, static_cast<long>(offset), SEEK_SET) != 0 ||
      std::fread(prefix, 1, sizeof(prefix), file_) != sizeof(prefix)) {
    fail(offset, std::string("cannot read: ") + std::strerror(errno));
  }
  record->opcode = prefix[0];
  std::uint64_t length = 0;
  std::memcpy(&length, prefix + 1, 8);
  const std::uint64_t available = file_size_ - offset - mcap::kRecordPrefix;
  if (length > available) {
    cut_opcode_ = record->opcode;
    fail(offset, mcap_opcode_name(record->opcode) + " record of " + bytes_text(length) + ", but the file ends after " +
                     bytes_text(available) + ": it was cut short (a recording that was not closed?)");
  }
  record->content.resize(static_cast<std::size_t>(length));
  if (length > 0 && std::fread(record->content.data(), 1, record->content.size(), file_) != record->content.size()) {
    fail(offset, std::string("cannot read: ") + std::strerror(errno));
  }
  if (in_scan) {
    data_crc_ = crc32(data_crc_, prefix, sizeof(prefix));
    data_crc_ = crc32(data_crc_, record->content.data(), record->content.size());
  }
  bytes_done_ = offset + mcap::kRecordPrefix + length;
  return true;
}

void McapReader::add_schema(const std::uint8_t* data, std::size_t size, std::uint64_t offset) {
  McapSchema s;
  try {
    ByteCursor c(data, size);
    s.id = c.u16("Schema.id");
    s.name = c.string("Schema.name");
    s.encoding = c.string("Schema.encoding");
    const std::uint32_t n = c.u32("Schema.data length");
    const std::uint8_t* bytes = c.bytes(n, "Schema.data");
    s.data.assign(reinterpret_cast<const char*>(bytes), n);
  } catch (const ByteCursor::Short& e) {
    fail(offset, std::string("Schema record: ") + e.what());
  }
  if (s.id == 0) fail(offset, "Schema record with id 0 (reserved for 'no schema')");
  schemas_[s.id] = std::move(s);
}

void McapReader::add_channel(const std::uint8_t* data, std::size_t size, std::uint64_t offset) {
  McapChannel ch;
  try {
    ByteCursor c(data, size);
    ch.id = c.u16("Channel.id");
    ch.schema_id = c.u16("Channel.schema_id");
    ch.topic = c.string("Channel.topic");
    ch.message_encoding = c.string("Channel.message_encoding");
    const std::uint32_t map_size = c.u32("Channel.metadata length");
    c.need(map_size, "Channel.metadata");
    ByteCursor m(c.here(), map_size);
    while (m.remaining() > 0) {
      std::string key = m.string("Channel.metadata key");
      std::string value = m.string("Channel.metadata value");
      ch.metadata.emplace_back(std::move(key), std::move(value));
    }
  } catch (const ByteCursor::Short& e) {
    fail(offset, std::string("Channel record: ") + e.what());
  }
  channels_[ch.id] = std::move(ch);
}

void McapReader::read_summary(std::uint64_t summary_start, std::uint64_t footer_offset, std::uint32_t summary_crc) {
  // The summary section, the summary offset section and the Footer up to its CRC.
  const std::uint64_t length = footer_offset - summary_start;
  std::vector<std::uint8_t> summary(static_cast<std::size_t>(length) + mcap::kRecordPrefix + 16);
  if (std::fseek(file_, static_cast<long>(summary_start), SEEK_SET) != 0 ||
      std::fread(summary.data(), 1, summary.size(), file_) != summary.size()) {
    fail(summary_start, std::string("cannot read the summary: ") + std::strerror(errno));
  }
  if (summary_crc != 0) {
    const std::uint32_t crc = crc32(0, summary.data(), summary.size());
    if (crc != summary_crc) {
      fail(summary_start, "the summary section's CRC is " + std::to_string(crc) + ", but the Footer records " +
                              std::to_string(summary_crc) + ": the file is corrupt");
    }
  }
  std::size_t position = 0;
  while (position < length) {
    const std::uint64_t offset = summary_start + position;
    if (length - position < mcap::kRecordPrefix) fail(offset, "a record cut short in the summary section");
    const std::uint8_t opcode = summary[position];
    std::uint64_t size = 0;
    std::memcpy(&size, summary.data() + position + 1, 8);
    if (size > length - position - mcap::kRecordPrefix) {
      fail(offset, mcap_opcode_name(opcode) + " record of " + bytes_text(size) +
                       " runs past the end of the summary section");
    }
    const std::uint8_t* content = summary.data() + position + mcap::kRecordPrefix;
    try {
      ByteCursor c(content, static_cast<std::size_t>(size));
      switch (opcode) {
        case mcap::kSchema:
          add_schema(content, static_cast<std::size_t>(size), offset);
          break;
        case mcap::kChannel:
          add_channel(content, static_cast<std::size_t>(size), offset);
          break;
        case mcap::kStatistics: {
          statistics_.message_count = c.u64("Statistics.message_count");
          c.u16("Statistics.schema_count");
          c.u32("Statistics.channel_count");
          c.u32("Statistics.attachment_count");
          c.u32("Statistics.metadata_count");
          statistics_.chunk_count = c.u32("Statistics.chunk_count");
          statistics_.message_start_time = c.u64("Statistics.message_start_time");
          statistics_.message_end_time = c.u64("Statistics.message_end_time");
          const std::uint32_t map_size = c.u32("Statistics.channel_message_counts length");
          c.need(map_size, "Statistics.channel_message_counts");
          ByteCursor m(c.here(), map_size);
          while (m.remaining() > 0) {
            const std::uint16_t channel = m.u16("Statistics channel id");
            statistics_.channel_message_counts[channel] = m.u64("Statistics channel count");
          }
          break;
        }
        case mcap::kChunkIndex: {
          ChunkLocation chunk;
          chunk.start_time = c.u64("ChunkIndex.message_start_time");
          c.u64("ChunkIndex.message_end_time");
          chunk.offset = c.u64("ChunkIndex.chunk_start_offset");
          chunk.length = c.u64("ChunkIndex.chunk_length");
          const std::uint32_t map_size = c.u32("ChunkIndex.message_index_offsets length");
          c.bytes(map_size, "ChunkIndex.message_index_offsets");
          c.u64("ChunkIndex.message_index_length");
          const std::string compression = c.string("ChunkIndex.compression");
          if (chunk.offset < data_start_ || chunk.offset > summary_start ||
              chunk.length > summary_start - chunk.offset) {
            fail(offset, "ChunkIndex points at bytes " + std::to_string(chunk.offset) + " + " +
                             std::to_string(chunk.length) + ", outside the data section");
          }
          if (std::find(compressions_.begin(), compressions_.end(), compression) == compressions_.end()) {
            compressions_.push_back(compression);
          }
          chunks_.push_back(chunk);
          break;
        }
        default:
          break;  // indexes of attachments and metadata, summary offsets: not needed
      }
    } catch (const ByteCursor::Short& e) {
      fail(offset, mcap_opcode_name(opcode) + " record: " + e.what());
    }
    position += mcap::kRecordPrefix + static_cast<std::size_t>(size);
  }
  if (statistics_.chunk_count == 0) statistics_.chunk_count = static_cast<std::uint32_t>(chunks_.size());
}

// A file without a chunk index: every record once, for the schemas, the
// channels and the counts. A problem is kept for next() to throw where it is.
void McapReader::scan_for_index() {
  statistics_ = McapStatistics{};
  compressions_.clear();
  rewind();
  counting_ = true;
  bool first_time = true;
  McapMessage message;
  try {
    while (next(&message)) {
      ++statistics_.message_count;
      ++statistics_.channel_message_counts[message.channel_id];
      if (first_time || message.log_time < statistics_.message_start_time) {
        statistics_.message_start_time = message.log_time;
      }
      if (first_time || message.log_time > statistics_.message_end_time) {
        statistics_.message_end_time = message.log_time;
      }
      first_time = false;
    }
  } catch (const LogError&) {
    data_end_ = record_.offset;
    // Cut short inside a record that holds no message (a chunk's message
    // index, the summary being written as the recording closed): every
    // message the file has was read, so it is not an error. A file that has
    // its Footer was not cut: a record running past its end is corrupt.
    const bool holds_messages = cut_opcode_ == mcap::kChunk || cut_opcode_ == mcap::kMessage;
    if (cut_opcode_ >= 0 && !holds_messages && !footer_found_) {
      mended_ = "cut short inside a " + mcap_opcode_name(static_cast<std::uint8_t>(cut_opcode_)) +
                " record after its last message (a recording stopped while closing): every message read";
    } else {
      scan_error_ = std::current_exception();
    }
  }
  counting_ = false;
}

void McapReader::rewind() {
  next_chunk_ = 0;
  position_ = data_start_;
  finished_ = false;
  in_chunk_ = false;
  chunk_position_ = 0;
  bytes_done_ = 0;
  if (!indexed_) {
    std::vector<std::uint8_t> head(static_cast<std::size_t>(data_start_));
    if (std::fseek(file_, 0, SEEK_SET) != 0 || std::fread(head.data(), 1, head.size(), file_) != head.size()) {
      fail(0, std::string("cannot read: ") + std::strerror(errno));
    }
    data_crc_ = crc32(0, head.data(), head.size());
  }
}

void McapReader::load_chunk(const Record& record) {
  std::uint64_t uncompressed_size = 0;
  std::uint32_t uncompressed_crc = 0;
  std::string compression;
  const std::uint8_t* records = nullptr;
  std::uint64_t records_size = 0;
  try {
    ByteCursor c(record.content.data(), record.content.size());
    c.u64("Chunk.message_start_time");
    c.u64("Chunk.message_end_time");
    uncompressed_size = c.u64("Chunk.uncompressed_size");
    uncompressed_crc = c.u32("Chunk.uncompressed_crc");
    compression = c.string("Chunk.compression");
    records_size = c.u64("Chunk.records length");
    records = c.bytes(records_size, "Chunk.records");
  } catch (const ByteCursor::Short& e) {
    fail(record.offset, std::string("Chunk record: ") + e.what());
  }
  if (!indexed_ && std::find(compressions_.begin(), compressions_.end(), compression) == compressions_.end()) {
    compressions_.push_back(compression);
  }
  if (!is_supported_compression(compression)) {
    fail(record.offset, "Chunk compressed with '" + compression + "', which skidimm does not read (zstd, lz4, none)");
  }
  // A corrupt size field must not make us allocate gigabytes: no real chunk
  // decompresses to more than 4096 times its size.
  if (uncompressed_size > kMaxChunkSize ||
      (!compression.empty() && uncompressed_size > records_size * 4096 + (std::uint64_t{1} << 20))) {
    fail(record.offset, "Chunk claims " + bytes_text(uncompressed_size) + " uncompressed from " +
                            bytes_text(records_size) + ": a corrupt chunk");
  }
  try {
    decompress(compression, records, static_cast<std::size_t>(records_size), static_cast<std::size_t>(uncompressed_size),
               &chunk_);
  } catch (const CompressionError& e) {
    fail(record.offset, std::string("Chunk does not decompress: ") + e.what());
  }
  if (uncompressed_crc != 0) {
    const std::uint32_t crc = crc32(0, chunk_.data(), chunk_.size());
    if (crc != uncompressed_crc) {
      fail(record.offset, "Chunk's CRC is " + std::to_string(crc) + ", but the chunk records " +
                              std::to_string(uncompressed_crc) + ": the chunk is corrupt");
    }
  }
  chunk_position_ = 0;
  chunk_offset_ = record.offset;
  in_chunk_ = true;
}

// The next message of the current chunk; Schema and Channel records in it
// are taken on the way.
bool McapReader::next_in_chunk(McapMessage* message) {
  while (chunk_position_ < chunk_.size()) {
    const std::size_t left = chunk_.size() - chunk_position_;
    if (left < mcap::kRecordPrefix) {
      fail(chunk_offset_, "Chunk: a record cut short at byte " + std::to_string(chunk_position_) + " of its records");
    }
    const std::uint8_t opcode = chunk_[chunk_position_];
    std::uint64_t size = 0;
    std::memcpy(&size, chunk_.data() + chunk_position_ + 1, 8);
    if (size > left - mcap::kRecordPrefix) {
      fail(chunk_offset_, "Chunk: " + mcap_opcode_name(opcode) + " record at byte " + std::to_string(chunk_position_) +
                              " of its records runs past the chunk's end");
    }
    const std::uint8_t* content = chunk_.data() + chunk_position_ + mcap::kRecordPrefix;
    chunk_position_ += mcap::kRecordPrefix + static_cast<std::size_t>(size);
    switch (opcode) {
      case mcap::kSchema:
        add_schema(content, static_cast<std::size_t>(size), chunk_offset_);
        break;
      case mcap::kChannel:
        add_channel(content, static_cast<std::size_t>(size), chunk_offset_);
        break;
      case mcap::kMessage: {
        if (size < 22) fail(chunk_offset_, "Chunk: a Message record of " + bytes_text(size) + ", shorter than 22");
        std::memcpy(&message->channel_id, content, 2);
        std::memcpy(&message->sequence, content + 2, 4);
        std::memcpy(&message->log_time, content + 6, 8);
        std::memcpy(&message->publish_time, content + 14, 8);
        message->data = content + 22;
        message->size = static_cast<std::size_t>(size) - 22;
        if (channels_.find(message->channel_id) == channels_.end()) {
          fail(chunk_offset_, "Chunk: a message on channel " + std::to_string(message->channel_id) +
                                  ", which no Channel record defines");
        }
        return true;
      }
      default:
        break;
    }
  }
  in_chunk_ = false;
  return false;
}

bool McapReader::next(McapMessage* message) {
  for (;;) {
    if (in_chunk_ && next_in_chunk(message)) return true;
    if (finished_) return false;
    if (indexed_) {
      if (next_chunk_ >= chunks_.size()) {
        finished_ = true;
        bytes_done_ = file_size_;
        return false;
      }
      const ChunkLocation& chunk = chunks_[next_chunk_++];
      read_record(chunk.offset, &record_, false);
      if (record_.opcode != mcap::kChunk) {
        fail(chunk.offset, "the chunk index points at a " + mcap_opcode_name(record_.opcode) + " record, not a Chunk");
      }
      load_chunk(record_);
      continue;
    }
    // Scanning the data section record by record.
    if (position_ >= data_end_) {
      finished_ = true;
      bytes_done_ = file_size_;
      if (scan_error_) std::rethrow_exception(scan_error_);
      return false;
    }
    const std::uint32_t crc_before = data_crc_;
    read_record(position_, &record_, true);
    position_ += mcap::kRecordPrefix + record_.content.size();
    switch (record_.opcode) {
      case mcap::kSchema:
        add_schema(record_.content.data(), record_.content.size(), record_.offset);
        break;
      case mcap::kChannel:
        add_channel(record_.content.data(), record_.content.size(), record_.offset);
        break;
      case mcap::kMessage: {
        const auto& c = record_.content;
        if (c.size() < 22) fail(record_.offset, "Message record of " + bytes_text(c.size()) + ", shorter than 22");
        std::memcpy(&message->channel_id, c.data(), 2);
        std::memcpy(&message->sequence, c.data() + 2, 4);
        std::memcpy(&message->log_time, c.data() + 6, 8);
        std::memcpy(&message->publish_time, c.data() + 14, 8);
        message->data = c.data() + 22;
        message->size = c.size() - 22;
        if (channels_.find(message->channel_id) == channels_.end()) {
          fail(record_.offset, "Message on channel " + std::to_string(message->channel_id) +
                                   ", which no Channel record before it defines");
        }
        return true;
      }
      case mcap::kChunk:
        if (counting_) ++statistics_.chunk_count;
        load_chunk(record_);
        break;
      case mcap::kDataEnd: {
        std::uint32_t recorded = 0;
        if (record_.content.size() >= 4) std::memcpy(&recorded, record_.content.data(), 4);
        if (recorded != 0 && recorded != crc_before) {
          fail(record_.offset, "the data section's CRC is " + std::to_string(crc_before) + ", but DataEnd records " +
                                   std::to_string(recorded) + ": the file is corrupt");
        }
        finished_ = true;
        bytes_done_ = file_size_;
        break;
      }
      case mcap::kFooter:
        finished_ = true;
        bytes_done_ = file_size_;
        break;
      default:
        break;  // indexes, attachments, metadata, a summary without a footer
    }
  }
}

double McapReader::progress() const {
  return file_size_ == 0 ? 1.0 : std::min(1.0, static_cast<double>(bytes_done_) / static_cast<double>(file_size_));
}

}  // namespace ros
}  // namespace skidimm
