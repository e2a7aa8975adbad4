#include "momentum/drivers/can_convert.hpp"

#include <cmath>
#include <initializer_list>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>

#include "momentum/can/dbc.hpp"
#include "momentum/can/socketcan.hpp"
#include "momentum/core/error.hpp"
#include "momentum/stream/writer.hpp"

namespace momentum::drivers {

// This driver runs the can stage: its names are this file's vocabulary.
using namespace can;

// ---- FrameSource ----------------------------------------------------------------------------

namespace {
// Thrown out of a blocking read (through the reader's interrupt hook) to end the source.
struct Stopped {};
}  // namespace

std::unique_ptr<FrameSource> FrameSource::files(std::vector<std::string> paths, CandumpOptions options) {
  std::unique_ptr<FrameSource> source(new FrameSource());
  source->paths_ = std::move(paths);
  if (source->paths_.empty()) source->paths_.push_back("-");
  source->text_options_ = std::move(options);
  source->open_next_text();
  return source;
}

std::unique_ptr<FrameSource> FrameSource::interface(const std::string& name) {
  std::unique_ptr<FrameSource> source(new FrameSource());
  source->socket_ = std::make_unique<SocketCanReader>(open_can_socket(name), true, name);
  source->interface_ = name;
  source->live_ = true;
  return source;
}

FrameSource::~FrameSource() = default;

bool FrameSource::open_next_text() {
  if (text_) {
    done_.bad_lines += text_->stats().bad_lines;
    done_.lost_frames += text_->stats().lost_frames;
    done_.frames += text_->stats().frames;
    done_.filtered += text_->stats().filtered;
    text_.reset();
  }
  if (next_path_ >= paths_.size()) return false;
  text_ = CandumpReader::open(paths_[next_path_++], text_options_);
  live_ = live_ || text_->live();
  text_->on_interrupt([this] {
    if (keep_going_ && !keep_going_()) throw Stopped{};
  });
  if (before_read_) text_->before_read(before_read_);
  return true;
}

void FrameSource::before_read(std::function<void()> hook) {
  before_read_ = std::move(hook);
  if (text_) text_->before_read(before_read_);
}

bool FrameSource::next(Frame& frame) {
  if (stopped_) return false;
  auto go_on = [this] { return !keep_going_ || keep_going_(); };
  try {
    for (;;) {
      if (!go_on()) break;
      if (socket_) {
        const auto status = socket_->next(frame);
        if (status == SocketCanReader::Status::frame) return true;
        if (status == SocketCanReader::Status::end) return false;
        continue;  // interrupted: asked again at the top
      }
      if (!text_) return false;
      if (text_->next(frame)) {
        if (!go_on()) break;
        return true;
      }
      if (!open_next_text()) return false;
    }
  } catch (const Stopped&) {
  }
  stopped_ = true;
  return false;
}

std::string FrameSource::where() const { return text_ ? text_->where() : interface_; }

SourceStats FrameSource::stats() const {
  SourceStats s = done_;
  if (text_) {
    s.bad_lines += text_->stats().bad_lines;
    s.lost_frames += text_->stats().lost_frames;
    s.frames += text_->stats().frames;
    s.filtered += text_->stats().filtered;
  }
  if (socket_) {
    s.lost_frames += socket_->stats().lost_frames;
    s.frames += socket_->stats().frames;
    s.bad_records += socket_->stats().bad_records;
  }
  return s;
}

// ---- options and summary --------------------------------------------------------------------

bool ConvertOptions::IsValid(std::string* why) const {
  auto no = [&](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  const int boundaries = (!sync.empty()) + (!cycle_message.empty()) + (period.has_value());
  if (boundaries > 1) return no("--sync, --cycle-message and --period are alternatives: give one");
  if (!interface.empty() && !inputs.empty()) return no("-i reads a live interface: give no files");
  if (long_format && (boundaries > 0 || !map.empty() || hold > 0))
    return no("--long writes every signal: --map, --sync, --cycle-message, --period and --hold do not apply");
  if (long_format && encoding != stream::Encoding::csv) return no("--long writes csv only");
  if (!sync.empty()) {
    try {
      parse_can_id(sync);
    } catch (const Error& e) {
      return no(std::string("--sync: ") + e.what());
    }
  }
  if (hold < 0) return no("hold must be 0 or more cycles");
  std::string period_why;
  if (period && !valid_period(*period, &period_why)) return no("--period: " + period_why);
  return true;
}

namespace {

// One line of counters: "<prefix>label N, label N, ...\n".
std::string counter_line(std::string_view prefix,
                         std::initializer_list<std::pair<const char*, std::uint64_t>> counters) {
  std::string line(prefix);
  const char* separator = "";
  for (const auto& [label, count] : counters) {
    line += separator;
    line += label;
    line += ' ';
    line += std::to_string(count);
    separator = ", ";
  }
  return line + "\n";
}

}  // namespace

std::string format_summary(const ConvertSummary& summary, std::string_view prefix) {
  const SourceStats& f = summary.source;
  if (summary.mode == ConvertSummary::Mode::cycles) {
    const CycleStats& s = summary.cycles;
    return counter_line(prefix, {{"frames read", f.frames}, {"decoded", s.decoded}, {"unknown ids", s.unknown_ids},
                                 {"sync", s.sync_frames}, {"error frames", s.error_frames},
                                 {"remote", s.remote_frames}, {"short", s.short_frames}}) +
           counter_line(prefix, {{"bad lines", f.bad_lines}, {"lost frames", f.lost_frames},
                                 {"bad records", f.bad_records}, {"frames before the first cycle", s.before_first_cycle},
                                 {"filtered (--bus)", f.filtered}}) +
           counter_line(prefix, {{"cycles complete", s.complete_cycles}, {"incomplete", s.incomplete_cycles},
                                 {"values missing", s.missing_values}, {"held", s.held_values},
                                 {"repeated", s.repeated_values}, {"empty periods", s.empty_periods}});
  }
  if (summary.mode == ConvertSummary::Mode::signals) {
    const SignalRowCounts& c = summary.signals;
    return counter_line(prefix, {{"frames read", f.frames}, {"decoded", c.decoded}, {"unknown ids", c.unknown_ids},
                                 {"short", c.short_frames}, {"bad lines", f.bad_lines}, {"lost frames", f.lost_frames},
                                 {"filtered (--bus)", f.filtered}});
  }
  return {};
}

std::string summary_json_line(const ConvertSummary& summary) {
  // Keys in sorted order, as a JSON object of counters is written everywhere in the suite.
  const SourceStats& f = summary.source;
  std::map<std::string, std::uint64_t> fields = {
      {"frames_read", f.frames}, {"bad_lines", f.bad_lines}, {"lost_frames", f.lost_frames}, {"filtered", f.filtered}};
  if (summary.mode == ConvertSummary::Mode::cycles) {
    const CycleStats& s = summary.cycles;
    fields.insert({{"decoded", s.decoded},
                   {"unknown_ids", s.unknown_ids},
                   {"sync", s.sync_frames},
                   {"error_frames", s.error_frames},
                   {"remote", s.remote_frames},
                   {"short", s.short_frames},
                   {"bad_records", f.bad_records},
                   {"before_first_cycle", s.before_first_cycle},
                   {"cycles_complete", s.complete_cycles},
                   {"cycles_incomplete", s.incomplete_cycles},
                   {"values_missing", s.missing_values},
                   {"values_held", s.held_values},
                   {"values_repeated", s.repeated_values},
                   {"empty_periods", s.empty_periods}});
  } else if (summary.mode == ConvertSummary::Mode::signals) {
    const SignalRowCounts& c = summary.signals;
    fields.insert({{"decoded", c.decoded}, {"unknown_ids", c.unknown_ids}, {"short", c.short_frames}});
  }
  std::string out = "{";
  for (const auto& [key, value] : fields) {
    if (out.size() > 1) out += ',';
    out += '"' + key + "\":" + std::to_string(value);
  }
  return out + "}\n";
}

// ---- Converter ------------------------------------------------------------------------------

struct Converter::State {
  ConvertOptions options;
  Database db;
  std::unique_ptr<FrameSource> source;
  std::unique_ptr<CycleAssembler> cycles;
  std::unique_ptr<stream::Writer> writer;
  std::unique_ptr<SignalRowWriter> signals;
  std::uint64_t rows = 0;
};

namespace {

CycleOptions cycle_options(const ConvertOptions& o, const Database& db) {
  CycleOptions options;
  options.hold = o.hold;
  if (o.period) {
    options.boundary = CycleBoundary::period;
    options.period = *o.period;
  } else if (!o.cycle_message.empty()) {
    const Message* m = db.find_name(o.cycle_message);
    if (m == nullptr) throw Error(o.dbc + ": no message '" + o.cycle_message + "' (--cycle-message)");
    options.boundary = CycleBoundary::message;
    options.message_key = m->key;
  } else if (!o.sync.empty()) {
    options.sync_key = parse_can_id(o.sync);
  }
  return options;
}

}  // namespace

Converter::Converter(ConvertOptions options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  auto s = std::make_unique<State>();
  s->db = Database::load(options.dbc);
  s->source = options.interface.empty() ? FrameSource::files(options.inputs, options.text)
                                        : FrameSource::interface(options.interface);
  if (options.long_format) {
    s->signals = std::make_unique<SignalRowWriter>(s->db, options.output);
    SignalRowWriter* w = s->signals.get();
    s->source->before_read([w] { w->flush(); });
  } else {
    std::vector<ColumnSource> sources =
        options.map.empty() ? columns_from_signal_names(s->db) : read_column_map(options.map, s->db);
    if (sources.empty())
      throw Error(options.dbc + ": no signal is named like a stream column (q1, dq1, i1, tau_m1, ...); give --map FILE");
    s->cycles = std::make_unique<CycleAssembler>(s->db, std::move(sources), cycle_options(options, s->db));
    stream::WriterOptions writer_options;
    writer_options.encoding = options.encoding;
    writer_options.line_buffered = options.line_buffered || s->source->live();
    s->writer = stream::Writer::open(options.output, writer_options);
    if (!options.provenance.empty()) s->writer->comment(options.provenance);
    s->writer->header(s->cycles->columns());
    stream::Writer* w = s->writer.get();
    if (w->interactive()) s->source->before_read([w] { w->flush(); });
  }
  s->options = std::move(options);
  state_ = std::move(s);
}

Converter::~Converter() = default;

void Converter::set_keep_going(std::function<bool()> keep_going) { state_->source->set_keep_going(std::move(keep_going)); }

void Converter::run() {
  State& s = *state_;
  Frame frame;
  if (s.signals) {
    while (s.source->next(frame)) {
      s.signals->write(frame);
      if (s.source->live()) s.signals->flush();
    }
    s.signals->flush();
    return;
  }
  bool warned_untimed = false;
  while (s.source->next(frame)) {
    if (!frame.has_time && !warned_untimed) {
      warned_untimed = true;
      warn(s.source->where() + ": capture without timestamps (candump without -t): t is nan");
    }
    const std::size_t closed = s.cycles->add(frame);
    for (std::size_t k = 0; k < closed; ++k) s.writer->row(s.cycles->row(k)), ++s.rows;
  }
  if (s.cycles->finish()) s.writer->row(s.cycles->row()), ++s.rows;
  s.writer->close();
}

ConvertSummary Converter::summary() const {
  const State& s = *state_;
  ConvertSummary summary;
  summary.source = s.source->stats();
  summary.rows = s.rows;
  if (s.cycles) {
    summary.mode = ConvertSummary::Mode::cycles;
    summary.cycles = s.cycles->stats();
  } else if (s.signals) {
    summary.mode = ConvertSummary::Mode::signals;
    summary.signals = s.signals->counts();
  }
  return summary;
}

void Converter::require_rows() const {
  if (!state_->cycles || state_->rows > 0) return;
  const std::uint64_t frames = state_->source->stats().frames;
  throw Error("no rows: " + std::to_string(frames) + " frame" + (frames == 1 ? "" : "s") +
              " read but no complete cycle (is the cycle's SYNC frame in the capture?)");
}

}  // namespace momentum::drivers
