#pragma once
// The MCAP container (https://mcap.dev/spec, major version 0), read front to back in bounded
// memory: the format of ROS 2 bags (rosbag2's default storage since Iron). Only what a stream
// of samples needs is decoded: Header, Schema, Channel, Message and Chunk records (chunks
// uncompressed, "zstd" or "lz4"); every other record (Message Index, Attachment, Metadata, the
// Summary section) is skipped by its length without being held. Reading never seeks, so a bag
// may come through a pipe; summary_channels() reads a file's channel list from its end.

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace momentum::stream::mcap {

// The 8 bytes that start (and end) every MCAP file: 0x89 "MCAP" '0' CR LF. The first byte is
// the first byte of the suite's binary magic too; the second tells them apart.
inline constexpr char kMagic[8] = {'\x89', 'M', 'C', 'A', 'P', '0', '\r', '\n'};

// The most bytes a chunk may hold, compressed or uncompressed, and the most a Schema, Channel
// or Message record outside a chunk may hold: a chunk is decompressed whole, so this bounds
// the reader's memory (about twice this at worst). Writers' chunks are far smaller (the MCAP
// libraries' default is 768 KiB, rosbag2's 768 KiB to a few MiB); a larger one is refused with
// an error that names this limit.
inline constexpr std::uint64_t kMaxChunkBytes = std::uint64_t{64} << 20;

// CRC-32 (ISO-HDLC, the polynomial of zlib and of MCAP's CRC fields) of `bytes`, continuing
// from `crc` (0 to start).
std::uint32_t crc32(std::string_view bytes, std::uint32_t crc = 0);

// Where the container reader takes its bytes from: a window onto the input that grows on
// demand. The stream reader's file input implements it; MemorySource serves tests and fuzzing.
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  // Makes at least n bytes available from the current position; false when the input ends
  // first (then available() holds all that is left).
  virtual bool want(std::size_t n) = 0;
  // The available bytes (valid until the next want() or consume()).
  virtual const char* data() const = 0;
  virtual std::size_t available() const = 0;
  // Drops the first n available bytes (n <= available()).
  virtual void consume(std::size_t n) = 0;
  // Bytes consumed since the start of the input.
  virtual std::uint64_t offset() const = 0;
  // Called before every read that may block (the stream reader's live-flush hook); may be
  // null or empty.
  std::function<void()>* before_read = nullptr;
};

// A ByteSource over bytes in memory (not copied: they must outlive the source).
class MemorySource final : public ByteSource {
 public:
  explicit MemorySource(std::string_view bytes) : bytes_(bytes) {}
  bool want(std::size_t n) override { return bytes_.size() - at_ >= n; }
  const char* data() const override { return bytes_.data() + at_; }
  std::size_t available() const override { return bytes_.size() - at_; }
  void consume(std::size_t n) override { at_ += n; }
  std::uint64_t offset() const override { return at_; }

 private:
  std::string_view bytes_;
  std::size_t at_ = 0;
};

// A Channel record with its Schema's name and encoding (empty when its schema_id is 0 or names
// no Schema seen before it).
struct Channel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;
  std::string topic;
  std::string message_encoding;  // "cdr" for ROS 2
  std::string schema_name;       // "sensor_msgs/msg/JointState"
  std::string schema_encoding;   // "ros2msg" or "ros2idl" for ROS 2
};

// A Message record; `data` points into the reader's buffers and is valid until the next call of
// RecordReader::next().
struct Message {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;      // ns since the writer's epoch
  std::uint64_t publish_time = 0;  // ns
  std::string_view data;
};

// The channels listed in the Summary section of the MCAP file at `path`, read from its end (the
// Footer gives the section's offset), so that a reader can choose a topic before it reads any
// message. Empty when the file has no summary, is not seekable or not MCAP, or the section is
// damaged or larger than kMaxChunkBytes: the caller then learns the channels as it reads.
std::vector<Channel> summary_channels(const std::string& path);

// Reads the records of an MCAP file in file order, descending into chunks one at a time.
class RecordReader {
 public:
  enum class Item {
    channel,  // a Channel record not seen before: channel()
    message,  // a Message record: message()
    damage,   // a part of the file that cannot be read: damage_kind(), damage()
    end,      // the end of the file (after the Footer and closing magic, or after damage)
  };

  // Reads the magic and the Header record. `name` prefixes messages. Throws momentum::Error
  // (`name: byte N: why`) when the input is not MCAP (wrong magic, another major version) or
  // ends inside the magic or the Header.
  RecordReader(ByteSource& source, std::string name);

  // The next item. Damage is reported once, as an item, and reading goes on where it can: a
  // Chunk whose CRC does not match its records, that does not decompress to its stated size or
  // whose records overrun it ("bad chunk": its messages are skipped), a Message record too
  // short for its fields ("bad record"), a record cut off by the end of the input ("truncated
  // record"; the complete records in what arrived of a cut chunk are returned first: all of an
  // uncompressed one's, those of a compressed one's complete blocks) or an input that ends
  // without its Footer before the Data End record ("truncated file"), after which the next
  // item is end. Throws momentum::Error for what makes the rest of the file unusable: a chunk
  // (or record) larger than kMaxChunkBytes, an unknown compression, opcode 0.
  Item next();

  // After Item::channel: the new channel. Channels are also kept by id (find_channel).
  const Channel& channel() const { return *channel_; }
  // After Item::message.
  const Message& message() const { return message_; }
  // The channel with this id, or nullptr.
  const Channel* find_channel(std::uint16_t id) const;
  // Every channel seen so far, by id.
  const std::map<std::uint16_t, Channel>& channels() const { return channels_; }
  // After Item::damage: a short fixed phrase ("truncated record") and the whole message,
  // without the location.
  const std::string& damage_kind() const { return damage_kind_; }
  const std::string& damage() const { return damage_; }

  // Where the last item came from: the byte offset in the file of its record, or of the Chunk
  // holding it, and its 1-based record number inside that chunk (0 outside chunks).
  std::uint64_t record_offset() const { return record_offset_; }
  std::uint64_t chunk_record() const { return chunk_record_; }

  // The Header's profile ("ros2" for rosbag2) and library.
  const std::string& profile() const { return profile_; }
  const std::string& library() const { return library_; }
  // Chunks read so far, and the compressions they used (each once, in order of appearance).
  std::uint64_t chunks() const { return chunks_; }
  const std::vector<std::string>& compressions() const { return compressions_; }

 private:
  bool next_top_level(Item& item);
  bool next_in_chunk(Item& item);
  bool handle(std::uint8_t opcode, std::string_view content, Item& item);
  void load_chunk(std::string_view content, bool truncated);
  void skip(std::uint64_t length);
  Item report(std::string kind, std::string text);

  ByteSource& in_;
  std::string name_;
  std::string profile_, library_;
  std::map<std::uint16_t, std::pair<std::string, std::string>> schemas_;  // id: name, encoding
  std::map<std::uint16_t, Channel> channels_;
  const Channel* channel_ = nullptr;
  Message message_;
  std::string damage_kind_, damage_;
  std::uint64_t record_offset_ = 0, chunk_record_ = 0;
  // The records of the chunk being read (decompressed), and where the next one starts.
  std::string chunk_;
  std::size_t chunk_at_ = 0;
  bool in_chunk_ = false;
  bool chunk_truncated_ = false;  // the chunk was cut off: after its records, the damage
  std::uint64_t chunk_offset_ = 0, chunk_length_ = 0, chunk_have_ = 0;
  bool after_data_end_ = false;  // the Summary section: records skipped
  bool ended_ = false;
  std::uint64_t chunks_ = 0;
  std::vector<std::string> compressions_;
};

}  // namespace momentum::stream::mcap
