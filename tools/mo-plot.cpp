// mo-plot: residuals against thresholds, events and true contacts, to PNG or SVG via gnuplot.
#include <cmath>
#include <cstdio>
#include <optional>

#include "momentum/cli/tool.hpp"
#include "momentum/detect/plot.hpp"
#include "momentum/detect/plot_views.hpp"
#include "momentum/eval/score.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/error.hpp"

using namespace momentum;

int main(int argc, char** argv) {
  cli::Tool tool("mo-plot", "Residuals against thresholds, with events and true contacts, to PNG or SVG.");
  tool.app().footer("\nExample:\n  mo-plot -p arm.json --events events.csv -o plot.png observed.csv\n\nMore: man mo-plot");
  tool.add_inputs("input stream with r<j> and/or mu<j> (- or none: stdin)");
  tool.add_profile(/*required=*/false);
  std::string output, format, events_path, truth_path, signals_option;
  bool script_only = false;
  detect::PlotOptions options;
  auto& app = tool.app();
  app.add_option("-o,--output", output, "image file to write (.png or .svg)")->type_name("FILE")->required();
  app.add_option("--format", format, "png or svg (default: from the file name, else png)")
      ->check(CLI::IsMember({"png", "svg"}));
  app.add_option("--events", events_path, "events of mo-detect to mark")->type_name("FILE");
  app.add_option("--truth", truth_path, "true contacts (mo-sim --truth) to shade")->type_name("FILE");
  app.add_option("--signal", signals_option, "mu, r or r,mu (default: those the stream has, r first)")
      ->type_name("LIST");
  app.add_option("--from", options.from, "start of the time window, s")->type_name("S");
  app.add_option("--to", options.to, "end of the time window, s")->type_name("S");
  app.add_option("--title", options.title, "title above the panels")->type_name("TEXT");
  app.add_option("--width", options.width, "image width in pixels (1400)")->type_name("PX");
  app.add_option("--panel-height", options.panel_height, "height of one joint's row in pixels (220)")->type_name("PX");
  app.add_option("--max-points", options.max_points, "time buckets per panel, min and max of each (2000)")
      ->type_name("N");
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
    detect::run_gnuplot(script);
    return cli::kSuccess;
  };
  return tool.run(argc, argv, [&] {
    if (tool.inputs().size() > 1) throw cli::UsageError("one input stream at a time");
    if (format.empty()) {
      const bool svg = output.size() > 4 && output.compare(output.size() - 4, 4, ".svg") == 0;
      format = svg ? "svg" : "png";
    }
    options.format = format;
    std::string why;
    if (!options.IsValid(&why)) throw cli::UsageError(why);
    if (view_name == "force") {
      // Events and truth only: mo-eval's matching, then estimated against true peak force.
      if (events_path.empty() || truth_path.empty() || !tool.inputs().empty())
        throw cli::UsageError("--view force takes --events and --truth, and no stream");
      const auto detections = eval::read_detections(events_path, tool.strict());
      std::vector<detect::ForcePoint> points;
      for (const auto& o : eval::score(eval::read_truth(truth_path), detections, {}).outcomes)
        if (o.detection >= 0 && std::isfinite(o.force_error))
          points.push_back({o.contact.peak_force, detections[static_cast<std::size_t>(o.detection)].peak_force,
                            o.contact.link});
      return emit(detect::force_view_script(points, output, options));
    }

    auto in = tool.open_input(tool.inputs().empty() ? "-" : tool.inputs().front());
    const std::size_t it = in->require("t");
    std::vector<detect::Signal> signals;
    try {
      signals = detect::parse_signal_list(signals_option);
    } catch (const Error& e) {
      throw cli::UsageError(std::string("--signal: ") + e.what());
    }
    if (signals.empty()) {
      if (in->find("r1")) signals.push_back(detect::Signal::r);
      if (in->find("mu1")) signals.push_back(detect::Signal::mu);
      if (signals.empty()) throw Error(in->name() + ": no r1 or mu1 column (run mo-observe first)");
    }
    const std::size_t n = stream::count_joint_columns(in->columns(), detect::signal_name(signals.front()));
    if (n == 0) throw Error(in->name() + ": missing column '" + std::string(detect::signal_name(signals.front())) + "1'");
    std::vector<std::vector<std::size_t>> columns;
    for (auto s : signals)
      columns.push_back(stream::column_indices(in->columns(), stream::joint_columns(detect::signal_name(s), n), in->name()));
    std::vector<std::size_t> idq;
    if (stream::count_joint_columns(in->columns(), "dq") >= n)
      idq = stream::column_indices(in->columns(), stream::joint_columns("dq", n), in->name());

    std::vector<std::optional<detect::Thresholds>> thresholds(signals.size());
    if (!tool.profile().empty()) {
      const auto profile = model::load_profile(tool.profile());
      for (std::size_t s = 0; s < signals.size(); ++s) {
        thresholds[s] = detect::thresholds_from_profile(profile.document, signals[s], tool.profile());
        if (!thresholds[s])
          warn(tool.profile() + ": no thresholds for " + std::string(detect::signal_name(signals[s])) + ": none drawn");
      }
    }
    std::vector<detect::Event> events;
    if (!events_path.empty()) events = detect::read_events(events_path);
    std::vector<detect::TruthContact> truth;
    if (!truth_path.empty()) truth = detect::read_truth(truth_path);

    const detect::PlotView view = detect::parse_plot_view(view_name);
    if (view != detect::PlotView::time) {
      // One signal: the one asked for, else mu when the stream has it (what mo-detect uses).
      std::size_t pick = 0;
      if (signals_option.empty())
        for (std::size_t s = 0; s < signals.size(); ++s)
          if (signals[s] == detect::Signal::mu) pick = s;
      detect::ViewData data(view, signals[pick], thresholds[pick], n, !idq.empty(), detect::event_spans(events));
      std::vector<double> x(n), dq(n);
      double t_prev = -INFINITY;
      while (const double* row = in->next()) {
        const double t = row[it];
        if (!(t >= t_prev)) {
          in->reject_row("time goes backwards");
          continue;
        }
        t_prev = t;
        if (t < options.from || t > options.to) continue;
        for (std::size_t j = 0; j < n; ++j) x[j] = row[columns[pick][j]];
        for (std::size_t j = 0; j < idq.size(); ++j) dq[j] = row[idq[j]];
        data.add(t, x.data(), idq.empty() ? nullptr : dq.data());
      }
      if (data.rows() == 0) throw Error(in->name() + ": no rows to plot");
      return emit(data.gnuplot_script(truth, output, options));
    }
    detect::PlotData data(signals, thresholds, n, !idq.empty(), options);
    std::vector<std::vector<double>> x(signals.size(), std::vector<double>(n));
    std::vector<const double*> rows(signals.size());
    std::vector<double> dq(n);
    double t_prev = -INFINITY, shift = 0, step = 0;
    while (const double* row = in->next()) {
      if (in->time_mark() == stream::TimeMark::clock_step) {
        // The stream's time policy kept this row as the start of a new time line: the time
        // axis goes on from the last row instead of drawing over earlier rows.
        shift = t_prev + step - row[it];
        warn(in->where() + ": the clock stepped back; the plot shifts the rows from here by " +
             short_number(shift) + " s");
      }
      const double t = row[it] + shift;
      if (!(t >= t_prev)) {
        in->reject_row("time goes backwards");
        continue;
      }
      if (std::isfinite(t_prev)) step = t - t_prev;
      t_prev = t;
      for (std::size_t s = 0; s < signals.size(); ++s) {
        for (std::size_t j = 0; j < n; ++j) x[s][j] = row[columns[s][j]];
        rows[s] = x[s].data();
      }
      for (std::size_t j = 0; j < idq.size(); ++j) dq[j] = row[idq[j]];
      data.add(t, rows.data(), idq.empty() ? nullptr : dq.data());
    }
    if (data.rows() == 0) throw Error(in->name() + ": no rows to plot" + (std::isfinite(options.from) || std::isfinite(options.to) ? " in the time window" : ""));
    return emit(detect::gnuplot_script(data, events, truth, output, options));
  });
}
