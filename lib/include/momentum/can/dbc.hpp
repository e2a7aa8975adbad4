#pragma once
// DBC files: the subset that says how to decode and encode signals.
//
// Read: BO_ (bit 31 of the id marks a 29-bit id), SG_ with Intel (@1) and Motorola (@0) byte
// order, signedness, factor, offset, min, max, unit and receivers; multiplexing (M, m<k>,
// m<k>M) with SG_MUL_VAL_ extended multiplexing; SIG_VALTYPE_ (1: IEEE float, 2: double);
// VAL_ value tables; CM_ comments (strings may span lines); BA_DEF_ / BA_DEF_DEF_ / BA_
// "VFrameFormat" for CAN FD messages. Every other statement is skipped up to its ';'.
//
// Every signal's extraction is precomputed when the file is loaded (byte window, shift, mask,
// sign extension), so decoding a frame is a table lookup and a few shifts per signal.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "momentum/can/frame.hpp"

namespace momentum::can {

enum class ByteOrder : std::uint8_t { little_endian /* Intel, @1 */, big_endian /* Motorola, @0 */ };
enum class ValueType : std::uint8_t { integer, float32, float64 };

// How a signal takes its bits out of the payload; computed by Database from the SG_ fields.
struct Extraction {
  std::uint16_t byte = 0;    // first payload byte of the load window
  std::uint8_t shift = 0;    // right shift after the (8-byte) load
  bool wide = false;         // the field spans 9 bytes: a second load is needed
  std::uint64_t mask = 0;    // (1 << length) - 1, all ones for 64 bits
  std::uint16_t min_len = 0; // payload bytes needed to hold the whole signal
};

struct Signal {
  std::string name;
  // Start bit as written in the DBC: the least significant bit for Intel, the most
  // significant bit (in the byte-wise "sawtooth" numbering, bit 7 = MSB of byte 0) for
  // Motorola.
  std::uint16_t start_bit = 0;
  std::uint16_t length = 0;  // bits, 1..64
  ByteOrder byte_order = ByteOrder::little_endian;
  bool is_signed = false;
  ValueType value_type = ValueType::integer;
  // physical = raw * factor + offset. When both were written as integers (as in "(1,0)"),
  // integer_scaling holds and decoders can compute the physical value exactly in integers.
  double factor = 1;
  double offset = 0;
  bool integer_scaling = false;
  std::int64_t factor_int = 1;
  std::int64_t offset_int = 0;
  double minimum = 0;  // [min|max] as written; both zero means "no range"
  double maximum = 0;
  std::string unit;
  std::vector<std::string> receivers;
  std::string comment;
  // VAL_ table: raw value -> description, in file order. Kept for display only.
  std::vector<std::pair<std::int64_t, std::string>> choices;

  // Multiplexing. `is_multiplexer`: this signal selects others (M or m<k>M). `mux_parent` is
  // the index (in Message::signals) of the signal that selects this one, -1 when the signal is
  // always present; it is then present when the parent's raw value lies in one of
  // `mux_ranges` (inclusive) and the parent itself is present.
  bool is_multiplexer = false;
  int mux_parent = -1;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> mux_ranges;

  Extraction extraction;
  std::uint32_t line = 0;  // line of the SG_ statement
};

struct Message {
  std::uint32_t key = 0;  // id, plus kExtendedFlag for a 29-bit id (the BO_ number as written)
  std::string name;
  std::uint32_t length = 0;  // bytes
  bool is_fd = false;        // VFrameFormat *_FD, or longer than 8 bytes
  std::string sender;
  std::string comment;
  // Signals in the order cantools lists them: by start bit (a Motorola signal by the position
  // of its MSB in the big-endian bit stream), ties in file order.
  std::vector<Signal> signals;
  std::uint32_t line = 0;  // line of the BO_ statement

  // Index of a signal by name, or -1.
  int find(std::string_view signal_name) const;
};

class DbcParser;

// A loaded DBC file. Read-only after loading; safe to share between threads.
class Database {
 public:
  // Parses DBC text. `name` is used in error messages (`name:line: message`). Throws
  // momentum::Error for a syntax error, an impossible signal (length 0 or above 64, bits
  // outside the message, float of a length other than 32/64), a duplicate message id or
  // signal name, or a reference to an unknown message or signal.
  static Database parse(std::string_view text, std::string_view name = "<dbc>");
  // Reads and parses a file. Throws momentum::Error (`file: cannot open: ...` or as parse()).
  static Database load(const std::string& path);

  const std::vector<Message>& messages() const { return messages_; }
  // The message for a frame key (Frame::key()), or nullptr. Constant time.
  const Message* find(std::uint32_t key) const {
    if (key <= kStandardMask) {
      const std::int32_t i = standard_[key];
      return i < 0 ? nullptr : &messages_[static_cast<std::size_t>(i)];
    }
    auto it = extended_.find(key);
    return it == extended_.end() ? nullptr : &messages_[it->second];
  }
  // The message with this name, or nullptr.
  const Message* find_name(std::string_view message_name) const;
  const std::string& version() const { return version_; }

 private:
  friend class DbcParser;
  std::vector<Message> messages_;
  std::vector<std::int32_t> standard_;  // 2048 entries: message index or -1
  std::unordered_map<std::uint32_t, std::size_t> extended_;
  std::string version_;
};

}  // namespace momentum::can
