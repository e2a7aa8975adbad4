#include "momentum/can/codec.hpp"

#include <bit>
#include <cstring>
#include <cmath>
#include <limits>
#include <vector>

#include "momentum/core/number.hpp"

namespace momentum::can {

namespace {

__extension__ typedef __int128 int128;
__extension__ typedef unsigned __int128 uint128;

// Exact raw * factor + offset for integer scaling.
int128 exact_physical(const Signal& s, std::uint64_t bits) {
  const int128 raw = s.is_signed ? static_cast<int128>(raw_signed(s, bits)) : static_cast<int128>(bits);
  return raw * s.factor_int + s.offset_int;
}

std::size_t format_int128(int128 v, char* out) {
  char digits[48];
  int n = 0;
  const bool negative = v < 0;
  uint128 u = negative ? static_cast<uint128>(-(v + 1)) + 1 : static_cast<uint128>(v);
  do {
    digits[n++] = static_cast<char>('0' + static_cast<int>(u % 10));
    u /= 10;
  } while (u != 0);
  std::size_t len = 0;
  if (negative) out[len++] = '-';
  while (n > 0) out[len++] = digits[--n];
  return len;
}

// core::format_double, but a NaN decoded from a frame is "nan" whatever its sign bit: a float
// signal's NaN carries no sign worth keeping.
std::size_t format_shortest(double v, char* out) {
  if (std::isnan(v)) {
    std::memcpy(out, "nan", 3);
    return 3;
  }
  return core::format_double(v, out);
}

// Whether signal i is selected by its multiplexer chain; `absent` (may be null) marks signals
// that are not in the frame, which select nothing.
bool present(const Message& m, std::size_t i, const std::uint64_t* bits, const bool* absent) {
  const Signal& s = m.signals[i];
  if (s.mux_parent < 0) return true;
  if (absent != nullptr && absent[s.mux_parent]) return false;
  const std::uint64_t selector = bits[s.mux_parent];
  bool selected = false;
  for (const auto& [lo, hi] : s.mux_ranges) {
    if (selector >= lo && selector <= hi) {
      selected = true;
      break;
    }
  }
  return selected && present(m, static_cast<std::size_t>(s.mux_parent), bits, absent);
}

}  // namespace

double raw_value(const Signal& signal, std::uint64_t bits) {
  switch (signal.value_type) {
    case ValueType::float32:
      return static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(bits)));
    case ValueType::float64:
      return std::bit_cast<double>(bits);
    case ValueType::integer:
      break;
  }
  return signal.is_signed ? static_cast<double>(raw_signed(signal, bits)) : static_cast<double>(bits);
}

double physical_value(const Signal& signal, std::uint64_t bits) {
  if (signal.value_type == ValueType::integer && signal.integer_scaling) {
    if (signal.factor_int == 1 && signal.offset_int == 0)
      return signal.is_signed ? static_cast<double>(raw_signed(signal, bits)) : static_cast<double>(bits);
    return static_cast<double>(exact_physical(signal, bits));
  }
  return raw_value(signal, bits) * signal.factor + signal.offset;
}

std::size_t format_raw(const Signal& signal, std::uint64_t bits, char* out) {
  if (signal.value_type != ValueType::integer) return format_shortest(raw_value(signal, bits), out);
  const int128 raw = signal.is_signed ? static_cast<int128>(raw_signed(signal, bits)) : static_cast<int128>(bits);
  return format_int128(raw, out);
}

std::size_t format_physical(const Signal& signal, std::uint64_t bits, char* out) {
  if (signal.value_type == ValueType::integer && signal.integer_scaling)
    return format_int128(exact_physical(signal, bits), out);
  return format_shortest(physical_value(signal, bits), out);
}

std::size_t decode(const Message& message, const Frame& frame, SignalValue* out, bool* truncated) {
  const std::size_t n = message.signals.size();
  const std::size_t len = frame.len;
  bool short_frame = false;
  std::size_t count = 0;
  bool has_mux = false;
  for (const Signal& s : message.signals) has_mux |= s.mux_parent >= 0;
  if (!has_mux) {
    for (std::size_t i = 0; i < n; ++i) {
      const Signal& s = message.signals[i];
      if (s.extraction.min_len > len) {
        short_frame = true;
        continue;
      }
      const std::uint64_t bits = extract_bits(s, frame.data);
      out[count++] = SignalValue{static_cast<std::uint32_t>(i), bits, physical_value(s, bits)};
    }
  } else {
    std::uint64_t local[256];
    bool local_absent[256];
    std::vector<std::uint64_t> heap;
    std::vector<char> heap_absent;
    std::uint64_t* bits = local;
    bool* absent = local_absent;
    if (n > 256) {
      heap.resize(n);
      heap_absent.resize(n);
      bits = heap.data();
      absent = reinterpret_cast<bool*>(heap_absent.data());
    }
    for (std::size_t i = 0; i < n; ++i) {
      const Signal& s = message.signals[i];
      absent[i] = s.extraction.min_len > len;
      bits[i] = absent[i] ? 0 : extract_bits(s, frame.data);
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (absent[i]) {
        if (present(message, i, bits, absent)) short_frame = true;
        continue;
      }
      const Signal& s = message.signals[i];
      if (!present(message, i, bits, absent)) continue;
      out[count++] = SignalValue{static_cast<std::uint32_t>(i), bits[i], physical_value(s, bits[i])};
    }
  }
  if (truncated != nullptr) *truncated = short_frame;
  return count;
}

std::uint64_t encode_bits(const Signal& signal, double value, bool* saturated) {
  bool clamped = false;
  std::uint64_t bits = 0;
  const double scaled = (value - signal.offset) / signal.factor;
  switch (signal.value_type) {
    case ValueType::float32: {
      const float f = static_cast<float>(scaled);
      if (std::isinf(f) && !std::isinf(scaled)) clamped = true;
      bits = std::bit_cast<std::uint32_t>(f);
      break;
    }
    case ValueType::float64:
      bits = std::bit_cast<std::uint64_t>(scaled);
      break;
    case ValueType::integer: {
      const double lo = signal.is_signed ? -std::ldexp(1.0, signal.length - 1) : 0.0;
      const double hi = signal.is_signed ? std::ldexp(1.0, signal.length - 1) - 1 : std::ldexp(1.0, signal.length) - 1;
      double r = std::nearbyint(scaled);
      if (std::isnan(r)) {
        r = 0;
        clamped = true;
      } else if (r < lo) {
        r = lo;
        clamped = true;
      } else if (r > hi) {
        // For 64-bit fields hi is not representable; 2^63 or 2^64 rounds onto it.
        r = hi;
        clamped = true;
      }
      if (signal.is_signed) {
        std::int64_t v;
        if (r >= 9223372036854775807.0) {
          v = std::numeric_limits<std::int64_t>::max();
        } else {
          v = static_cast<std::int64_t>(r);
        }
        bits = static_cast<std::uint64_t>(v);
      } else {
        bits = r >= 18446744073709551615.0 ? ~std::uint64_t{0} : static_cast<std::uint64_t>(r);
      }
      // For 64-bit fields the clamp in double is not exact: limit in integers too.
      if (signal.is_signed && signal.length < 64) {
        const std::int64_t max = (std::int64_t{1} << (signal.length - 1)) - 1;
        if (static_cast<std::int64_t>(bits) > max) bits = static_cast<std::uint64_t>(max);
      }
      break;
    }
  }
  if (saturated != nullptr) *saturated = clamped;
  return bits & signal.extraction.mask;
}

void insert_bits(const Signal& signal, std::uint64_t bits, std::uint8_t* data) {
  const Extraction& e = signal.extraction;
  std::uint8_t* p = data + e.byte;
  bits &= e.mask;
  // Work on the 16-byte window as two 64-bit halves in the load order of extract_bits().
  if (signal.byte_order == ByteOrder::little_endian) {
    std::uint64_t lo = detail::load_le64(p);
    lo = (lo & ~(e.mask << e.shift)) | (bits << e.shift);
    std::uint64_t le = lo;
    if constexpr (__BYTE_ORDER__ == __ORDER_BIG_ENDIAN__) le = __builtin_bswap64(le);
    std::memcpy(p, &le, 8);
    if (e.wide) {
      std::uint64_t hi = detail::load_le64(p + 8);
      const unsigned down = 64U - e.shift;
      hi = (hi & ~(e.mask >> down)) | (bits >> down);
      if constexpr (__BYTE_ORDER__ == __ORDER_BIG_ENDIAN__) hi = __builtin_bswap64(hi);
      std::memcpy(p + 8, &hi, 8);
    }
    return;
  }
  if (!e.wide) {
    std::uint64_t w = detail::load_be64(p);
    w = (w & ~(e.mask << e.shift)) | (bits << e.shift);
    if constexpr (__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__) w = __builtin_bswap64(w);
    std::memcpy(p, &w, 8);
    return;
  }
  // 128-bit big-endian window: value = hi:lo, field = bits << shift (shift < 64).
  std::uint64_t hi = detail::load_be64(p);
  std::uint64_t lo = detail::load_be64(p + 8);
  const unsigned up = 64U - e.shift;
  hi = (hi & ~(e.mask >> up)) | (bits >> up);
  lo = (lo & ~(e.mask << e.shift)) | (bits << e.shift);
  if constexpr (__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__) {
    hi = __builtin_bswap64(hi);
    lo = __builtin_bswap64(lo);
  }
  std::memcpy(p, &hi, 8);
  std::memcpy(p + 8, &lo, 8);
}

EncodeSummary encode(const Message& message, const double* values, Frame& frame) {
  EncodeSummary summary;
  std::memset(frame.data, 0, sizeof(frame.data));
  frame.id = message.key & ~kExtendedFlag;
  frame.extended = (message.key & kExtendedFlag) != 0;
  frame.rtr = false;
  frame.error = false;
  frame.fd = message.is_fd;
  frame.fd_flags = message.is_fd ? 0x04 : 0;  // CANFD_FDF, as current kernels report
  frame.len = static_cast<std::uint8_t>(message.length);
  frame.len8_dlc = 0;
  const std::size_t n = message.signals.size();
  std::uint64_t local[256];
  std::vector<std::uint64_t> heap;
  std::uint64_t* bits = local;
  if (n > 256) {
    heap.resize(n);
    bits = heap.data();
  }
  for (std::size_t i = 0; i < n; ++i) {
    bool clamped = false;
    bits[i] = encode_bits(message.signals[i], values[i], &clamped);
    if (clamped) ++summary.saturated;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!present(message, i, bits, nullptr)) continue;
    insert_bits(message.signals[i], bits[i], frame.data);
    ++summary.signals_written;
  }
  // insert_bits may write zeros into the padding beyond the payload; it stays zero.
  return summary;
}

double resolution(const Signal& signal, double value) {
  switch (signal.value_type) {
    case ValueType::float32:
      return std::abs(value) * 0x1p-24 + std::abs(signal.offset) * 0x1p-24;
    case ValueType::float64:
      return std::abs(value) * 0x1p-53 * 2 + std::abs(signal.offset) * 0x1p-52;
    case ValueType::integer:
      break;
  }
  return std::abs(signal.factor) / 2;
}

}  // namespace momentum::can
