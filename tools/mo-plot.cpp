// mo-plot: residuals against thresholds, events and true contacts, to PNG, SVG or PDF via gnuplot.
#include <cstdio>
#include <string>
#include <vector>

#include "momentum/cli/tool.hpp"
#include "momentum/cli/whole_number.hpp"
#include "momentum/core/error.hpp"
#include "momentum/drivers/plot_stream.hpp"
#include "momentum/eval/truth.hpp"

using namespace momentum;

int main(int argc, char** argv) {
  cli::Tool tool("mo-plot", "Residuals against thresholds, with events and true contacts, to PNG, SVG or PDF.");
  tool.app().footer("\nExample:\n  mo-plot -p arm.json --events events.csv -o plot.png observed.csv\n\nMore: man mo-plot");
  tool.add_inputs("input stream with r<j> and/or mu<j> (- or none: stdin)");
  tool.add_profile(/*required=*/false);
  std::string output, format, events_path, truth_path, signals_option;
  bool script_only = false;
  plot::PlotOptions options;
  auto& app = tool.app();
  app.add_option("-o,--output", output, "image file to write (.png, .svg or .pdf)")->type_name("FILE")->required();
  app.add_option("--format", format, "png, svg or pdf (default: from the file name, else png)")
      ->check(CLI::IsMember({"png", "svg", "pdf"}));
  app.add_option("--events", events_path, "events of mo-detect to mark")->type_name("FILE");
  app.add_option("--truth", truth_path, "true contacts (mo-sim --truth) to shade")->type_name("FILE");
  app.add_option("--signal", signals_option, "mu, r or r,mu (default: those the stream has, r first)")
      ->type_name("LIST");
  app.add_option("--from", options.from, "start of the time window, s")->type_name("S");
  app.add_option("--to", options.to, "end of the time window, s")->type_name("S");
  app.add_option("--title", options.title, "title above the panels")->type_name("TEXT");
  app.add_option("--width", options.width, "image width in pixels, 200 to 20000 (1400)")
      ->type_name("PX")
      ->check(cli::whole_number_in(plot::kMinPlotWidth, plot::kMaxPlotWidth));
  app.add_option("--panel-height", options.panel_height, "height of one joint's row in pixels, 80 to 5000 (220)")
      ->type_name("PX")
      ->check(cli::whole_number_in(plot::kMinPanelHeight, plot::kMaxPanelHeight));
  app.add_option("--max-points", options.max_points, "time buckets per panel, min and max of each, 10 to 100000 (2000)")
      ->type_name("N")
      ->check(cli::whole_number_in(plot::kMinPlotPoints, plot::kMaxPlotPoints));
  std::string view_name = "time";
  app.add_option("--view", view_name, "time (default), events, mu-dq, histogram or force (no stream)")
      ->check(CLI::IsMember({"time", "events", "mu-dq", "histogram", "force"}));
  app.add_flag("--script", script_only, "print the gnuplot script (which draws -o) instead of running it");
  tool.add_strict();

  // The script, printed (--script) or drawn by gnuplot.
  auto emit = [&](const std::string& script) {
    if (script_only) {
      if (std::fwrite(script.data(), 1, script.size(), stdout) != script.size()) throw Error("cannot write the script");
      return cli::kSuccess;
    }
    plot::run_gnuplot(script);
    return cli::kSuccess;
  };
  return tool.run(argc, argv, [&] {
    if (tool.inputs().size() > 1) throw cli::UsageError("one input stream at a time");
    try {
      plot::check_gnuplot_text(output, "the output name");
      options.format = plot::plot_format(output, format);
    } catch (const Error& e) {
      throw cli::UsageError(e.what());
    }
    std::string why;
    if (!options.IsValid(&why)) throw cli::UsageError(why);
    if (view_name == "force") {
      if (events_path.empty() || !tool.inputs().empty())
        throw cli::UsageError("--view force takes --events (and --truth), and no stream");
      return emit(drivers::force_plot_script(events_path, truth_path, tool.strict(), output, options));
    }

    std::vector<detect::Signal> signals;
    try {
      signals = detect::parse_signal_list(signals_option);
    } catch (const Error& e) {
      throw cli::UsageError(std::string("--signal: ") + e.what());
    }
    auto in = tool.open_input(tool.inputs().empty() ? "-" : tool.inputs().front());
    const drivers::PlotColumns columns = drivers::plot_columns(*in, signals);
    const auto thresholds = drivers::plot_thresholds(tool.profile(), columns.signals, &options.friction_band);
    std::vector<detect::Event> events;
    if (!events_path.empty()) events = detect::read_events(events_path);
    std::vector<eval::TruthContact> truth;
    if (!truth_path.empty()) truth = eval::read_truth(truth_path).contacts;
    const plot::PlotView view = plot::parse_plot_view(view_name);
    return emit(drivers::stream_plot_script(*in, columns, thresholds, view, events, truth, output, options));
  });
}
