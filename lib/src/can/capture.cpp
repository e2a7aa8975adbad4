#include "momentum/can/capture.hpp"

#include <algorithm>
#include <cmath>

#include "momentum/can/candump.hpp"
#include "momentum/can/codec.hpp"
#include "momentum/core/error.hpp"

namespace momentum::can {

bool CaptureOptions::IsValid(std::string* why) const {
  auto no = [&](const char* message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (interface.empty() || interface.size() > 32 || interface.find_first_of(" \t\n()#") != std::string::npos)
    return no("the interface name must be 1 to 32 characters without blanks, '(', ')' or '#'");
  if (!(frame_spacing >= 0 && std::isfinite(frame_spacing))) return no("the frame spacing must be 0 or more seconds");
  if (send_sync && (sync_key & kExtendedFlag ? (sync_key & ~(kExtendedFlag | kExtendedMask)) != 0 : sync_key > kStandardMask))
    return no("the SYNC id is neither an 11-bit nor a 29-bit id");
  return true;
}

CaptureWriter::CaptureWriter(const Database& db, std::vector<ColumnSource> sources, CaptureOptions options)
    : sources_(std::move(sources)), options_(std::move(options)) {
  std::string why;
  if (!options_.IsValid(&why)) throw Error(why);
  const Message* base = db.messages().data();
  for (std::size_t c = 0; c < sources_.size(); ++c) {
    const ColumnSource& src = sources_[c];
    if (src.message == nullptr || src.message < base || src.message >= base + db.messages().size() || src.signal < 0 ||
        static_cast<std::size_t>(src.signal) >= src.message->signals.size())
      throw Error("column " + src.column + ": source is not a signal of this dbc");
    const Signal& s = src.message->signals[static_cast<std::size_t>(src.signal)];
    int selector = -1;
    std::uint64_t selector_raw = 0;
    if (s.mux_parent >= 0) {
      const Signal& parent = src.message->signals[static_cast<std::size_t>(s.mux_parent)];
      if (parent.mux_parent >= 0)
        throw Error("column " + src.column + ": signal " + s.name + " is under nested multiplexing, which the encoder does not write");
      selector = s.mux_parent;
      selector_raw = s.mux_ranges.front().first;
    }
    auto it = std::find_if(groups_.begin(), groups_.end(), [&](const Group& g) {
      return g.message == src.message && g.selector == selector && g.selector_raw == selector_raw;
    });
    if (it == groups_.end()) {
      groups_.push_back(Group{src.message, selector, selector_raw, {}});
      it = groups_.end() - 1;
    }
    it->signals.emplace_back(src.signal, c);
  }
  // DBC order, then selector value, so that captures read naturally.
  std::stable_sort(groups_.begin(), groups_.end(), [&](const Group& a, const Group& b) {
    if (a.message != b.message) return a.message < b.message;
    return a.selector_raw < b.selector_raw;
  });
  std::size_t most = 0;
  for (const Message& m : db.messages()) most = std::max(most, m.signals.size());
  scratch_.resize(most);
  frames_.reserve(groups_.size() + 1);
}

std::size_t CaptureWriter::write_cycle(double t, const double* values, std::string& out) {
  frames_.clear();
  const std::int64_t t_ns = std::llround(t * 1e9);
  const std::int64_t spacing_ns = std::llround(options_.frame_spacing * 1e9);
  std::int64_t at = t_ns;
  if (options_.send_sync) {
    Frame sync;
    sync.id = options_.sync_key & ~kExtendedFlag;
    sync.extended = (options_.sync_key & kExtendedFlag) != 0;
    sync.time_ns = at;
    sync.has_time = true;
    frames_.push_back(sync);
  }
  for (const Group& g : groups_) {
    const Message& m = *g.message;
    // Unmapped signals carry raw 0 (physical value = offset).
    for (std::size_t i = 0; i < m.signals.size(); ++i) scratch_[i] = m.signals[i].offset;
    if (g.selector >= 0) {
      const Signal& sel = m.signals[static_cast<std::size_t>(g.selector)];
      scratch_[static_cast<std::size_t>(g.selector)] = static_cast<double>(g.selector_raw) * sel.factor + sel.offset;
    }
    for (const auto& [signal, column] : g.signals) scratch_[static_cast<std::size_t>(signal)] = values[column];
    Frame f;
    const EncodeSummary summary = encode(m, scratch_.data(), f);
    stats_.saturated += summary.saturated;
    at += spacing_ns;
    f.time_ns = at;
    f.has_time = true;
    frames_.push_back(f);
  }
  char line[kMaxLogLine];
  for (const Frame& f : frames_) out.append(line, format_log_line(f, options_.interface, line));
  ++stats_.cycles;
  stats_.frames += frames_.size();
  return frames_.size();
}

}  // namespace momentum::can
