// mo-can2csv: candump text (any of its formats) or a live SocketCAN interface, decoded with a
// DBC file, into a sample stream with one row per control cycle (or, with --long, one row per
// decoded signal).
#include <signal.h>

#include <cinttypes>
#include <csignal>
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "momentum/can/candump.hpp"
#include "momentum/can/codec.hpp"
#include "momentum/can/cycle.hpp"
#include "momentum/can/dbc.hpp"
#include "momentum/can/signal_rows.hpp"
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

// Totals over every input, for --stats.
struct Totals {
  std::uint64_t frames = 0, bad_lines = 0, lost_frames = 0, bad_records = 0, filtered = 0;
};

// Thrown out of a read when SIGINT or SIGTERM arrived: the capture ends like at end of input.
struct Stopped {};

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("mo-can2csv", "Decode CAN captures (candump text or live SocketCAN) into a sample stream.");
  tool.app().footer("\nExample:\n  candump -L can0 | mo-can2csv --dbc arm.dbc > arm.csv\n\nMore: man mo-can2csv");
  tool.add_inputs("candump text files, concatenated; - or none: stdin");
  std::string dbc_path, interface, map_path, sync_text, cycle_message, output = "-", output_format = "csv";
  std::string timestamps = "auto", bus;
  std::optional<double> period;
  int hold = 0;
  bool long_format = false, stats = false, line_buffered = false;
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
  std::string stats_format = "text";
  app.add_option("--stats-format", stats_format, "--stats as text (default) or jsonl: one JSON object per report")
      ->check(CLI::IsMember({"text", "jsonl"}));
  app.add_option("-o,--output", output, "output file (default: stdout)")->type_name("FILE");
  app.add_option("--output-format", output_format, "csv or bin (default csv)")->type_name("FORMAT");
  app.add_flag("--line-buffered", line_buffered, "flush every row (automatic for live input)");
  tool.add_strict();

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
    std::unique_ptr<can::SignalRowWriter> long_writer;

    auto print_stats = [&] {
      std::uint64_t bad_lines = totals.bad_lines, lost = totals.lost_frames, frames = totals.frames;
      std::uint64_t filtered = totals.filtered;
      if (text) {
        bad_lines += text->stats().bad_lines;
        lost += text->stats().lost_frames;
        frames += text->stats().frames;
        filtered += text->stats().filtered;
      }
      if (socket) {
        lost += socket->stats().lost_frames;
        frames += socket->stats().frames;
      }
      if (stats_format == "jsonl") {
        nlohmann::json line = {{"frames_read", frames}, {"bad_lines", bad_lines}, {"lost_frames", lost},
                               {"filtered", filtered}};
        if (cycles) {
          const can::CycleStats& s = cycles->stats();
          line.update({{"decoded", s.decoded}, {"unknown_ids", s.unknown_ids}, {"sync", s.sync_frames},
                       {"error_frames", s.error_frames}, {"remote", s.remote_frames}, {"short", s.short_frames},
                       {"bad_records", totals.bad_records + (socket ? socket->stats().bad_records : 0)},
                       {"before_first_cycle", s.before_first_cycle}, {"cycles_complete", s.complete_cycles},
                       {"cycles_incomplete", s.incomplete_cycles}, {"values_missing", s.missing_values},
                       {"values_held", s.held_values}, {"values_repeated", s.repeated_values},
                       {"empty_periods", s.empty_periods}});
        } else if (long_writer) {
          const can::SignalRowCounts& c = long_writer->counts();
          line.update({{"decoded", c.decoded}, {"unknown_ids", c.unknown_ids}, {"short", c.short_frames}});
        }
        const std::string text = line.dump() + "\n";
        std::fwrite(text.data(), 1, text.size(), stderr);
        std::fflush(stderr);
        return;
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
                      ", frames before the first cycle %" PRIu64 ", filtered (--bus) %" PRIu64 "\n",
                      bad_lines, lost, totals.bad_records + (socket ? socket->stats().bad_records : 0), s.before_first_cycle,
                      filtered);
        out += line;
        std::snprintf(line, sizeof line,
                      "mo-can2csv: stats: cycles complete %" PRIu64 ", incomplete %" PRIu64 ", values missing %" PRIu64
                      ", held %" PRIu64 ", repeated %" PRIu64 ", empty periods %" PRIu64 "\n",
                      s.complete_cycles, s.incomplete_cycles, s.missing_values, s.held_values, s.repeated_values,
                      s.empty_periods);
        out += line;
      } else if (long_writer) {
        const can::SignalRowCounts& c = long_writer->counts();
        std::snprintf(line, sizeof line,
                      "mo-can2csv: stats: frames read %" PRIu64 ", decoded %" PRIu64 ", unknown ids %" PRIu64
                      ", short %" PRIu64 ", bad lines %" PRIu64 ", lost frames %" PRIu64 ", filtered (--bus) %" PRIu64
                      "\n",
                      frames, c.decoded, c.unknown_ids, c.short_frames, bad_lines, lost, filtered);
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
      if (g_stop_requested) throw Stopped{};
    };
    install(SIGUSR1, on_usr1);
    // Ctrl-C on `candump -L can0 | mo-can2csv` reaches both: end like at end of input, with
    // the last cycle written and --stats printed.
    install(SIGINT, on_stop);
    install(SIGTERM, on_stop);

    can::CandumpOptions text_options;
    text_options.strict = tool.strict();
    text_options.timestamps = mode;
    text_options.interface = bus;
    auto open_next_text = [&]() -> bool {
      if (text) {
        totals.bad_lines += text->stats().bad_lines;
        totals.lost_frames += text->stats().lost_frames;
        totals.frames += text->stats().frames;
        totals.filtered += text->stats().filtered;
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
    } else {
      open_next_text();
    }

    bool warned_untimed = false;
    std::uint64_t rows_written = 0;
    // The next frame from whichever source; false at the end or on SIGINT/SIGTERM.
    auto next_frame = [&](can::Frame& frame) -> bool {
      try {
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
      } catch (const Stopped&) {
        return false;
      }
    };

    can::Frame frame;
    if (long_format) {
      long_writer = std::make_unique<can::SignalRowWriter>(db, output);
      can::SignalRowWriter* w = long_writer.get();
      flush_output = [w] { w->flush(); };
      if (text) text->before_read(flush_output);
      while (next_frame(frame)) {
        w->write(frame);
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
        try {
          options.sync_key = can::parse_can_id(sync_text);
        } catch (const Error& e) {
          throw cli::UsageError(std::string("--sync: ") + e.what());
        }
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
        if (cycles->add(frame)) writer->row(cycles->row()), ++rows_written;
      }
      if (cycles->finish()) writer->row(cycles->row()), ++rows_written;
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
    if (!long_format && rows_written == 0)
      throw Error("no rows: " + std::to_string(totals.frames) + " frame" + (totals.frames == 1 ? "" : "s") +
                  " read but no complete cycle (is the cycle's SYNC frame in the capture?)");
    return cli::kSuccess;
  });
}
