#include "momentum/sim/candump_output.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "momentum/can/candump.hpp"
#include "momentum/can/codec.hpp"
#include "momentum/stream/error.hpp"
#include "momentum/stream/writer.hpp"

namespace momentum::sim {

namespace {
constexpr std::uint32_t kSyncKey = 0x080;
constexpr double kFrameSpacing = 100e-6;
}  // namespace

CandumpOutput::CandumpOutput(const can::Database& db, const std::string& path, int nq, double period,
                             std::string interface)
    : db_(&db), interface_(std::move(interface)) {
  const std::vector<std::string> columns = sample_columns(nq, true);
  for (const auto& message : db.messages()) {
    if (message.key == kSyncKey) {
      sync_ = &message;
      continue;
    }
    Source source{&message, {}};
    bool any = false;
    for (const auto& signal : message.signals) {
      const auto it = std::find(columns.begin(), columns.end(), signal.name);
      if (it == columns.end()) {
        source.value_index.push_back(-1);
        continue;
      }
      source.value_index.push_back(static_cast<int>(it - columns.begin()));
      any = true;
    }
    if (!any)
      throw Error("dbc message " + message.name + " has no signal named after a sample column (q1, dq1, i1, ...)");
    for (std::size_t k = 0; k < message.signals.size(); ++k)
      if (source.value_index[k] < 0 && !message.signals[k].is_multiplexer)
        warn("dbc signal " + message.name + "." + message.signals[k].name + " matches no column; sent as 0");
    sources_.push_back(std::move(source));
  }
  if (!sync_) throw Error("the dbc has no SYNC message (id 0x080) to start each cycle");
  spacing_ = std::min(kFrameSpacing, period / static_cast<double>(sources_.size() + 2));
  if (path.empty() || path == "-") {
    file_ = stdout;
    name_ = "<stdout>";
  } else {
    file_ = std::fopen(path.c_str(), "w");
    if (!file_) throw Error(path + ": cannot create: " + std::strerror(errno));
    owns_ = true;
    name_ = path;
  }
}

CandumpOutput::~CandumpOutput() {
  if (owns_ && file_) std::fclose(file_);
}

void CandumpOutput::put(const char* text, std::size_t size) {
  if (std::fwrite(text, 1, size, file_) != size) {
    if (errno == EPIPE) throw stream::BrokenPipe();
    throw Error(name_ + ": write failed: " + std::strerror(errno));
  }
}

void CandumpOutput::write(const Sample& s) {
  const auto n = s.q.size();
  values_.assign(1, s.t);
  for (const Eigen::VectorXd* v : {&s.q, &s.dq, &s.i, &s.tau_f_true, &s.tau_c_true})
    for (Eigen::Index j = 0; j < n; ++j) values_.push_back((*v)[j]);

  char line[can::kMaxLogLine];
  auto emit = [&](const can::Message& message, const std::vector<int>* indices, double t) {
    frame_.time_ns = std::llround(t * 1e9);
    frame_.has_time = true;
    signal_values_.assign(message.signals.size(), 0.0);
    if (indices)
      for (std::size_t k = 0; k < indices->size(); ++k)
        if ((*indices)[k] >= 0) signal_values_[k] = values_[static_cast<std::size_t>((*indices)[k])];
    const can::EncodeSummary summary = can::encode(message, signal_values_.data(), frame_);
    saturated_ += summary.saturated;
    put(line, can::format_log_line(frame_, interface_, line));
    ++frames_;
  };
  emit(*sync_, nullptr, s.t);
  for (std::size_t k = 0; k < sources_.size(); ++k)
    emit(*sources_[k].message, &sources_[k].value_index, s.t + static_cast<double>(k + 1) * spacing_);
}

void CandumpOutput::close() {
  if (!file_) return;
  if (std::fflush(file_) != 0) {
    if (errno == EPIPE) throw stream::BrokenPipe();
    throw Error(name_ + ": write failed: " + std::strerror(errno));
  }
  if (owns_) {
    std::fclose(file_);
    file_ = nullptr;
  }
}

}  // namespace momentum::sim
