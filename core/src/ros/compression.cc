#include "compression.h"

#include <lz4frame.h>
#include <zstd.h>

#include <memory>

namespace skidimm {
namespace ros {

bool is_supported_compression(std::string_view compression) {
  return compression.empty() || compression == "zstd" || compression == "lz4";
}

namespace {

struct Lz4Context {
  LZ4F_dctx* context = nullptr;
  Lz4Context() {
    if (LZ4F_isError(LZ4F_createDecompressionContext(&context, LZ4F_VERSION))) {
      throw CompressionError("lz4: cannot create a decompression context");
    }
  }
  ~Lz4Context() { LZ4F_freeDecompressionContext(context); }
  Lz4Context(const Lz4Context&) = delete;
  Lz4Context& operator=(const Lz4Context&) = delete;
};

void decompress_lz4(const std::uint8_t* data, std::size_t size, std::size_t expected_size,
                    std::vector<std::uint8_t>* out) {
  Lz4Context lz4;
  std::size_t read = 0, written = 0;
  for (;;) {
    std::size_t in = size - read;
    std::size_t room = expected_size - written;
    const std::size_t hint = LZ4F_decompress(lz4.context, out->data() + written, &room, data + read, &in, nullptr);
    if (LZ4F_isError(hint)) throw CompressionError(std::string("lz4: ") + LZ4F_getErrorName(hint));
    read += in;
    written += room;
    if (hint == 0) break;  // the frame is complete
    if (read == size) throw CompressionError("lz4: the frame ends early");
    if (written == expected_size && in == 0 && room == 0) {
      throw CompressionError("lz4: the data decompresses to more than the " + std::to_string(expected_size) +
                             " bytes recorded");
    }
  }
  if (written != expected_size) {
    throw CompressionError("lz4: the data decompresses to " + std::to_string(written) + " bytes, not the " +
                           std::to_string(expected_size) + " recorded");
  }
}

}  // namespace

void decompress(std::string_view compression, const std::uint8_t* data, std::size_t size, std::size_t expected_size,
                std::vector<std::uint8_t>* out) {
  out->resize(expected_size);
  if (compression.empty()) {
    if (size != expected_size) {
      throw CompressionError("uncompressed data of " + std::to_string(size) + " bytes, but " +
                             std::to_string(expected_size) + " recorded");
    }
    if (size > 0) std::copy(data, data + size, out->begin());
    return;
  }
  if (compression == "zstd") {
    const std::size_t n = ZSTD_decompress(out->data(), expected_size, data, size);
    if (ZSTD_isError(n)) throw CompressionError(std::string("zstd: ") + ZSTD_getErrorName(n));
    if (n != expected_size) {
      throw CompressionError("zstd: the data decompresses to " + std::to_string(n) + " bytes, not the " +
                             std::to_string(expected_size) + " recorded");
    }
    return;
  }
  if (compression == "lz4") {
    decompress_lz4(data, size, expected_size, out);
    return;
  }
  throw CompressionError("unknown compression '" + std::string(compression) + "' (known: zstd, lz4, none)");
}

void compress(std::string_view compression, const std::uint8_t* data, std::size_t size, int level,
              std::vector<std::uint8_t>* out) {
  if (compression == "zstd") {
    out->resize(ZSTD_compressBound(size));
    const std::size_t n = ZSTD_compress(out->data(), out->size(), data, size, level);
    if (ZSTD_isError(n)) throw CompressionError(std::string("zstd: ") + ZSTD_getErrorName(n));
    out->resize(n);
    return;
  }
  if (compression == "lz4") {
    LZ4F_preferences_t preferences{};
    preferences.compressionLevel = level;
    out->resize(LZ4F_compressFrameBound(size, &preferences));
    const std::size_t n = LZ4F_compressFrame(out->data(), out->size(), data, size, &preferences);
    if (LZ4F_isError(n)) throw CompressionError(std::string("lz4: ") + LZ4F_getErrorName(n));
    out->resize(n);
    return;
  }
  if (compression.empty()) {
    out->assign(data, data + size);
    return;
  }
  throw CompressionError("unknown compression '" + std::string(compression) + "' (known: zstd, lz4, none)");
}

}  // namespace ros
}  // namespace skidimm
