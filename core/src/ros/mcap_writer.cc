#include "mcap_writer.h"

#include <cstring>

#include "compression.h"
#include "crc32.h"
#include "mcap_format.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace ros {

namespace {

// Little-endian fields appended to a record's content.
struct Bytes {
  std::string s;
  Bytes& u8(std::uint8_t v) {
    s.push_back(static_cast<char>(v));
    return *this;
  }
  Bytes& u16(std::uint16_t v) { return raw(&v, 2); }
  Bytes& u32(std::uint32_t v) { return raw(&v, 4); }
  Bytes& u64(std::uint64_t v) { return raw(&v, 8); }
  Bytes& raw(const void* p, std::size_t n) {
    s.append(static_cast<const char*>(p), n);
    return *this;
  }
  Bytes& str(const std::string& v) {
    u32(static_cast<std::uint32_t>(v.size()));
    s += v;
    return *this;
  }
  Bytes& map(const std::vector<std::pair<std::string, std::string>>& m) {
    Bytes inner;
    for (const auto& [k, v] : m) inner.str(k).str(v);
    return u32(static_cast<std::uint32_t>(inner.s.size())).raw(inner.s.data(), inner.s.size());
  }
};

std::string record(std::uint8_t opcode, const std::string& content) {
  Bytes r;
  r.u8(opcode).u64(content.size());
  r.s += content;
  return r.s;
}

}  // namespace

McapWriter::McapWriter(const std::filesystem::path& path, Options options)
    : out_(std::make_unique<OutputFile>(path)), options_(std::move(options)) {
  if (!is_supported_compression(options_.compression)) {
    throw Error(path.string() + ": unknown MCAP chunk compression '" + options_.compression + "'");
  }
  put(std::string(reinterpret_cast<const char*>(mcap::kMagic), sizeof(mcap::kMagic)));
  put(record(mcap::kHeader, Bytes().str(options_.profile).str(options_.library).s));
}

McapWriter::~McapWriter() {
  if (finished_) return;
  // An error upstream: finish what was written, keep it as .partial.
  try {
    finish();
    out_->keep_partial();
  } catch (...) {
  }
}

void McapWriter::put(const std::string& bytes) {
  out_->write(bytes);
  offset_ += bytes.size();
  data_crc_ = crc32(data_crc_, bytes.data(), bytes.size());
}

std::uint16_t McapWriter::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  const std::uint16_t id = next_schema_++;
  Bytes b;
  b.u16(id).str(name).str(encoding).u32(static_cast<std::uint32_t>(data.size()));
  b.s += data;
  const std::string r = record(mcap::kSchema, b.s);
  schemas_.push_back(r);
  chunk_records_ += r;
  return id;
}

std::uint16_t McapWriter::add_channel(const std::string& topic, const std::string& message_encoding,
                                      std::uint16_t schema_id,
                                      const std::vector<std::pair<std::string, std::string>>& metadata) {
  const std::uint16_t id = next_channel_++;
  const std::string r = record(mcap::kChannel, Bytes().u16(id).u16(schema_id).str(topic).str(message_encoding).map(metadata).s);
  channels_.push_back(r);
  chunk_records_ += r;
  return id;
}

void McapWriter::write(std::uint16_t channel, std::uint64_t log_time, std::uint64_t publish_time, const void* data,
                       std::size_t size) {
  chunk_index_[channel].emplace_back(log_time, chunk_records_.size());
  Bytes b;
  b.u8(mcap::kMessage).u64(22 + size).u16(channel).u32(static_cast<std::uint32_t>(channel_counts_[channel]));
  b.u64(log_time).u64(publish_time).raw(data, size);
  chunk_records_ += b.s;
  if (!chunk_has_messages_ || log_time < chunk_start_) chunk_start_ = log_time;
  if (!chunk_has_messages_ || log_time > chunk_end_) chunk_end_ = log_time;
  chunk_has_messages_ = true;
  if (message_count_ == 0 || log_time < start_time_) start_time_ = log_time;
  if (message_count_ == 0 || log_time > end_time_) end_time_ = log_time;
  ++message_count_;
  ++channel_counts_[channel];
  if (chunk_records_.size() >= options_.chunk_size) flush_chunk();
}

void McapWriter::flush_chunk() {
  if (chunk_records_.empty()) return;
  const std::uint32_t crc = crc32(0, chunk_records_.data(), chunk_records_.size());
  std::vector<std::uint8_t> compressed;
  compress(options_.compression, reinterpret_cast<const std::uint8_t*>(chunk_records_.data()), chunk_records_.size(),
           options_.compression == "zstd" ? 3 : 0, &compressed);
  Bytes c;
  c.u64(chunk_start_).u64(chunk_end_).u64(chunk_records_.size()).u32(crc).str(options_.compression);
  c.u64(compressed.size()).raw(compressed.data(), compressed.size());
  ChunkIndex index;
  index.start_time = chunk_start_;
  index.end_time = chunk_end_;
  index.offset = offset_;
  const std::string chunk = record(mcap::kChunk, c.s);
  index.length = chunk.size();
  index.compressed_size = compressed.size();
  index.uncompressed_size = chunk_records_.size();
  put(chunk);
  const std::uint64_t indexes_start = offset_;
  for (const auto& [channel, entries] : chunk_index_) {
    index.message_index_offsets.emplace_back(channel, offset_);
    Bytes array;
    for (const auto& [time, at] : entries) array.u64(time).u64(at);
    put(record(mcap::kMessageIndex, Bytes().u16(channel).u32(static_cast<std::uint32_t>(array.s.size())).s + array.s));
  }
  index.message_index_length = offset_ - indexes_start;
  chunks_.push_back(std::move(index));
  chunk_records_.clear();
  chunk_index_.clear();
  chunk_has_messages_ = false;
}

void McapWriter::finish() {
  finished_ = true;
  flush_chunk();
  put(record(mcap::kDataEnd, Bytes().u32(data_crc_).s));
  // The summary: each group of records, with a SummaryOffset to it.
  const std::uint64_t summary_start = offset_;
  std::uint32_t summary_crc = 0;
  auto put_summary = [&](const std::string& bytes) {
    out_->write(bytes);
    offset_ += bytes.size();
    summary_crc = crc32(summary_crc, bytes.data(), bytes.size());
  };
  std::vector<std::tuple<std::uint8_t, std::uint64_t, std::uint64_t>> groups;
  auto group = [&](std::uint8_t opcode, const std::vector<std::string>& records) {
    if (records.empty()) return;
    const std::uint64_t start = offset_;
    for (const std::string& r : records) put_summary(r);
    groups.emplace_back(opcode, start, offset_ - start);
  };
  group(mcap::kSchema, schemas_);
  group(mcap::kChannel, channels_);
  {
    Bytes s;
    s.u64(message_count_).u16(static_cast<std::uint16_t>(schemas_.size())).u32(static_cast<std::uint32_t>(channels_.size()));
    s.u32(0).u32(0).u32(static_cast<std::uint32_t>(chunks_.size())).u64(start_time_).u64(end_time_);
    Bytes counts;
    for (const auto& [channel, n] : channel_counts_) counts.u16(channel).u64(n);
    s.u32(static_cast<std::uint32_t>(counts.s.size())).raw(counts.s.data(), counts.s.size());
    group(mcap::kStatistics, {record(mcap::kStatistics, s.s)});
  }
  std::vector<std::string> chunk_indexes;
  for (const ChunkIndex& c : chunks_) {
    Bytes b;
    b.u64(c.start_time).u64(c.end_time).u64(c.offset).u64(c.length);
    Bytes offsets;
    for (const auto& [channel, at] : c.message_index_offsets) offsets.u16(channel).u64(at);
    b.u32(static_cast<std::uint32_t>(offsets.s.size())).raw(offsets.s.data(), offsets.s.size());
    b.u64(c.message_index_length).str(options_.compression).u64(c.compressed_size).u64(c.uncompressed_size);
    chunk_indexes.push_back(record(mcap::kChunkIndex, b.s));
  }
  group(mcap::kChunkIndex, chunk_indexes);
  const std::uint64_t summary_offset_start = offset_;
  for (const auto& [opcode, start, length] : groups) {
    put_summary(record(mcap::kSummaryOffset, Bytes().u8(opcode).u64(start).u64(length).s));
  }
  // The Footer: its CRC covers the summary up to the CRC field itself.
  Bytes footer_head;
  footer_head.u8(mcap::kFooter).u64(mcap::kFooterContent).u64(summary_start).u64(summary_offset_start);
  summary_crc = crc32(summary_crc, footer_head.s.data(), footer_head.s.size());
  out_->write(footer_head.s + Bytes().u32(summary_crc).s);
  out_->write(std::string(reinterpret_cast<const char*>(mcap::kMagic), sizeof(mcap::kMagic)));
}

void McapWriter::commit() {
  finish();
  out_->commit();
}

}  // namespace ros
}  // namespace skidimm
