// mo-can2csv: candump text (any of its formats) or a live SocketCAN interface, decoded with a
// DBC file, into a sample stream with one row per control cycle (or, with --long, one row per
// decoded signal). The work is drivers::Converter's; this file is the command line.
#include <signal.h>

#include <climits>
#include <csignal>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include "momentum/drivers/can_convert.hpp"
#include "momentum/cli/tool.hpp"
#include "momentum/cli/whole_number.hpp"
#include "momentum/stream/format.hpp"

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

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("mo-can2csv", "Decode CAN captures (candump text or live SocketCAN) into a sample stream.");
  tool.app().footer("\nExample:\n  candump -L can0 | mo-can2csv --dbc arm.dbc > arm.csv\n\nMore: man mo-can2csv");
  tool.add_inputs("candump text files, concatenated; - or none: stdin");
  drivers::ConvertOptions o;
  std::string output_format = "csv", timestamps = "auto", stats_format = "text";
  bool stats = false;
  auto& app = tool.app();
  app.add_option("--dbc", o.dbc, "DBC file that decodes the frames")->type_name("FILE")->required();
  app.add_option("-i,--interface", o.interface, "read live from this SocketCAN interface (e.g. can0)")->type_name("IFACE");
  app.add_flag("--long", o.long_format, "one row per decoded signal: t,can_id,message,signal,raw,value");
  app.add_option("--map", o.map, "column map: lines 'q1 = Message.Signal' (default: signals named q1, dq1, i1, ...)")
      ->type_name("FILE");
  app.add_option("--sync", o.sync, "cycle boundary: frames with this hex can id (default 080, CANopen SYNC)")
      ->type_name("ID");
  app.add_option("--cycle-message", o.cycle_message, "cycle boundary: each arrival of this DBC message")->type_name("NAME");
  app.add_option("--period", o.period, "cycle boundary: fixed periods of this many seconds from the first frame")
      ->type_name("SECONDS");
  app.add_option("--hold", o.hold, "reuse a missing value for at most N cycles (default 0: write nan)")
      ->type_name("N")
      ->check(cli::whole_number_in(0, INT_MAX));
  app.add_option("--timestamps", timestamps, "default-format timestamps: auto, absolute, delta (-t d) or zero (-t z)")
      ->type_name("MODE");
  app.add_option("--bus", o.text.interface, "keep only frames captured on this interface (candump any)")->type_name("IFACE");
  app.add_flag("--stats", stats, "print counters on stderr at the end (and on SIGUSR1)");
  app.add_option("--stats-format", stats_format, "--stats as text (default) or jsonl: one JSON object per report")
      ->check(CLI::IsMember({"text", "jsonl"}));
  app.add_option("-o,--output", o.output, "output file (default: stdout)")->type_name("FILE");
  app.add_option("--output-format", output_format, "csv or bin (default csv)")->type_name("FORMAT");
  app.add_flag("--line-buffered", o.line_buffered, "flush every row (automatic for live input)");
  tool.add_strict();

  return tool.run(argc, argv, [&] {
    o.inputs = tool.inputs();
    o.text.strict = tool.strict();
    o.encoding = stream::parse_encoding(output_format);
    o.text.timestamps = can::parse_timestamp_mode(timestamps);
    o.provenance = tool.provenance();
    std::string why;
    if (!o.IsValid(&why)) throw cli::UsageError(why);

    install(SIGUSR1, on_usr1);
    // Ctrl-C on `candump -L can0 | mo-can2csv` reaches both: end like at end of input, with
    // the last cycle written and --stats printed.
    install(SIGINT, on_stop);
    install(SIGTERM, on_stop);
    drivers::Converter converter(o);
    auto print_stats = [&] {
      const drivers::ConvertSummary s = converter.summary();
      const std::string text = stats_format == "jsonl" ? drivers::summary_json_line(s)
                                                      : drivers::format_summary(s, "mo-can2csv: stats: ");
      std::fwrite(text.data(), 1, text.size(), stderr);
      std::fflush(stderr);
    };
    converter.set_keep_going([&] {
      if (g_stats_requested) {
        g_stats_requested = 0;
        print_stats();
      }
      return !g_stop_requested;
    });
    converter.run();
    if (stats) print_stats();
    converter.require_rows();
    return cli::kSuccess;
  });
}
