// McapReader on files written by @mcap/core: every layout the writer has
// (zstd, lz4 and uncompressed chunks, no chunks, no summary), and the bad
// files of a user: cut short, a wrong CRC, a corrupt chunk.
#include "ros/mcap_reader.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include "core/temp_files.h"
#include "ros/crc32.h"
#include "ros/ros_fixtures.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace ros {
namespace {

using skidimm_test::first_record;
using skidimm_test::read_file;
using skidimm_test::records_of;
using skidimm_test::ros_fixture;
using skidimm_test::test_directory;
using skidimm_test::write_file;

struct Seen {
  std::vector<std::uint64_t> log_times;
  std::vector<std::string> payloads;
};

Seen read_all(McapReader& reader) {
  Seen seen;
  McapMessage m;
  while (reader.next(&m)) {
    seen.log_times.push_back(m.log_time);
    seen.payloads.emplace_back(reinterpret_cast<const char*>(m.data), m.size);
  }
  return seen;
}

TEST(Crc32, MatchesTheCheckValueOfTheStandard) {
  // CRC-32/ISO-HDLC's check value: the CRC of "123456789".
  EXPECT_EQ(crc32(0, "123456789", 9), 0xCBF43926u);
  // Continuing over two parts equals one pass.
  EXPECT_EQ(crc32(crc32(0, "12345", 5), "6789", 4), 0xCBF43926u);
  EXPECT_EQ(crc32(0, "", 0), 0u);
  const std::string long_text(1000, 'x');
  EXPECT_EQ(crc32(crc32(0, long_text.data(), 333), long_text.data() + 333, 667), crc32(0, long_text.data(), 1000));
}

// The bit-by-bit definition, against the folding and table paths crc32 takes
// for long and short inputs, at every length up to 3000 and four alignments.
TEST(Crc32, EqualsTheBitwiseDefinitionAtEveryLengthAndAlignment) {
  std::vector<unsigned char> bytes(4000);
  std::uint32_t state = 1;
  for (auto& b : bytes) b = static_cast<unsigned char>((state = state * 1103515245u + 12345u) >> 16);
  const auto bitwise = [](const unsigned char* p, std::size_t n) {
    std::uint32_t c = ~0u;
    for (std::size_t i = 0; i < n; ++i) {
      c ^= p[i];
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    }
    return ~c;
  };
  for (std::size_t n = 0; n <= 3000; ++n) {
    for (std::size_t offset : {0, 1, 7, 13}) {
      ASSERT_EQ(crc32(0, bytes.data() + offset, n), bitwise(bytes.data() + offset, n)) << n << " at " << offset;
    }
  }
}

TEST(McapReader, ReadsEveryLayoutOfTheSameMessagesAlike) {
  McapReader reference(ros_fixture("all_types.mcap"));
  EXPECT_TRUE(reference.indexed());
  EXPECT_EQ(reference.profile(), "ros2");
  ASSERT_EQ(reference.channels().size(), 1u);
  const McapChannel& channel = reference.channels().begin()->second;
  EXPECT_EQ(channel.topic, "/all_types");
  EXPECT_EQ(channel.message_encoding, "cdr");
  const McapSchema& schema = reference.schemas().at(channel.schema_id);
  EXPECT_EQ(schema.name, "skidimm_test/msg/AllTypes");
  EXPECT_EQ(schema.encoding, "ros2msg");
  EXPECT_EQ(reference.statistics().message_count, 120u);
  EXPECT_EQ(reference.compressions(), std::vector<std::string>{"zstd"});
  const Seen expected = read_all(reference);
  ASSERT_EQ(expected.log_times.size(), 120u);
  EXPECT_EQ(expected.log_times.front(), 1700000000010000000u);
  EXPECT_EQ(reference.statistics().message_start_time, expected.log_times.front());
  EXPECT_EQ(reference.statistics().message_end_time, expected.log_times.back());
  EXPECT_GT(reference.statistics().chunk_count, 5u) << "small chunks, so that chunk boundaries are crossed";

  for (const char* name : {"all_types_lz4.mcap", "all_types_uncompressed.mcap", "all_types_unchunked.mcap",
                           "all_types_no_summary.mcap"}) {
    SCOPED_TRACE(name);
    McapReader reader(ros_fixture(name));
    EXPECT_EQ(reader.statistics().message_count, 120u);
    EXPECT_EQ(reader.statistics().channel_message_counts.at(channel.id), 120u);
    const Seen seen = read_all(reader);
    EXPECT_EQ(seen.log_times, expected.log_times);
    EXPECT_EQ(seen.payloads, expected.payloads);
    // Read again from the start.
    reader.rewind();
    EXPECT_EQ(read_all(reader).payloads, expected.payloads);
    EXPECT_DOUBLE_EQ(reader.progress(), 1.0);
  }
  EXPECT_FALSE(McapReader(ros_fixture("all_types_no_summary.mcap")).indexed());
  EXPECT_FALSE(McapReader(ros_fixture("all_types_no_summary.mcap")).has_summary());
  // Messages outside chunks have no chunk index, but the file's summary is read.
  EXPECT_FALSE(McapReader(ros_fixture("all_types_unchunked.mcap")).indexed());
  EXPECT_TRUE(McapReader(ros_fixture("all_types_unchunked.mcap")).has_summary());
  EXPECT_TRUE(reference.has_summary());
  EXPECT_EQ(McapReader(ros_fixture("all_types_lz4.mcap")).compressions(), std::vector<std::string>{"lz4"});
}

std::string error_of(const std::filesystem::path& file, long* messages_before = nullptr) {
  long n = 0;
  try {
    McapReader reader(file);
    McapMessage m;
    while (reader.next(&m)) ++n;
  } catch (const LogError& e) {
    if (messages_before != nullptr) *messages_before = n;
    return e.what();
  }
  if (messages_before != nullptr) *messages_before = n;
  return "";
}

TEST(McapReader, AFileCutShortIsReadUpToTheCutThenReported) {
  const auto dir = test_directory();
  const std::string bytes = read_file(ros_fixture("all_types_no_summary.mcap"));
  // Cut in the middle: the chunks before the cut are read, then the error.
  const auto cut = write_file(dir / "cut.mcap", bytes.substr(0, bytes.size() / 2));
  long before = 0;
  const std::string message = error_of(cut, &before);
  EXPECT_NE(message.find("cut.mcap: byte "), std::string::npos) << message;
  EXPECT_NE(message.find("Chunk record of"), std::string::npos) << message;
  EXPECT_NE(message.find("cut short"), std::string::npos) << message;
  EXPECT_GT(before, 20);
  EXPECT_LT(before, 120);
  // An indexed file cut short has lost its summary: it is scanned the same
  // way, and when only the summary is lost, every message is there.
  const std::string indexed = read_file(ros_fixture("all_types.mcap"));
  const auto summary_lost = write_file(dir / "summary_lost.mcap", indexed.substr(0, indexed.size() - 100));
  EXPECT_EQ(error_of(summary_lost, &before), "");
  EXPECT_EQ(before, 120);
  EXPECT_FALSE(McapReader(summary_lost).indexed());
  const auto cut_indexed = write_file(dir / "cut_indexed.mcap", indexed.substr(0, indexed.size() * 2 / 3));
  EXPECT_NE(error_of(cut_indexed, &before).find("cut short"), std::string::npos);
  EXPECT_GT(before, 20);
  EXPECT_LT(before, 120);
  // Cut at a record boundary (right after the header): no messages, no error.
  const std::size_t after_header = records_of(bytes).at(1).second;
  McapReader header_only(write_file(dir / "header_only.mcap", bytes.substr(0, after_header)));
  EXPECT_EQ(read_all(header_only).payloads.size(), 0u);
}

TEST(McapReader, AFileThatIsNoMcapSaysSo) {
  const auto dir = test_directory();
  const std::string message = error_of(write_file(dir / "drive.mcap", "time,wz\n0,1\n"));
  EXPECT_NE(message.find("drive.mcap: not an MCAP file"), std::string::npos) << message;
  EXPECT_NE(error_of(write_file(dir / "empty.mcap", "")).find("not an MCAP file"), std::string::npos);
  EXPECT_NE(error_of(dir / "missing.mcap").find("cannot open"), std::string::npos);
}

// The byte offset of `needle` in `bytes`.
std::size_t find(const std::string& bytes, const std::string& needle) {
  const auto at = bytes.find(needle);
  EXPECT_NE(at, std::string::npos) << needle;
  return at;
}

TEST(McapReader, AWrongCrcIsReportedWithItsChunk) {
  const auto dir = test_directory();
  std::string bytes = read_file(ros_fixture("mixed.mcap"));
  bytes[find(bytes, "SKIDIMM_MARKER_2") + 15] = 'X';  // inside an uncompressed chunk: only the CRC can tell
  long before = 0;
  const std::string message = error_of(write_file(dir / "bad_crc.mcap", bytes), &before);
  EXPECT_NE(message.find("bad_crc.mcap: byte "), std::string::npos) << message;
  EXPECT_NE(message.find("Chunk's CRC is"), std::string::npos) << message;
  EXPECT_NE(message.find("the chunk is corrupt"), std::string::npos) << message;
}

TEST(McapReader, ACorruptCompressedChunkIsReported) {
  const auto dir = test_directory();
  std::string bytes = read_file(ros_fixture("all_types.mcap"));
  // The first chunk's compressed records: after the record's prefix, four
  // fixed fields, "zstd" with its length and the records' length.
  const std::size_t records = first_record(bytes, 6) + 9 + 28 + 8 + 8;
  for (std::size_t i = 0; i < 40; ++i) bytes[records + 20 + i] = static_cast<char>(bytes[records + 20 + i] ^ 0x5A);
  const std::string message = error_of(write_file(dir / "corrupt.mcap", bytes));
  EXPECT_NE(message.find("corrupt.mcap: byte "), std::string::npos) << message;
  const bool decompress = message.find("Chunk does not decompress: zstd") != std::string::npos;
  const bool crc = message.find("Chunk's CRC is") != std::string::npos;
  EXPECT_TRUE(decompress || crc) << message;
}

// A summary that does not read costs the index, not the messages: the file
// is scanned, every chunk checked by its own CRC, and every message read,
// the same as through an intact summary; the bag's description says so.
TEST(McapReader, ASummaryThatDoesNotReadIsScannedPast) {
  const auto dir = test_directory();
  const std::string intact = read_file(ros_fixture("all_types.mcap"));
  McapReader reference(ros_fixture("all_types.mcap"));
  const Seen expected = read_all(reference);
  ASSERT_EQ(expected.payloads.size(), 120u);
  std::string crc = intact;  // the Footer's summary CRC: the 4 bytes before the closing magic
  crc[crc.size() - 8 - 1] = static_cast<char>(crc[crc.size() - 8 - 1] ^ 1);
  std::string flipped = intact;  // a byte inside the summary's first record (after DataEnd)
  const std::size_t summary = first_record(intact, 0x0F) + 9 + 4 + 9 + 5;
  flipped[summary] = static_cast<char>(flipped[summary] ^ 0x40);
  for (const auto& [name, bytes] : {std::make_pair("crc.mcap", crc), std::make_pair("flipped.mcap", flipped)}) {
    const auto file = write_file(dir / name, bytes);
    EXPECT_EQ(error_of(file), "") << name;
    McapReader reader(file);
    EXPECT_FALSE(reader.indexed()) << name;
    EXPECT_NE(reader.mended().find("its summary does not read ("), std::string::npos) << reader.mended();
    EXPECT_EQ(read_all(reader).payloads, expected.payloads) << name;
  }
  EXPECT_NE(McapReader(dir / "crc.mcap").mended().find("the summary section's CRC is"), std::string::npos);
  // A summary with no CRC (0: not recorded) whose first record runs past its end: parsed, it fails, and is scanned
  // past.
  std::string unchecked = intact;
  for (std::size_t i = 0; i < 4; ++i) unchecked[unchecked.size() - 8 - 4 + i] = 0;
  const std::size_t schema = first_record(intact, 0x0F) + 9 + 4;  // the record after DataEnd
  const std::uint64_t huge = 1u << 20;
  std::memcpy(&unchecked[schema + 1], &huge, 8);
  McapReader parsed(write_file(dir / "unparsed.mcap", unchecked));
  EXPECT_NE(parsed.mended().find("runs past the end of the summary section"), std::string::npos) << parsed.mended();
  EXPECT_EQ(read_all(parsed).payloads, expected.payloads);
  // The Footer's summary_start, lowered into the data (its CRC then fails): the scan still reads to DataEnd,
  // not to that offset, which would have dropped the chunks after it without a word.
  std::string lowered = intact;
  const std::size_t footer = lowered.size() - 8 - 29;
  const std::uint64_t second_chunk = records_of(intact).at(3).second;
  std::memcpy(&lowered[footer + 9], &second_chunk, 8);
  McapReader rescanned(write_file(dir / "lowered.mcap", lowered));
  EXPECT_NE(rescanned.mended().find("its summary does not read"), std::string::npos) << rescanned.mended();
  EXPECT_EQ(read_all(rescanned).payloads, expected.payloads);
}

// Cut short inside a record that holds no message (the last chunk's message
// index, written as a recording closed): every message is there, and the
// file reads without an error; cut inside the last chunk, it is an error.
TEST(McapReader, ACutAfterTheLastMessageLosesNothingAndIsNoError) {
  const auto dir = test_directory();
  const std::string bytes = read_file(ros_fixture("all_types.mcap"));
  std::size_t last_index = 0, last_chunk = 0;
  for (const auto& [opcode, at] : records_of(bytes)) {
    if (opcode == 0x0F) break;  // DataEnd: the summary follows
    if (opcode == 0x07) last_index = at;
    if (opcode == 0x06) last_chunk = at;
  }
  ASSERT_GT(last_index, last_chunk) << "a message index follows the last chunk";
  long before = 0;
  const auto in_index = write_file(dir / "in_index.mcap", bytes.substr(0, last_index + 12));
  EXPECT_EQ(error_of(in_index, &before), "");
  EXPECT_EQ(before, 120);
  EXPECT_NE(McapReader(in_index).mended().find("cut short inside a MessageIndex record after its last message"),
            std::string::npos);
  const auto in_chunk = write_file(dir / "in_chunk.mcap", bytes.substr(0, last_chunk + 40));
  EXPECT_NE(error_of(in_chunk, &before).find("Chunk record of"), std::string::npos);
  EXPECT_LT(before, 120);
  // Cut inside the index's 9-byte prefix: the same.
  const auto in_prefix = write_file(dir / "in_prefix.mcap", bytes.substr(0, last_index + 5));
  EXPECT_EQ(error_of(in_prefix, &before), "");
  EXPECT_EQ(before, 120);
  // A record running past the end of a file that has its Footer: not cut short, corrupt, and an error.
  std::string overrun = read_file(ros_fixture("all_types_no_summary.mcap"));
  const std::size_t data_end = first_record(overrun, 0x0F);
  const std::uint64_t huge = 1u << 20;
  std::memcpy(&overrun[data_end + 1], &huge, 8);
  EXPECT_NE(error_of(write_file(dir / "overrun.mcap", overrun), &before).find("DataEnd record of"), std::string::npos);
}

TEST(McapReader, AChunkClaimingGigabytesIsRefusedBeforeAllocating) {
  const auto dir = test_directory();
  std::string bytes = read_file(ros_fixture("all_types_no_summary.mcap"));
  // uncompressed_size: the third u64 of the first chunk.
  const std::size_t chunk = first_record(bytes, 6);
  const std::uint64_t huge = std::uint64_t{1} << 40;
  std::memcpy(&bytes[chunk + 9 + 16], &huge, 8);
  const std::string message = error_of(write_file(dir / "huge.mcap", bytes));
  EXPECT_NE(message.find("a corrupt chunk"), std::string::npos) << message;
}

}  // namespace
}  // namespace ros
}  // namespace skidimm
