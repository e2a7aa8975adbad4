// ROS 2 bags (MCAP with CDR JointState messages): the CDR decoding against hand-built byte
// strings in both byte orders, the container against files built here record by record (every
// chunk compression, CRCs, damage), and Reader::open on them (joints matched by name). The bags
// of the MCAP project's own writer are read back in the golden cases (tests/cli/mo-cat/mcap-*).
#include <gtest/gtest.h>
#include <lz4frame.h>
#include <unistd.h>
#include <zstd.h>

#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "momentum/core/error.hpp"
#include "momentum/stream/joint_state.hpp"
#include "momentum/stream/mcap.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/writer.hpp"

namespace ms = momentum::stream;
namespace mcap = momentum::stream::mcap;
namespace ros2 = momentum::stream::ros2;

namespace {

std::string bytes(std::initializer_list<int> values) {
  std::string s;
  for (int v : values) s += static_cast<char>(v);
  return s;
}

// JointState{stamp 5 s + 0.25 s, frame_id "b", name [a, bc], position [1.5, -2], velocity [],
// effort [0.25, 3]}, little-endian, laid out by hand (offsets from the byte after the 4-byte
// encapsulation header; padding to each field's size).
const std::string kLittle = bytes({
    0x00, 0x01, 0x00, 0x00,                          // encapsulation: CDR_LE
    0x05, 0x00, 0x00, 0x00,                          //  0 sec 5
    0x80, 0xB2, 0xE6, 0x0E,                          //  4 nanosec 250000000
    0x02, 0x00, 0x00, 0x00, 'b', 0x00, 0x00, 0x00,   //  8 frame_id "b" (2 with NUL), pad to 16
    0x02, 0x00, 0x00, 0x00,                          // 16 two names
    0x02, 0x00, 0x00, 0x00, 'a', 0x00, 0x00, 0x00,   // 20 "a", pad to 28
    0x03, 0x00, 0x00, 0x00, 'b', 'c', 0x00, 0x00,    // 28 "bc", pad to 36
    0x02, 0x00, 0x00, 0x00,                          // 36 two positions (40 is 8-aligned)
    0, 0, 0, 0, 0, 0, 0xF8, 0x3F,                    // 40 1.5
    0, 0, 0, 0, 0, 0, 0x00, 0xC0,                    // 48 -2
    0x00, 0x00, 0x00, 0x00,                          // 56 no velocities
    0x02, 0x00, 0x00, 0x00,                          // 60 two efforts
    0, 0, 0, 0, 0, 0, 0xD0, 0x3F,                    // 64 0.25
    0, 0, 0, 0, 0, 0, 0x08, 0x40,                    // 72 3
});

// The same message big-endian: every number's bytes reversed, the layout unchanged.
const std::string kBig = bytes({
    0x00, 0x00, 0x00, 0x00,                          // encapsulation: CDR_BE
    0x00, 0x00, 0x00, 0x05,                          //
    0x0E, 0xE6, 0xB2, 0x80,                          //
    0x00, 0x00, 0x00, 0x02, 'b', 0x00, 0x00, 0x00,   //
    0x00, 0x00, 0x00, 0x02,                          //
    0x00, 0x00, 0x00, 0x02, 'a', 0x00, 0x00, 0x00,   //
    0x00, 0x00, 0x00, 0x03, 'b', 'c', 0x00, 0x00,    //
    0x00, 0x00, 0x00, 0x02,                          //
    0x3F, 0xF8, 0, 0, 0, 0, 0, 0,                    //
    0xC0, 0x00, 0, 0, 0, 0, 0, 0,                    //
    0x00, 0x00, 0x00, 0x00,                          //
    0x00, 0x00, 0x00, 0x02,                          //
    0x3F, 0xD0, 0, 0, 0, 0, 0, 0,                    //
    0x40, 0x08, 0, 0, 0, 0, 0, 0,                    //
});

void expect_hand_message(const ros2::JointState& s) {
  EXPECT_EQ(s.stamp_sec, 5);
  EXPECT_EQ(s.stamp_nanosec, 250000000u);
  EXPECT_EQ(s.frame_id, "b");
  EXPECT_EQ(s.name, (std::vector<std::string>{"a", "bc"}));
  EXPECT_EQ(s.position, (std::vector<double>{1.5, -2.0}));
  EXPECT_TRUE(s.velocity.empty());
  EXPECT_EQ(s.effort, (std::vector<double>{0.25, 3.0}));
}

TEST(JointStateCdr, DecodesLittleEndian) {
  ros2::JointState s;
  ASSERT_EQ(ros2::decode_joint_state(kLittle, s), "");
  expect_hand_message(s);
}

TEST(JointStateCdr, DecodesBigEndian) {
  ros2::JointState s;
  ASSERT_EQ(ros2::decode_joint_state(kBig, s), "");
  expect_hand_message(s);
}

TEST(JointStateCdr, EveryTruncationIsRefusedWithAReason) {
  for (const std::string* message : {&kLittle, &kBig}) {
    for (std::size_t n = 0; n < message->size(); ++n) {
      ros2::JointState s;
      const std::string why = ros2::decode_joint_state(message->substr(0, n), s);
      EXPECT_FALSE(why.empty()) << "prefix of " << n << " bytes accepted";
    }
  }
}

TEST(JointStateCdr, RefusesOtherEncapsulationsAndCorruptCounts) {
  ros2::JointState s;
  std::string xcdr2 = kLittle;
  xcdr2[1] = 0x07;  // CDR2_LE: another alignment rule
  EXPECT_NE(ros2::decode_joint_state(xcdr2, s).find("not plain XCDR1"), std::string::npos);
  std::string huge = kLittle;
  huge[4 + 16 + 3] = 0x7F;  // 2^31 names: refused before anything is allocated for them
  EXPECT_NE(ros2::decode_joint_state(huge, s).find("sequence count"), std::string::npos);
  std::string no_nul = kLittle;
  no_nul[4 + 25] = 'x';  // the NUL of "a"
  EXPECT_NE(ros2::decode_joint_state(no_nul, s).find("NUL"), std::string::npos);
}

// --- MCAP files built record by record (the specification's layouts) ---

void put(std::string& out, std::uint64_t v, int n) {
  for (int i = 0; i < n; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
}
void put_string(std::string& out, const std::string& s) {
  put(out, s.size(), 4);
  out += s;
}
std::string record(int opcode, const std::string& content) {
  std::string r(1, static_cast<char>(opcode));
  put(r, content.size(), 8);
  return r + content;
}
std::string schema_record(int id, const std::string& name) {
  std::string c;
  put(c, id, 2);
  put_string(c, name);
  put_string(c, "ros2msg");
  put_string(c, "");  // data (uint32-prefixed)
  return record(0x03, c);
}
std::string channel_record(int id, int schema, const std::string& topic, const std::string& encoding = "cdr") {
  std::string c;
  put(c, id, 2);
  put(c, schema, 2);
  put_string(c, topic);
  put_string(c, encoding);
  put(c, 0, 4);  // empty metadata map
  return record(0x04, c);
}
std::string message_record(int channel, std::uint64_t log_time, const std::string& data) {
  std::string c;
  put(c, channel, 2);
  put(c, 0, 4);
  put(c, log_time, 8);
  put(c, log_time, 8);
  return record(0x05, c + data);
}
std::string chunk_record(const std::string& records, const std::string& compression, bool with_crc = true) {
  std::string compressed = records;
  if (compression == "zstd") {
    compressed.resize(ZSTD_compressBound(records.size()));
    compressed.resize(ZSTD_compress(compressed.data(), compressed.size(), records.data(), records.size(), 3));
  } else if (compression == "lz4") {
    compressed.resize(LZ4F_compressFrameBound(records.size(), nullptr));
    compressed.resize(LZ4F_compressFrame(compressed.data(), compressed.size(), records.data(), records.size(), nullptr));
  }
  std::string c;
  put(c, 0, 8);
  put(c, 0, 8);
  put(c, records.size(), 8);
  put(c, with_crc ? mcap::crc32(records) : 0, 4);
  put_string(c, compression);
  put(c, compressed.size(), 8);
  return record(0x06, c + compressed);
}
std::string bag_start() {
  std::string h;
  put_string(h, "ros2");
  put_string(h, "momentum test");
  return std::string(mcap::kMagic, 8) + record(0x01, h);
}
std::string bag_end() {
  std::string f;
  put(f, 0, 8);
  put(f, 0, 8);
  put(f, 0, 4);
  std::string crc;
  put(crc, 0, 4);
  return record(0x0F, crc) + record(0x02, f) + std::string(mcap::kMagic, 8);
}

// A JointState message in CDR little-endian, laid out like kLittle, for any names and values.
std::string joint_state(std::int32_t sec, std::uint32_t nanosec, const std::vector<std::string>& names,
                        const std::vector<double>& position, const std::vector<double>& velocity,
                        const std::vector<double>& effort) {
  std::string d;
  auto align = [&](std::size_t n) {
    while (d.size() % n) d += '\0';
  };
  auto str = [&](const std::string& s) {
    align(4);
    put(d, s.size() + 1, 4);
    d += s;
    d += '\0';
  };
  auto doubles = [&](const std::vector<double>& v) {
    align(4);
    put(d, v.size(), 4);
    for (double x : v) {
      align(8);
      std::uint64_t bits;
      std::memcpy(&bits, &x, 8);
      put(d, bits, 8);
    }
  };
  put(d, static_cast<std::uint32_t>(sec), 4);
  put(d, nanosec, 4);
  str("base");
  align(4);
  put(d, names.size(), 4);
  for (const auto& n : names) str(n);
  doubles(position);
  doubles(velocity);
  doubles(effort);
  return bytes({0, 1, 0, 0}) + d;
}

std::string three_joint_message(int k, const std::vector<int>& order) {
  static const std::vector<std::string> names = {"j1", "j2", "j3"};
  std::vector<std::string> n;
  std::vector<double> q, dq, tau;
  for (int j : order) {
    n.push_back(names[j]);
    q.push_back(k + 0.1 * (j + 1));
    dq.push_back(k + 0.01 * (j + 1));
    tau.push_back(-k - (j + 1.0));
  }
  return joint_state(100 + k, 500000000, n, q, dq, tau);
}

// Messages k = 0..count-1 on channel 1, the joint order rotating with k.
std::string messages(int first, int count) {
  std::string r;
  for (int k = first; k < first + count; ++k)
    r += message_record(1, 1000u * k, three_joint_message(k, {k % 3, (k + 1) % 3, (k + 2) % 3}));
  return r;
}

std::string header_records() {
  return schema_record(1, "sensor_msgs/msg/JointState") + channel_record(1, 1, "/joint_states");
}

struct Read {
  std::vector<std::uint64_t> log_times;
  std::vector<std::string> damage;
  bool ended = false;
};

Read read_all(const std::string& file) {
  mcap::MemorySource source(file);
  mcap::RecordReader records(source, "bag");
  Read r;
  for (;;) {
    auto item = records.next();
    if (item == mcap::RecordReader::Item::end) {
      r.ended = true;
      return r;
    }
    if (item == mcap::RecordReader::Item::message) r.log_times.push_back(records.message().log_time);
    if (item == mcap::RecordReader::Item::damage) r.damage.push_back(records.damage_kind() + ": " + records.damage());
  }
}

std::vector<std::uint64_t> times(int first, int count) {
  std::vector<std::uint64_t> t;
  for (int k = first; k < first + count; ++k) t.push_back(1000u * k);
  return t;
}

TEST(Mcap, Crc32CheckValue) {
  EXPECT_EQ(mcap::crc32("123456789"), 0xCBF43926u);  // the CRC-32/ISO-HDLC check value
  EXPECT_EQ(mcap::crc32("56789", mcap::crc32("1234")), 0xCBF43926u);
}

TEST(Mcap, MessagesOutsideAndInsideChunksOfEveryCompression) {
  const std::string file = bag_start() + header_records() + messages(0, 2) + chunk_record(messages(2, 3), "") +
                           chunk_record(messages(5, 4), "zstd") + chunk_record(messages(9, 5), "lz4") + bag_end();
  const Read r = read_all(file);
  EXPECT_EQ(r.log_times, times(0, 14));
  EXPECT_TRUE(r.damage.empty());
  EXPECT_TRUE(r.ended);
}

TEST(Mcap, ChunkWithABadCrcIsSkippedAndReadingGoesOn) {
  std::string bad = chunk_record(messages(2, 3), "zstd");
  const std::size_t crc_at = 9 + 24;
  bad[crc_at] = static_cast<char>(bad[crc_at] ^ 1);
  const Read r = read_all(bag_start() + header_records() + chunk_record(messages(0, 2), "lz4") + bad +
                          chunk_record(messages(5, 1), "") + bag_end());
  EXPECT_EQ(r.log_times, (std::vector<std::uint64_t>{0, 1000, 5000}));
  ASSERT_EQ(r.damage.size(), 1u);
  EXPECT_NE(r.damage[0].find("bad chunk: CRC"), std::string::npos) << r.damage[0];
}

TEST(Mcap, ZeroCrcIsNotChecked) {
  const Read r = read_all(bag_start() + header_records() + chunk_record(messages(0, 3), "zstd", false) + bag_end());
  EXPECT_EQ(r.log_times, times(0, 3));
}

TEST(Mcap, UnknownCompressionIsAnError) {
  std::string c;
  put(c, 0, 8);
  put(c, 0, 8);
  put(c, 10, 8);
  put(c, 0, 4);
  put_string(c, "brotli");
  put(c, 10, 8);
  c += std::string(10, 'x');
  const std::string file = bag_start() + header_records() + record(0x06, c) + bag_end();
  mcap::MemorySource source(file);
  mcap::RecordReader records(source, "bag");
  try {
    while (records.next() != mcap::RecordReader::Item::end) {
    }
    FAIL() << "no error";
  } catch (const momentum::Error& e) {
    EXPECT_NE(std::string(e.what()).find("chunk compression 'brotli' is not supported"), std::string::npos) << e.what();
  }
}

TEST(Mcap, ChunkAboveTheLimitIsRefused) {
  std::string c;
  put(c, 0, 8);
  put(c, 0, 8);
  put(c, mcap::kMaxChunkBytes + 1, 8);  // uncompressed size: refused before any allocation
  put(c, 0, 4);
  put_string(c, "zstd");
  put(c, 4, 8);
  c += "abcd";
  const std::string file = bag_start() + record(0x06, c) + bag_end();
  mcap::MemorySource source(file);
  mcap::RecordReader records(source, "bag");
  EXPECT_THROW(records.next(), momentum::Error);
}

TEST(Mcap, TruncatedUncompressedChunkKeepsItsCompleteMessages) {
  const std::string first = bag_start() + header_records() + chunk_record(messages(0, 3), "");
  const std::string second = chunk_record(messages(3, 4), "");
  // Cut inside the second chunk's third message: messages 3 and 4 are whole.
  const std::size_t header = 9 + 8 + 8 + 8 + 4 + 4 + 8;
  const std::size_t message = message_record(1, 0, three_joint_message(0, {0, 1, 2})).size();
  const std::string file = first + second.substr(0, header + 2 * message + message / 2);
  const Read r = read_all(file);
  EXPECT_EQ(r.log_times, times(0, 5));
  ASSERT_EQ(r.damage.size(), 1u);
  EXPECT_EQ(r.damage[0].substr(0, 33), "truncated record: truncated recor") << r.damage[0];
  EXPECT_TRUE(r.ended);
}

TEST(Mcap, TruncatedCompressedChunkAndTruncatedFile) {
  const std::string whole = bag_start() + header_records() + chunk_record(messages(0, 3), "zstd");
  const std::string cut = whole + chunk_record(messages(3, 3), "lz4").substr(0, 40);
  Read r = read_all(cut);
  EXPECT_EQ(r.log_times, times(0, 3));
  ASSERT_EQ(r.damage.size(), 1u);
  EXPECT_NE(r.damage[0].find("truncated record (chunk"), std::string::npos) << r.damage[0];
  r = read_all(whole);  // cut between two records, before the data end
  ASSERT_EQ(r.damage.size(), 1u);
  EXPECT_NE(r.damage[0].find("truncated file"), std::string::npos) << r.damage[0];
}

TEST(Mcap, TruncatedCompressedChunkKeepsTheMessagesOfItsCompleteBlocks) {
  // 3000 messages (about 500 KiB) make several zstd blocks (128 KiB) and lz4 blocks (64 KiB).
  for (const std::string compression : {"zstd", "lz4"}) {
    const std::string chunk = chunk_record(messages(0, 3000), compression);
    const std::string file = bag_start() + header_records() + chunk.substr(0, chunk.size() * 6 / 10);
    const Read r = read_all(file);
    ASSERT_GT(r.log_times.size(), 0u) << compression;
    ASSERT_LT(r.log_times.size(), 3000u) << compression;
    EXPECT_EQ(r.log_times, times(0, static_cast<int>(r.log_times.size()))) << compression;
    ASSERT_EQ(r.damage.size(), 1u);
    EXPECT_NE(r.damage[0].find("its complete messages kept"), std::string::npos) << r.damage[0];
  }
}

TEST(Mcap, WrongMagicAndVersion) {
  mcap::MemorySource csv("t,q1\n0,1\n");
  EXPECT_THROW(mcap::RecordReader(csv, "x"), momentum::Error);
  std::string v1 = bag_start() + bag_end();
  v1[5] = '1';
  mcap::MemorySource next_version(v1);
  try {
    mcap::RecordReader records(next_version, "x");
    FAIL();
  } catch (const momentum::Error& e) {
    EXPECT_NE(std::string(e.what()).find("major version '1'"), std::string::npos) << e.what();
  }
}

// --- Reader::open on bags ---

std::string temp_bag(const std::string& name, const std::string& content) {
  const std::string path = ::testing::TempDir() + "/momentum_mcap_" + std::to_string(::getpid()) + "_" + name;
  std::ofstream(path, std::ios::binary) << content;
  return path;
}

TEST(McapReader, JointsInChainOrderWhateverTheMessageOrder) {
  const std::string path = temp_bag("chain.mcap", bag_start() + header_records() + chunk_record(messages(0, 6), "zstd") + bag_end());
  ms::ReaderOptions options;
  options.joint_names = {"j3", "j1", "j2"};  // the chain's order, not the messages'
  auto in = ms::Reader::open(path, options);
  EXPECT_EQ(in->encoding(), ms::Encoding::mcap);
  EXPECT_EQ(in->columns(), (std::vector<std::string>{"t", "q1", "q2", "q3", "dq1", "dq2", "dq3", "tau_m1", "tau_m2", "tau_m3"}));
  const int chain[3] = {2, 0, 1};  // index in j1..j3 of column joint 1..3
  for (int k = 0; k < 6; ++k) {
    const double* row = in->next();
    ASSERT_NE(row, nullptr);
    EXPECT_DOUBLE_EQ(row[0], 100 + k + 0.5);
    for (int j = 0; j < 3; ++j) {
      EXPECT_DOUBLE_EQ(row[1 + j], k + 0.1 * (chain[j] + 1)) << k << " " << j;
      EXPECT_DOUBLE_EQ(row[4 + j], k + 0.01 * (chain[j] + 1));
      EXPECT_DOUBLE_EQ(row[7 + j], -k - (chain[j] + 1.0));
    }
  }
  EXPECT_EQ(in->next(), nullptr);
  EXPECT_EQ(in->rows_skipped(), 0u);
}

TEST(McapReader, WithoutAChainTheFirstMessageOrderAndItsNamesAsAComment) {
  const std::string path = temp_bag("first.mcap", bag_start() + header_records() + messages(1, 3) + bag_end());
  auto in = ms::Reader::open(path, {});
  ASSERT_EQ(in->leading_comments().size(), 2u);
  EXPECT_EQ(in->leading_comments()[1], " joints: 1=j2 2=j3 3=j1");
  for (int k = 1; k < 4; ++k) {
    const double* row = in->next();
    ASSERT_NE(row, nullptr);
    EXPECT_DOUBLE_EQ(row[1], k + 0.2);  // j2 in every row, whatever the message's order
    EXPECT_DOUBLE_EQ(row[3], k + 0.1);
  }
}

TEST(McapReader, MissingChainJointIsAnErrorNamingItAndTheNamesPresent) {
  const std::string path = temp_bag("missing.mcap", bag_start() + header_records() + messages(0, 2) + bag_end());
  ms::ReaderOptions options;
  options.joint_names = {"j1", "j2", "j3", "j4"};
  try {
    ms::Reader::open(path, options);
    FAIL();
  } catch (const momentum::Error& e) {
    EXPECT_NE(std::string(e.what()).find("joint 'j4' of the profile's chain is not in the JointState message (it has j1, j2, j3)"),
              std::string::npos)
        << e.what();
  }
}

TEST(McapReader, ZeroStampFallsBackToLogTimeAndBigEndianMessagesRead) {
  std::string zero = joint_state(0, 0, {"a"}, {1.0}, {}, {});
  const std::string path = temp_bag("zero.mcap", bag_start() + header_records() + message_record(1, 2500000000, zero) +
                                                     message_record(1, 9, kBig) + bag_end());
  std::vector<std::string> warnings;
  auto previous = momentum::set_warning_sink([&](std::string_view m) { warnings.emplace_back(m); });
  ms::ReaderOptions options;
  options.strict = true;
  options.time_order = false;
  options.joint_names = {"a"};
  auto in = ms::Reader::open(path, options);
  EXPECT_EQ(in->columns(), (std::vector<std::string>{"t", "q1"}));
  const double* row = in->next();
  ASSERT_NE(row, nullptr);
  EXPECT_DOUBLE_EQ(row[0], 2.5);
  row = in->next();  // kBig: names a, bc; a's position 1.5 at 5.25 s
  ASSERT_NE(row, nullptr);
  EXPECT_DOUBLE_EQ(row[0], 5.25);
  EXPECT_DOUBLE_EQ(row[1], 1.5);
  momentum::set_warning_sink(previous);
  ASSERT_GE(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("header.stamp is zero"), std::string::npos) << warnings[0];
}

TEST(McapReader, SeveralJointStateTopicsNeedATopic) {
  const std::string file = bag_start() + header_records() + channel_record(2, 1, "/other/joint_states") +
                           channel_record(3, 0, "/chatter") + messages(0, 2) + bag_end();
  const std::string path = temp_bag("topics.mcap", file);
  try {
    ms::Reader::open(path, {});
    FAIL();
  } catch (const momentum::Error& e) {
    EXPECT_NE(std::string(e.what()).find("several sensor_msgs/msg/JointState topics (/joint_states, /other/joint_states)"),
              std::string::npos)
        << e.what();
  }
  ms::ReaderOptions options;
  options.topic = "/joint_states";
  EXPECT_EQ(ms::Reader::open(path, options)->columns().size(), 10u);
  options.topic = "/chatter";
  EXPECT_THROW(ms::Reader::open(path, options), momentum::Error);
  options.topic = "/nowhere";
  EXPECT_THROW(ms::Reader::open(path, options), momentum::Error);
}

TEST(McapReader, BagsAreReadNotWritten) {
  EXPECT_EQ(ms::encoding_name(ms::Encoding::mcap), "mcap");
  EXPECT_THROW(ms::Writer::open(temp_bag("out.mcap", ""), {ms::Encoding::mcap, false}), momentum::Error);
}

}  // namespace
