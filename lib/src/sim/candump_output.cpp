#include "momentum/sim/candump_output.hpp"

#include <algorithm>

#include "momentum/core/error.hpp"

namespace momentum::sim {

namespace {
constexpr std::uint32_t kSyncKey = 0x080;
constexpr double kFrameSpacing = 100e-6;
}  // namespace

CandumpOutput::CandumpOutput(const can::Database& db, const std::string& path, int nq, double period,
                             std::string interface) {
  const std::vector<std::string> columns = sample_columns(nq, true);
  bool has_sync = false;
  std::vector<can::ColumnSource> sources;
  std::size_t messages = 0;
  for (const auto& message : db.messages()) {
    if (message.key == kSyncKey) {
      has_sync = true;
      continue;
    }
    bool any = false;
    for (std::size_t k = 0; k < message.signals.size(); ++k) {
      const can::Signal& signal = message.signals[k];
      const auto it = std::find(columns.begin(), columns.end(), signal.name);
      if (it == columns.end()) {
        if (!signal.is_multiplexer)
          warn("dbc signal " + message.name + "." + signal.name + " matches no column; sent as raw 0");
        continue;
      }
      sources.push_back({signal.name, &message, static_cast<int>(k)});
      columns_.push_back(static_cast<std::size_t>(it - columns.begin()));
      any = true;
    }
    if (!any)
      throw Error("dbc message " + message.name + " has no signal named after a sample column (q1, dq1, i1, ...)");
    ++messages;
  }
  if (!has_sync) throw Error("the dbc has no SYNC message (id 0x080) to start each cycle");
  can::CaptureOptions options;
  options.interface = std::move(interface);
  options.sync_key = kSyncKey;
  options.frame_spacing = std::min(kFrameSpacing, period / static_cast<double>(messages + 2));
  writer_.emplace(db, std::move(sources), std::move(options));
  values_.resize(columns_.size());
  out_.emplace(path);
}

CandumpOutput::~CandumpOutput() = default;

void CandumpOutput::put(const std::string& text) {
  buffer_ += text;
  if (buffer_.size() >= (1u << 16)) {
    out_->write(buffer_);
    buffer_.clear();
  }
}

void CandumpOutput::write(const Sample& s) {
  sample_row(s, true, row_);
  for (std::size_t c = 0; c < columns_.size(); ++c) values_[c] = row_[columns_[c]];
  text_.clear();
  writer_->write_cycle(s.t, values_.data(), text_);
  put(text_);
}

void CandumpOutput::close() {
  if (!out_) return;
  const std::string rest = std::move(buffer_);
  buffer_.clear();
  out_->write(rest);
  out_->close();
  out_.reset();
}

}  // namespace momentum::sim
