// libFuzzer target: DBC text. Any input either loads or throws momentum::Error (never
// crashes); a database that loads encodes and decodes frames of every message, and a value
// encoded then decoded stays within the signal's resolution.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <vector>

#include "momentum/can/codec.hpp"
#include "momentum/can/dbc.hpp"
#include "momentum/core/error.hpp"

using namespace momentum::can;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const Database db = Database::parse(text, "fuzz.dbc");
    Frame frame;
    std::vector<SignalValue> out;
    for (const Message& m : db.messages()) {
      if (db.find(m.key) == nullptr) __builtin_trap();
      out.resize(m.signals.size());
      // Decode a frame filled from the input itself.
      clear(frame);
      frame.len = static_cast<std::uint8_t>(m.length);
      std::memcpy(frame.data, data, size < m.length ? size : m.length);
      decode(m, frame, out.data());
      // Whole messages encode and decode without fault (overlapping signals may clobber each
      // other, so values are checked per signal below).
      std::vector<double> values(m.signals.size());
      for (std::size_t i = 0; i < m.signals.size(); ++i)
        values[i] = static_cast<double>(i % 3) * m.signals[i].factor + m.signals[i].offset;
      encode(m, values.data(), frame);
      decode(m, frame, out.data());
      // Each signal alone: its bits come back exactly, its value within resolution.
      for (std::size_t i = 0; i < m.signals.size(); ++i) {
        const Signal& s = m.signals[i];
        bool saturated = false;
        const std::uint64_t bits = encode_bits(s, values[i], &saturated);
        std::uint8_t payload[kPayloadStorage] = {};
        insert_bits(s, bits, payload);
        if (extract_bits(s, payload) != bits) __builtin_trap();
        for (std::size_t b = s.extraction.min_len; b < kPayloadStorage; ++b)
          if (payload[b] != 0) __builtin_trap();  // nothing written past the signal
        const bool exact = s.value_type == ValueType::integer && !saturated && std::abs(s.factor) > 1e-200 &&
                           std::abs(s.factor) < 1e200 && std::abs(s.offset) < 1e200 && std::isfinite(values[i]);
        if (!exact) continue;
        const double err = std::abs(physical_value(s, bits) - values[i]);
        if (err > resolution(s, values[i]) * 1.000001 + std::abs(values[i]) * 1e-12 + 1e-300) __builtin_trap();
      }
    }
  } catch (const momentum::Error&) {
  }
  return 0;
}
