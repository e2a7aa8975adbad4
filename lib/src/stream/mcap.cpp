#include "momentum/stream/mcap.hpp"

#include <lz4frame.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <tuple>
#include <memory>

#include "momentum/core/error.hpp"
#include "momentum/core/text.hpp"

namespace momentum::stream::mcap {

namespace {

// Record opcodes of the specification that this reader acts on.
constexpr std::uint8_t kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05,
                       kChunk = 0x06, kDataEnd = 0x0F;
constexpr std::size_t kRecordPrefix = 9;  // opcode (1) and content length (8)

const char* opcode_name(std::uint8_t opcode) {
  switch (opcode) {
    case kHeader: return "header";
    case kFooter: return "footer";
    case kSchema: return "schema";
    case kChannel: return "channel";
    case kMessage: return "message";
    case kChunk: return "chunk";
    case 0x07: return "message index";
    case 0x08: return "chunk index";
    case 0x09: return "attachment";
    case 0x0A: return "attachment index";
    case 0x0B: return "statistics";
    case 0x0C: return "metadata";
    case 0x0D: return "metadata index";
    case 0x0E: return "summary offset";
    case kDataEnd: return "data end";
    default: return opcode >= 0x80 ? "private" : "unknown";
  }
}

// Little-endian fields of a record's content, in order; a field that overruns the content
// sets `ok` false and reads as zero or empty.
class Fields {
 public:
  explicit Fields(std::string_view content) : s_(content) {}
  bool ok = true;
  std::uint64_t uint(std::size_t bytes) {
    if (s_.size() - at_ < bytes) {
      ok = false;
      at_ = s_.size();
      return 0;
    }
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < bytes; ++i) v |= std::uint64_t{static_cast<unsigned char>(s_[at_ + i])} << (8 * i);
    at_ += bytes;
    return v;
  }
  std::string_view bytes(std::uint64_t length) {
    if (s_.size() - at_ < length) {
      ok = false;
      at_ = s_.size();
      return {};
    }
    std::string_view v = s_.substr(at_, static_cast<std::size_t>(length));
    at_ += static_cast<std::size_t>(length);
    return v;
  }
  std::string_view string() { return bytes(uint(4)); }
  std::string_view rest() const { return s_.substr(at_); }

 private:
  std::string_view s_;
  std::size_t at_ = 0;
};

std::uint64_t little_u64(const char* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= std::uint64_t{static_cast<unsigned char>(p[i])} << (8 * i);
  return v;
}

std::string hex32(std::uint32_t v) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%08x", v);
  return text;
}

std::string mib(std::uint64_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

// Decompresses a chunk's records `in` into `out` (sized to the chunk's uncompressed size) and
// returns the bytes produced. Streaming, so that a cut input (`cut`) gives what its complete
// blocks hold; `failure` says why the data is corrupt (a cut input running out is no failure).
std::size_t decompress(const std::string& compression, std::string_view in, std::string& out, bool cut,
                       std::string& failure) {
  if (compression == "zstd") {
    std::unique_ptr<ZSTD_DStream, decltype(&ZSTD_freeDStream)> stream(ZSTD_createDStream(), &ZSTD_freeDStream);
    if (!stream || ZSTD_isError(ZSTD_initDStream(stream.get()))) throw Error("zstd: cannot create a decompression context");
    ZSTD_inBuffer input{in.data(), in.size(), 0};
    ZSTD_outBuffer output{out.data(), out.size(), 0};
    for (;;) {
      const std::size_t before_in = input.pos, before_out = output.pos;
      const std::size_t hint = ZSTD_decompressStream(stream.get(), &output, &input);
      if (ZSTD_isError(hint)) {
        failure = ZSTD_getErrorName(hint);
        break;
      }
      if (hint == 0) break;  // the frame is complete
      if (input.pos == before_in && output.pos == before_out) {
        if (input.pos < input.size) failure = "more data than its uncompressed_size";
        else if (!cut) failure = "the frame ends early";
        break;
      }
    }
    return output.pos;
  }
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) throw Error("lz4: cannot create a decompression context");
  std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> context(raw, &LZ4F_freeDecompressionContext);
  std::size_t in_at = 0, out_at = 0;
  for (;;) {
    std::size_t out_size = out.size() - out_at, in_size = in.size() - in_at;
    const std::size_t hint = LZ4F_decompress(context.get(), out.data() + out_at, &out_size, in.data() + in_at, &in_size, nullptr);
    if (LZ4F_isError(hint)) {
      failure = LZ4F_getErrorName(hint);
      break;
    }
    in_at += in_size;
    out_at += out_size;
    if (hint == 0) break;  // the frame is complete
    if (in_size == 0 && out_size == 0) {
      if (in_at < in.size()) failure = "more data than its uncompressed_size";
      else if (!cut) failure = "the frame ends early";
      break;
    }
  }
  return out_at;
}

}  // namespace

std::uint32_t crc32(std::string_view bytes, std::uint32_t crc) {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  crc = ~crc;
  for (char b : bytes) crc = table[(crc ^ static_cast<unsigned char>(b)) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

std::vector<Channel> summary_channels(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) return {};
  file.seekg(0, std::ios::end);
  const std::streamoff size = file.tellg();
  // Footer record (opcode, length 20, summary_start, summary_offset_start, crc) and magic.
  constexpr std::streamoff kTail = kRecordPrefix + 20 + sizeof kMagic;
  if (size < static_cast<std::streamoff>(sizeof kMagic) + kTail) return {};
  std::string tail(static_cast<std::size_t>(kTail), '\0');
  file.seekg(size - kTail);
  if (!file.read(tail.data(), kTail)) return {};
  if (tail[0] != static_cast<char>(kFooter) || little_u64(tail.data() + 1) != 20 ||
      std::memcmp(tail.data() + kTail - sizeof kMagic, kMagic, sizeof kMagic) != 0)
    return {};
  const std::uint64_t start = little_u64(tail.data() + kRecordPrefix);
  const auto end = static_cast<std::uint64_t>(size - kTail);
  if (start == 0 || start >= end || end - start > kMaxChunkBytes) return {};
  std::string summary(static_cast<std::size_t>(end - start), '\0');
  file.seekg(static_cast<std::streamoff>(start));
  if (!file.read(summary.data(), static_cast<std::streamsize>(summary.size()))) return {};
  std::map<std::uint16_t, std::pair<std::string, std::string>> schemas;
  std::vector<Channel> channels;
  Fields records(summary);
  while (!records.rest().empty()) {
    const auto opcode = static_cast<std::uint8_t>(records.uint(1));
    Fields fields(records.bytes(records.uint(8)));
    if (!records.ok) return {};
    if (opcode == kSchema) {
      const auto id = static_cast<std::uint16_t>(fields.uint(2));
      const std::string_view name = fields.string(), encoding = fields.string();
      if (fields.ok) schemas[id] = {std::string(name), std::string(encoding)};
    } else if (opcode == kChannel) {
      Channel channel;
      channel.id = static_cast<std::uint16_t>(fields.uint(2));
      channel.schema_id = static_cast<std::uint16_t>(fields.uint(2));
      channel.topic = fields.string();
      channel.message_encoding = fields.string();
      if (!fields.ok) continue;
      if (auto schema = schemas.find(channel.schema_id); schema != schemas.end())
        std::tie(channel.schema_name, channel.schema_encoding) = schema->second;
      channels.push_back(std::move(channel));
    }
  }
  return channels;
}

RecordReader::RecordReader(ByteSource& source, std::string name) : in_(source), name_(std::move(name)) {
  if (!in_.want(sizeof kMagic)) {
    if (in_.available() >= 5 && std::memcmp(in_.data(), kMagic, 5) == 0)
      throw Error(name_ + ": byte 0: truncated MCAP magic");
    throw Error(name_ + ": byte 0: not an MCAP file (wrong magic)");
  }
  if (std::memcmp(in_.data(), kMagic, 5) != 0) throw Error(name_ + ": byte 0: not an MCAP file (wrong magic)");
  if (std::memcmp(in_.data(), kMagic, sizeof kMagic) != 0)
    throw Error(name_ + ": byte 5: unsupported MCAP major version '" + core::printable(std::string_view(in_.data() + 5, 1)) +
                "' (this build reads version 0)");
  in_.consume(sizeof kMagic);
  const std::uint64_t at = in_.offset();
  if (!in_.want(kRecordPrefix)) throw Error(name_ + ": byte " + std::to_string(at) + ": truncated header record");
  const auto opcode = static_cast<std::uint8_t>(in_.data()[0]);
  const std::uint64_t length = little_u64(in_.data() + 1);
  if (opcode != kHeader)
    throw Error(name_ + ": byte " + std::to_string(at) + ": the first record is a " + opcode_name(opcode) +
                " record, not the header");
  if (length > kMaxChunkBytes || !in_.want(kRecordPrefix + static_cast<std::size_t>(length)))
    throw Error(name_ + ": byte " + std::to_string(at) + ": truncated header record");
  Fields fields(std::string_view(in_.data() + kRecordPrefix, static_cast<std::size_t>(length)));
  profile_ = fields.string();
  library_ = fields.string();
  if (!fields.ok) throw Error(name_ + ": byte " + std::to_string(at) + ": bad header record (too short for its fields)");
  in_.consume(kRecordPrefix + static_cast<std::size_t>(length));
}

const Channel* RecordReader::find_channel(std::uint16_t id) const {
  auto it = channels_.find(id);
  return it == channels_.end() ? nullptr : &it->second;
}

RecordReader::Item RecordReader::report(std::string kind, std::string text) {
  damage_kind_ = std::move(kind);
  damage_ = std::move(text);
  return Item::damage;
}

RecordReader::Item RecordReader::next() {
  for (;;) {
    if (ended_) return Item::end;
    Item item = Item::end;
    if (in_chunk_ ? next_in_chunk(item) : next_top_level(item)) return item;
  }
}

bool RecordReader::next_in_chunk(Item& item) {
  const std::size_t left = chunk_.size() - chunk_at_;
  if (left == 0 || (chunk_truncated_ && left < kRecordPrefix)) {
    in_chunk_ = false;
    if (!chunk_truncated_) return false;
    ended_ = true;
    record_offset_ = chunk_offset_;
    chunk_record_ = 0;
    item = report("truncated record", "truncated record (chunk, " + std::to_string(chunk_have_) + " of " +
                                          std::to_string(chunk_length_) + " bytes; its complete messages kept)");
    return true;
  }
  record_offset_ = chunk_offset_;
  ++chunk_record_;
  if (left < kRecordPrefix) {
    in_chunk_ = false;
    item = report("bad chunk", "bad chunk: " + std::to_string(left) + " bytes after its last record");
    return true;
  }
  const auto opcode = static_cast<std::uint8_t>(chunk_[chunk_at_]);
  const std::uint64_t length = little_u64(chunk_.data() + chunk_at_ + 1);
  if (length > left - kRecordPrefix) {
    if (chunk_truncated_) {  // the record the input's end cut off
      chunk_at_ = chunk_.size();
      --chunk_record_;
      return false;
    }
    in_chunk_ = false;
    item = report("bad chunk", "bad chunk: record " + std::to_string(chunk_record_) + " (" + opcode_name(opcode) +
                                   ") overruns the chunk by " + std::to_string(length - (left - kRecordPrefix)) + " bytes");
    return true;
  }
  const std::string_view content(chunk_.data() + chunk_at_ + kRecordPrefix, static_cast<std::size_t>(length));
  chunk_at_ += kRecordPrefix + static_cast<std::size_t>(length);
  if (opcode == kChunk) return false;  // not allowed inside a chunk: skipped
  return handle(opcode, content, item);
}

bool RecordReader::handle(std::uint8_t opcode, std::string_view content, Item& item) {
  Fields fields(content);
  switch (opcode) {
    case kSchema: {
      const auto id = static_cast<std::uint16_t>(fields.uint(2));
      const std::string_view name = fields.string(), encoding = fields.string();
      if (!fields.ok) {
        item = report("bad record", "bad schema record (too short for its fields)");
        return true;
      }
      if (id != 0 && !schemas_.count(id)) schemas_[id] = {std::string(name), std::string(encoding)};
      return false;
    }
    case kChannel: {
      Channel channel;
      channel.id = static_cast<std::uint16_t>(fields.uint(2));
      channel.schema_id = static_cast<std::uint16_t>(fields.uint(2));
      channel.topic = fields.string();
      channel.message_encoding = fields.string();
      if (!fields.ok) {
        item = report("bad record", "bad channel record (too short for its fields)");
        return true;
      }
      if (channels_.count(channel.id)) return false;  // a repeat (the specification allows them)
      if (auto schema = schemas_.find(channel.schema_id); schema != schemas_.end()) {
        channel.schema_name = schema->second.first;
        channel.schema_encoding = schema->second.second;
      }
      channel_ = &channels_.emplace(channel.id, std::move(channel)).first->second;
      item = Item::channel;
      return true;
    }
    case kMessage: {
      message_.channel_id = static_cast<std::uint16_t>(fields.uint(2));
      message_.sequence = static_cast<std::uint32_t>(fields.uint(4));
      message_.log_time = fields.uint(8);
      message_.publish_time = fields.uint(8);
      if (!fields.ok) {
        item = report("bad record", "bad message record (" + std::to_string(content.size()) + " bytes, fewer than its 22 bytes of fields)");
        return true;
      }
      message_.data = fields.rest();
      item = Item::message;
      return true;
    }
    default:
      return false;  // the Header again, indexes, attachments, metadata, private records
  }
}

bool RecordReader::next_top_level(Item& item) {
  record_offset_ = in_.offset();
  chunk_record_ = 0;
  if (!in_.want(kRecordPrefix)) {
    const std::size_t have = in_.available();
    in_.consume(have);
    ended_ = true;
    if (have == 0) {
      // Cut off between two records: every message of the data section is in when its Data
      // End record was read (only the summary and footer are missing).
      if (after_data_end_) return false;
      item = report("truncated file", "truncated file (it ends without the footer record)");
    } else {
      item = report("truncated record", "truncated record (" + std::to_string(have) + " of the 9 bytes of a record's opcode and length)");
    }
    return true;
  }
  const auto opcode = static_cast<std::uint8_t>(in_.data()[0]);
  const std::uint64_t length = little_u64(in_.data() + 1);
  if (opcode == 0)
    throw Error(name_ + ": byte " + std::to_string(record_offset_) + ": bad record (opcode 0): the file is corrupt here");
  if (opcode == kFooter) {
    ended_ = true;  // what follows is the closing magic
    return false;
  }
  if (opcode == kDataEnd) after_data_end_ = true;
  const bool wanted = !after_data_end_ && (opcode == kSchema || opcode == kChannel || opcode == kMessage || opcode == kChunk);
  if (!wanted) {  // skipped by its length, in pieces: an attachment may be larger than memory
    in_.consume(kRecordPrefix);
    std::uint64_t left = length;
    while (left > 0) {
      if (in_.available() == 0 && !in_.want(1)) {
        ended_ = true;
        item = report("truncated record", std::string("truncated record (") + opcode_name(opcode) + ", " +
                                              std::to_string(length - left) + " of " + std::to_string(length) + " bytes)");
        return true;
      }
      const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, in_.available()));
      in_.consume(n);
      left -= n;
    }
    return false;
  }
  // A chunk's fields before its records take at most this much besides the compression name.
  if (length > kMaxChunkBytes + 64)
    throw Error(name_ + ": byte " + std::to_string(record_offset_) + ": " + opcode_name(opcode) + " record of " +
                std::to_string(length) + " bytes, more than this reader's limit of " + mib(kMaxChunkBytes));
  in_.consume(kRecordPrefix);
  const bool whole = in_.want(static_cast<std::size_t>(length));
  const std::size_t have = std::min<std::size_t>(in_.available(), static_cast<std::size_t>(length));
  const std::string_view content(in_.data(), have);
  if (opcode == kChunk) {
    chunk_offset_ = record_offset_;
    chunk_length_ = length;
    chunk_have_ = have;
    load_chunk(content, !whole);
    in_.consume(have);
    if (!whole && !in_chunk_) {  // cut inside the chunk's fields
      ended_ = true;
      item = report("truncated record", "truncated record (chunk, " + std::to_string(have) + " of " + std::to_string(length) + " bytes)");
      return true;
    }
    if (!damage_.empty() && !in_chunk_) {  // load_chunk found the chunk unusable
      item = Item::damage;
      return true;
    }
    return false;
  }
  if (!whole) {
    in_.consume(have);
    ended_ = true;
    item = report("truncated record", std::string("truncated record (") + opcode_name(opcode) + ", " + std::to_string(have) +
                                          " of " + std::to_string(length) + " bytes)");
    return true;
  }
  // The content stays where it is until the next call (the next want() may move it).
  in_.consume(have);
  return handle(opcode, content, item);
}

void RecordReader::load_chunk(std::string_view content, bool truncated) {
  damage_.clear();
  in_chunk_ = false;
  chunk_truncated_ = false;
  chunk_.clear();
  chunk_at_ = 0;
  chunk_record_ = 0;
  const std::string at = name_ + ": byte " + std::to_string(chunk_offset_) + ": ";
  Fields fields(content);
  fields.uint(8);  // message_start_time
  fields.uint(8);  // message_end_time
  const std::uint64_t uncompressed_size = fields.uint(8);
  const auto crc = static_cast<std::uint32_t>(fields.uint(4));
  const std::string compression(fields.string());
  const std::uint64_t records_length = fields.uint(8);
  if (!fields.ok) {
    if (!truncated) report("bad chunk", "bad chunk (too short for its fields)");
    return;  // truncated: the caller reports it
  }
  if (compression != "" && compression != "zstd" && compression != "lz4")
    throw Error(at + "chunk compression '" + core::printable(compression) + "' is not supported (none, zstd or lz4)");
  if (uncompressed_size > kMaxChunkBytes)
    throw Error(at + "chunk of " + std::to_string(uncompressed_size) + " bytes uncompressed, more than this reader's limit of " +
                mib(kMaxChunkBytes));
  std::string_view records = fields.rest();
  if (records.size() > records_length) records = records.substr(0, static_cast<std::size_t>(records_length));
  if (records.size() < records_length && !truncated) {
    report("bad chunk", "bad chunk: its records (" + std::to_string(records_length) + " bytes) overrun the record");
    return;
  }
  if (std::find(compressions_.begin(), compressions_.end(), compression) == compressions_.end())
    compressions_.push_back(compression);
  ++chunks_;
  std::string failure;
  if (compression.empty()) {
    chunk_.assign(records);
  } else {
    chunk_.resize(static_cast<std::size_t>(uncompressed_size));
    chunk_.resize(decompress(compression, records, chunk_, truncated, failure));
  }
  if (truncated) {
    // What the records that arrived hold is still good: their complete records are read, the
    // damage is reported after them. The CRC covers the whole chunk and cannot be checked.
    chunk_truncated_ = true;
    in_chunk_ = true;
    return;
  }
  if (failure.empty() && chunk_.size() != uncompressed_size)
    failure = (compression.empty() ? std::to_string(chunk_.size()) + " bytes of records"
                                   : "decompressed to " + std::to_string(chunk_.size()) + " bytes") +
              ", its uncompressed_size says " + std::to_string(uncompressed_size);
  if (!failure.empty()) {
    report("bad chunk", "bad chunk: " + (compression.empty() ? "" : compression + ": ") + failure);
    chunk_.clear();
    return;
  }
  if (crc != 0) {
    const std::uint32_t actual = crc32(chunk_);
    if (actual != crc) {
      report("bad chunk", "bad chunk: CRC " + hex32(actual) + " of its records, the chunk says " + hex32(crc) +
                              " (its messages skipped)");
      chunk_.clear();
      return;
    }
  }
  in_chunk_ = true;
}

}  // namespace momentum::stream::mcap
