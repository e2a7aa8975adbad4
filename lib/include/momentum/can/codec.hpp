#pragma once
// Decoding frames into physical signal values, and encoding physical values into frames, with
// one piece of bit arithmetic shared by both directions (the Extraction of each Signal).

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "momentum/can/dbc.hpp"
#include "momentum/can/frame.hpp"

namespace momentum::can {

namespace detail {
inline std::uint64_t load_le64(const std::uint8_t* p) {
  std::uint64_t v;
  std::memcpy(&v, p, 8);
  if constexpr (__BYTE_ORDER__ == __ORDER_BIG_ENDIAN__) v = __builtin_bswap64(v);
  return v;
}
inline std::uint64_t load_be64(const std::uint8_t* p) {
  std::uint64_t v;
  std::memcpy(&v, p, 8);
  if constexpr (__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__) v = __builtin_bswap64(v);
  return v;
}
}  // namespace detail

// The raw bits of a signal (zero-extended, `length` bits) from a payload buffer of at least
// kPayloadStorage bytes (a Frame's data). Bytes beyond the frame's length read as zero.
inline std::uint64_t extract_bits(const Signal& signal, const std::uint8_t* data) {
  const Extraction& e = signal.extraction;
  const std::uint8_t* p = data + e.byte;
  std::uint64_t bits;
  if (signal.byte_order == ByteOrder::little_endian) {
    bits = detail::load_le64(p) >> e.shift;
    if (e.wide) bits |= detail::load_le64(p + 8) << (64 - e.shift);
  } else if (!e.wide) {
    bits = detail::load_be64(p) >> e.shift;
  } else {
    bits = (detail::load_be64(p) << (64 - e.shift)) | (detail::load_be64(p + 8) >> e.shift);
  }
  return bits & e.mask;
}

// The raw value of an integer signal, sign-extended when the signal is signed.
inline std::int64_t raw_signed(const Signal& signal, std::uint64_t bits) {
  if (signal.length == 64) return static_cast<std::int64_t>(bits);
  const unsigned unused = 64U - signal.length;
  return static_cast<std::int64_t>(bits << unused) >> unused;
}

// The raw value as a double: the integer (signed or not) or the IEEE float/double the bits
// hold.
double raw_value(const Signal& signal, std::uint64_t bits);

// The physical value raw * factor + offset. For integer signals whose factor and offset were
// written as integers the product is formed exactly in integers and rounded once (as cantools
// computes it with Python integers); otherwise in double precision, raw * factor then + offset.
double physical_value(const Signal& signal, std::uint64_t bits);

// Writes the raw value as cantools prints it (integers exactly, floats in the shortest form
// that reads back to the same double); `out` must hold 48 characters. Returns the length.
std::size_t format_raw(const Signal& signal, std::uint64_t bits, char* out);
// Writes the physical value: exact integer when integer_scaling holds for an integer signal,
// otherwise the shortest round-trip form of physical_value(). `out`: 48 characters.
std::size_t format_physical(const Signal& signal, std::uint64_t bits, char* out);

// One decoded signal.
struct SignalValue {
  std::uint32_t index = 0;  // in Message::signals
  std::uint64_t bits = 0;   // raw field bits
  double value = 0;         // physical value
};

// Decodes every signal of `message` present in `frame`: signals whose multiplexer selects
// them, and that lie wholly within the frame's payload (a frame shorter than the DBC length
// yields fewer signals; `*truncated` is set when any signal was left out for that reason).
// Writes at most message.signals.size() values to `out`, in Message::signals order, and
// returns how many. Does not allocate for messages of up to 256 signals.
std::size_t decode(const Message& message, const Frame& frame, SignalValue* out, bool* truncated = nullptr);

// The bits that encode a physical value: integer signals round (value - offset) / factor to
// the nearest integer and saturate at the field's range (setting *saturated); float signals
// store (value - offset) / factor as IEEE float or double. NaN encodes as raw 0 (saturated).
std::uint64_t encode_bits(const Signal& signal, double value, bool* saturated = nullptr);

// Writes `bits` into the signal's place in a payload buffer of kPayloadStorage bytes, leaving
// every other bit unchanged.
void insert_bits(const Signal& signal, std::uint64_t bits, std::uint8_t* data);

// Result of encode().
struct EncodeSummary {
  std::size_t signals_written = 0;
  std::size_t saturated = 0;  // values clamped to their field's range (or NaN)
};

// Builds a frame of `message` from physical values (values[i] for Message::signals[i]).
// Multiplexed signals are written only when the multiplexer values (taken from `values`
// too) select them, exactly as decode() would read them back. The frame gets the message's
// id, length and FD-ness; time and direction are left as they are. Bits that no signal
// covers are zero.
EncodeSummary encode(const Message& message, const double* values, Frame& frame);

// Half the step between two neighbouring physical values of the signal (|factor| / 2 for
// integer signals; for floats the relative rounding of float/double times |value|, plus
// nothing else): the error bound of decode(encode(x)) for x within the signal's range.
double resolution(const Signal& signal, double value);

}  // namespace momentum::can
