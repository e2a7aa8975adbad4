// mo-can2csv: candump text (any of its formats) or a live SocketCAN interface, decoded with a
// DBC file, into a sample stream with one row per control cycle (or, with --long, one row per
// decoded signal).
#include <signal.h>

#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

#include "momentum/can/candump.hpp"
#include "momentum/can/codec.hpp"
#include "momentum/can/cycle.hpp"
#include "momentum/can/dbc.hpp"
#include "momentum/can/socketcan.hpp"
#include "momentum/cli/tool.hpp"
#include "momentum/stream/error.hpp"
#include "momentum/stream/writer.hpp"

using namespace momentum;

namespace {

volatile std::sig_atomic_t g_stats_requested = 0;
volatile std::sig_atomic_t g_stop_requested = 0;

extern "C" void on_usr1(int) { g_stats_requested = 1; }
extern "C" void on_stop(int) { g_stop_requested = 1; }

// Installs a handler without SA_RESTART, so that a blocking read returns EINTR.
void install(int signo, void (*handler)(int)) {
  struct sigaction action {};
  action.sa_handler = handler;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;
  sigaction(signo, &action, nullptr);
}

// "0x080", "080", "80" -> 0x080; 8 hex digits (or a value above 0x7FF) -> a 29-bit id.
std::uint32_t parse_can_id(std::string text) {
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) text = text.substr(2);
  if (text.empty() || text.size() > 8 || text.find_first_not_of("0123456789abcdefABCDEF") != std::string::npos)
    throw cli::UsageError("--sync: '" + text + "' is not a hexadecimal can id");
  const std::uint32_t id = static_cast<std::uint32_t>(std::stoul(text, nullptr, 16));
  if (id > can::kExtendedMask) throw cli::UsageError("--sync: " + text + " is above 1FFFFFFF");
  return (text.size() == 8 || id > can::kStandardMask) ? (id | can::kExtendedFlag) : id;
}

// Totals over every input, for --stats.
struct Totals {
  std::uint64_t frames = 0, bad_lines = 0, lost_frames = 0, bad_records = 0;
  std::uint64_t long_decoded = 0, long_unknown = 0, long_short = 0;
};

// --long output: CSV text written with write(2) through one buffer.
class LongWriter {
 public:
  explicit LongWriter(const std::string& path) {
    if (path.empty() || path == "-") {
      fd_ = STDOUT_FILENO;
    } else {
      fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
      if (fd_ < 0) throw Error(path + ": cannot create: " + std::strerror(errno));
      owns_ = true;
    }
    buffer_.reserve(kSize + 512);
  }
  ~LongWriter() {
    try {
      flush();
    } catch (...) {
    }
    if (owns_) ::close(fd_);
  }
  void append(std::string_view text) {
    buffer_.append(text);
    if (buffer_.size() >= kSize) flush();
  }
  void flush() {
    std::size_t done = 0;
    while (done < buffer_.size()) {
      const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
      if (n < 0) {
        if (errno == EINTR) continue;
        if (errno == EPIPE) throw stream::BrokenPipe();
        throw Error(std::string("write error: ") + std::strerror(errno));
      }
      done += static_cast<std::size_t>(n);
    }
    buffer_.clear();
  }

 private:
  static constexpr std::size_t kSize = 1 << 16;
  int fd_ = -1;
  bool owns_ = false;
  std::string buffer_;
};

// "1700000000.001000": 6 fraction digits, 9 when the time is not a whole microsecond.
std::size_t format_time(const can::Frame& f, char* out) {
  if (!f.has_time) {
    std::memcpy(out, "nan", 3);
    return 3;
  }
  std::int64_t ns = f.time_ns;
  std::size_t n = 0;
  if (ns < 0) {
    out[n++] = '-';
    ns = -ns;
  }
  const bool micro = ns % 1000 == 0;
  std::int64_t sec = ns / 1000000000, frac = ns % 1000000000;
  char digits[24];
  int d = 0;
  do {
    digits[d++] = static_cast<char>('0' + sec % 10);
    sec /= 10;
  } while (sec > 0);
  while (d > 0) out[n++] = digits[--d];
  out[n++] = '.';
  int width = 9;
  if (micro) {
    frac /= 1000;
    width = 6;
  }
  for (int i = width - 1; i >= 0; --i) {
    out[n + static_cast<std::size_t>(i)] = static_cast<char>('0' + frac % 10);
    frac /= 10;
  }
  return n + static_cast<std::size_t>(width);
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("mo-can2csv", "Decode CAN captures (candump text or live SocketCAN) into a sample stream.");
  tool.add_inputs("candump text files, concatenated; - or none: stdin");
  std::string dbc_path, interface, map_path, sync_text, cycle_message, output = "-", output_format = "csv";
  std::string timestamps = "auto", bus;
  std::optional<double> period;
  int hold = 0;
  bool long_format = false, stats = false, line_buffered = false, strict = false;
  auto& app = tool.app();
  app.add_option("--dbc", dbc_path, "DBC file that decodes the frames")->type_name("FILE")->required();
  app.add_option("-i,--interface", interface, "read live from this SocketCAN interface (e.g. can0)")->type_name("IFACE");
  app.add_flag("--long", long_format, "one row per decoded signal: t,can_id,message,signal,raw,value");
  app.add_option("--map", map_path, "column map: lines 'q1 = Message.Signal' (default: signals named q1, dq1, i1, ...)")
      ->type_name("FILE");
  app.add_option("--sync", sync_text, "cycle boundary: frames with this hex can id (default 080, CANopen SYNC)")
      ->type_name("ID");
  app.add_option("--cycle-message", cycle_message, "cycle boundary: each arrival of this DBC message")->type_name("NAME");
  app.add_option("--period", period, "cycle boundary: fixed periods of this many seconds from the first frame")
      ->type_name("SECONDS");
  app.add_option("--hold", hold, "reuse a missing value for at most N cycles (default 0: write nan)")
      ->type_name("N")
      ->check(cli::whole_number());
  app.add_option("--timestamps", timestamps, "default-format timestamps: auto, absolute, delta (-t d) or zero (-t z)")
      ->type_name("MODE");
  app.add_option("--bus", bus, "keep only frames captured on this interface (candump any)")->type_name("IFACE");
  app.add_flag("--stats", stats, "print counters on stderr at the end (and on SIGUSR1)");
  app.add_option("-o,--output", output, "output file (default: stdout)")->type_name("FILE");
  app.add_option("--output-format", output_format, "csv or bin (default csv)")->type_name("FORMAT");
  app.add_flag("--line-buffered", line_buffered, "flush every row (automatic for live input)");
  app.add_flag("--strict", strict, "stop at the first bad line instead of skipping it");

  return tool.run(argc, argv, [&] {
    const int boundaries = (!sync_text.empty()) + (!cycle_message.empty()) + (period.has_value());
    if (boundaries > 1) throw cli::UsageError("--sync, --cycle-message and --period are alternatives: give one");
    if (!interface.empty() && !tool.inputs().empty()) throw cli::UsageError("-i reads a live interface: give no files");
    if (long_format && (boundaries > 0 || !map_path.empty() || hold > 0))
      throw cli::UsageError("--long writes every signal: --map, --sync, --cycle-message, --period and --hold do not apply");
    if (long_format && output_format != "csv") throw cli::UsageError("--long writes csv only");
    const stream::Encoding encoding = stream::parse_encoding(output_format);
    const can::TimestampMode mode = can::parse_timestamp_mode(timestamps);

    const can::Database db = can::Database::load(dbc_path);

    // Where frames come from: candump text files one after the other, or a socket.
    std::vector<std::string> inputs = tool.inputs();
    if (inputs.empty() && interface.empty()) inputs.push_back("-");
    std::size_t next_input = 0;
    std::unique_ptr<can::CandumpReader> text;
    std::unique_ptr<can::SocketCanReader> socket;
    Totals totals;
    bool live = false;
    std::function<void()> flush_output;

    std::unique_ptr<can::CycleAssembler> cycles;
    std::unique_ptr<stream::Writer> writer;
    std::unique_ptr<LongWriter> long_writer;

    auto print_stats = [&] {
      std::uint64_t bad_lines = totals.bad_lines, lost = totals.lost_frames, frames = totals.frames;
      if (text) {
        bad_lines += text->stats().bad_lines;
        lost += text->stats().lost_frames;
        frames += text->stats().frames;
      }
      if (socket) {
        lost += socket->stats().lost_frames;
        frames += socket->stats().frames;
      }
      std::string out;
      char line[512];
      if (cycles) {
        const can::CycleStats& s = cycles->stats();
        std::snprintf(line, sizeof line,
                      "mo-can2csv: stats: frames read %" PRIu64 ", decoded %" PRIu64 ", unknown ids %" PRIu64
                      ", sync %" PRIu64 ", error frames %" PRIu64 ", remote %" PRIu64 ", short %" PRIu64 "\n",
                      frames, s.decoded, s.unknown_ids, s.sync_frames, s.error_frames, s.remote_frames, s.short_frames);
        out += line;
        std::snprintf(line, sizeof line,
                      "mo-can2csv: stats: bad lines %" PRIu64 ", lost frames %" PRIu64 ", bad records %" PRIu64
                      ", frames before the first cycle %" PRIu64 "\n",
                      bad_lines, lost, totals.bad_records + (socket ? socket->stats().bad_records : 0), s.before_first_cycle);
        out += line;
        std::snprintf(line, sizeof line,
                      "mo-can2csv: stats: cycles complete %" PRIu64 ", incomplete %" PRIu64 ", values missing %" PRIu64
                      ", held %" PRIu64 ", repeated %" PRIu64 ", empty periods %" PRIu64 "\n",
                      s.complete_cycles, s.incomplete_cycles, s.missing_values, s.held_values, s.repeated_values,
                      s.empty_periods);
        out += line;
      } else {
        std::snprintf(line, sizeof line,
                      "mo-can2csv: stats: frames read %" PRIu64 ", decoded %" PRIu64 ", unknown ids %" PRIu64
                      ", short %" PRIu64 ", bad lines %" PRIu64 ", lost frames %" PRIu64 "\n",
                      frames, totals.long_decoded, totals.long_unknown, totals.long_short, bad_lines, lost);
        out += line;
      }
      std::fwrite(out.data(), 1, out.size(), stderr);
      std::fflush(stderr);
    };
    auto service_signals = [&] {
      if (g_stats_requested) {
        g_stats_requested = 0;
        print_stats();
      }
    };
    install(SIGUSR1, on_usr1);

    can::CandumpOptions text_options;
    text_options.strict = strict;
    text_options.timestamps = mode;
    text_options.interface = bus;
    auto open_next_text = [&]() -> bool {
      if (text) {
        totals.bad_lines += text->stats().bad_lines;
        totals.lost_frames += text->stats().lost_frames;
        totals.frames += text->stats().frames;
        text.reset();
      }
      if (next_input >= inputs.size()) return false;
      text = can::CandumpReader::open(inputs[next_input++], text_options);
      live = live || text->live();
      text->on_interrupt(service_signals);
      if (flush_output) text->before_read(flush_output);
      return true;
    };

    if (!interface.empty()) {
      socket = std::make_unique<can::SocketCanReader>(can::open_can_socket(interface), true, interface);
      live = true;
      install(SIGINT, on_stop);
      install(SIGTERM, on_stop);
    } else {
      open_next_text();
    }

    bool warned_untimed = false;
    // The next frame from whichever source; false at the end (or on SIGINT/SIGTERM when live).
    auto next_frame = [&](can::Frame& frame) -> bool {
      for (;;) {
        if (g_stop_requested) return false;
        if (socket) {
          const auto status = socket->next(frame);
          if (status == can::SocketCanReader::Status::frame) return true;
          if (status == can::SocketCanReader::Status::end) return false;
          service_signals();
          continue;
        }
        if (text->next(frame)) {
          service_signals();
          return true;
        }
        if (!open_next_text()) return false;
      }
    };

    can::Frame frame;
    if (long_format) {
      long_writer = std::make_unique<LongWriter>(output);
      LongWriter* w = long_writer.get();
      flush_output = [w] { w->flush(); };
      if (text) text->before_read(flush_output);
      w->append("t,can_id,message,signal,raw,value\n");
      std::vector<can::SignalValue> values;
      std::size_t most = 0;
      for (const auto& m : db.messages()) most = std::max(most, m.signals.size());
      values.resize(most);
      std::string row;
      while (next_frame(frame)) {
        if (frame.error || frame.rtr) continue;
        const can::Message* m = db.find(frame.key());
        if (m == nullptr) {
          ++totals.long_unknown;
          continue;
        }
        ++totals.long_decoded;
        bool truncated = false;
        const std::size_t n = can::decode(*m, frame, values.data(), &truncated);
        if (truncated) ++totals.long_short;
        char t[48], id[8], raw[48], value[48];
        const std::size_t t_len = format_time(frame, t);
        const std::size_t id_len = can::format_id(frame, id);
        for (std::size_t k = 0; k < n; ++k) {
          const can::Signal& s = m->signals[values[k].index];
          row.assign(t, t_len);
          row += ',';
          row.append(id, id_len);
          row += ',';
          row += m->name;
          row += ',';
          row += s.name;
          row += ',';
          row.append(raw, can::format_raw(s, values[k].bits, raw));
          row += ',';
          row.append(value, can::format_physical(s, values[k].bits, value));
          row += '\n';
          w->append(row);
        }
        if (live) w->flush();
      }
      w->flush();
    } else {
      std::vector<can::ColumnSource> sources =
          map_path.empty() ? can::columns_from_signal_names(db) : can::read_column_map(map_path, db);
      if (sources.empty())
        throw Error(dbc_path + ": no signal is named like a stream column (q1, dq1, i1, tau_m1, ...); give --map FILE");
      can::CycleOptions options;
      options.hold = hold;
      if (period) {
        options.boundary = can::CycleBoundary::period;
        options.period = *period;
      } else if (!cycle_message.empty()) {
        const can::Message* m = db.find_name(cycle_message);
        if (m == nullptr) throw Error(dbc_path + ": no message '" + cycle_message + "' (--cycle-message)");
        options.boundary = can::CycleBoundary::message;
        options.message_key = m->key;
      } else if (!sync_text.empty()) {
        options.sync_key = parse_can_id(sync_text);
      }
      std::string why;
      if (!options.IsValid(&why)) throw cli::UsageError(why);
      cycles = std::make_unique<can::CycleAssembler>(db, std::move(sources), options);

      stream::WriterOptions writer_options;
      writer_options.encoding = encoding;
      writer_options.line_buffered = line_buffered || live;
      writer = stream::Writer::open(output, writer_options);
      writer->comment(tool.provenance());
      writer->header(cycles->columns());
      stream::Writer* w = writer.get();
      flush_output = [w] { w->flush(); };
      if (text && w->interactive()) text->before_read(flush_output);
      while (next_frame(frame)) {
        if (!frame.has_time && !warned_untimed) {
          warned_untimed = true;
          warn((text ? text->where() : interface) + ": capture without timestamps (candump without -t): t is nan");
        }
        if (cycles->add(frame)) writer->row(cycles->row());
      }
      if (cycles->finish()) writer->row(cycles->row());
      writer->close();
    }

    if (text) open_next_text();  // fold the last reader's counters into the totals
    if (socket) {
      totals.lost_frames += socket->stats().lost_frames;
      totals.frames += socket->stats().frames;
      totals.bad_records += socket->stats().bad_records;
      socket.reset();
    }
    if (stats) print_stats();
    if (totals.bad_lines > 0) {
      warn(std::to_string(totals.bad_lines) + " bad line" + (totals.bad_lines == 1 ? "" : "s") + " skipped");
      return cli::kFailure;
    }
    return cli::kSuccess;
  });
}
