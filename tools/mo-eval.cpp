// mo-eval: score collision events against mo-sim's ground truth.
#include <cstdio>
#include <optional>
#include <string>

#include "momentum/cli/tool.hpp"
#include "momentum/eval/score.hpp"

using namespace momentum;

int main(int argc, char** argv) {
  cli::Tool tool("mo-eval", "Score collision events against ground truth: detections, misses, false alarms, delays, isolation.");
  tool.app().footer("\nExample:\n  mo-eval --truth truth.csv events.csv\n\nMore: man mo-eval");
  std::string truth_path, events_path = "-";
  eval::ScoreOptions options;
  std::optional<double> duration;
  bool json = false, list = false;
  tool.app().add_option("events", events_path, "event file (mo-detect's, or CSV with t_detect,link); - or none: stdin")->type_name("FILE");
  tool.app().add_option("--truth", truth_path, "ground truth from mo-sim --truth")->type_name("FILE")->required();
  tool.app().add_option("--window", options.window, "seconds after onset within which a detection counts")->type_name("S")->capture_default_str();
  tool.app().add_option("--min-torque", options.min_torque, "count apart the contacts below this joint torque on every joint")->type_name("NM")->capture_default_str();
  tool.app().add_option("--duration", duration, "length of the run (default: the truth file's)")->type_name("S");
  tool.app().add_flag("--json", json, "write the score as JSON");
  tool.app().add_flag("--list", list, "list every contact and false alarm");
  tool.add_strict();

  return tool.run(argc, argv, [&] {
    options.duration = duration;
    std::string why;
    if (!options.IsValid(&why)) throw cli::UsageError(why);
    const eval::Truth truth = eval::read_truth(truth_path);
    const auto detections = eval::read_detections(events_path, tool.strict());
    const eval::Score score = eval::score(truth, detections, options);
    const std::string text = json ? eval::to_json(score).dump(2) + "\n" : eval::format_table(score, list);
    std::fwrite(text.data(), 1, text.size(), stdout);
    return cli::kSuccess;
  });
}
