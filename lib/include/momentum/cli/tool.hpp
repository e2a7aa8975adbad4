#pragma once
// The command-line layer every tool shares: standard options, --help/--version, error
// formatting and exit statuses. A tool is one thin main:
//
//   int main(int argc, char** argv) {
//     momentum::cli::Tool tool("mo-cat", "convert and inspect sample streams");
//     tool.add_inputs();
//     tool.add_stream_output();
//     return tool.run(argc, argv, [&] { ...; return momentum::cli::kSuccess; });
//   }
//
// Errors read `mo-TOOL: error: file:line: message`; warnings `mo-TOOL: warning: ...`.

#include <CLI/CLI.hpp>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "momentum/core/file.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/writer.hpp"

namespace momentum::cli {

// Exit statuses. mo-detect follows grep instead: 0 no collision, 1 collision, 2 error.
inline constexpr int kSuccess = 0;
inline constexpr int kFailure = 1;
inline constexpr int kUsage = 2;

// A usage error found after parsing (conflicting options, a bad list). Exit status 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Tool {
 public:
  Tool(std::string name, std::string summary);

  CLI::App& app() { return app_; }
  const std::string& name() const { return name_; }

  // Positional input files; none or "-" means stdin.
  void add_inputs(const std::string& description = "input streams (- or none: stdin)");
  // Positional input streams (add_inputs), and the options every tool that reads sample
  // streams shares, which open_input applies: --separator (CSV: auto, comma, semicolon, tab,
  // space), --rename OLD=NEW,... (repeatable; ranges, _ to drop, :unit and *factor; see
  // stream::parse_renames), --preset NAME|FILE (a vendor's column mapping; a --rename of the
  // same column wins over the preset's) and --topic NAME (the sensor_msgs/msg/JointState topic
  // of a ROS 2 bag: stream::ReaderOptions::topic).
  void add_stream_inputs(const std::string& description = "input streams (- or none: stdin)");
  // The joints of the profile's chain, root to tip: open_input matches a bag's joints to them
  // by name (stream::ReaderOptions::joint_names). Tools with a profile call it before opening
  // their inputs.
  void set_chain_joints(std::vector<std::string> names) { chain_joints_ = std::move(names); }
  // -o FILE, --output-format csv|bin, --line-buffered, --strict: for tools that read and
  // write sample streams. "-o -" is standard output.
  void add_stream_output();
  // --strict: stop at the first bad row (line, record) instead of skipping it. For tools that
  // read without writing a stream (add_stream_output adds it too).
  void add_strict();

  // The rows policy every tool shares (mo-log(5)). Rows skipped anywhere in the library
  // (momentum::warn_row) are counted by kind; the first kShownPerKind of each kind are shown,
  // and at the end one line sums them up ("12 bad rows skipped: 10 bad number, 2 time out of
  // order") with a count of those not shown. A body that returns kSuccess after skipped rows
  // exits with `status` (default kFailure); nullopt keeps the body's status (mo-detect, whose
  // 1 means a collision).
  void set_skipped_rows_status(std::optional<int> status) { skipped_rows_status_ = status; }
  // When the tool opened inputs (open_input) and they held no row at all: by default an error
  // (`name: error: no rows in INPUT`, exit 1). With `warning`, a warning and exit `status`
  // instead (mo-detect: 3). Off with `check` false (a tool that may read nothing).
  void set_no_rows_policy(bool check, int status = kFailure, bool warning = false) {
    check_no_rows_ = check;
    no_rows_status_ = status;
    no_rows_warning_ = warning;
  }
  static constexpr std::uint64_t kShownPerKind = 5;
  // The exit status of a runtime error (momentum::Error, a failed write to standard output):
  // kFailure, or mo-detect's 2 (its 1 means a collision).
  void set_error_status(int status) { error_status_ = status; }
  // -p FILE, the robot profile.
  void add_profile(bool required = true);
  // --payload NAME: which of the profile's payloads the dynamics include ("none": none; not
  // given: the profile's "active_payload"). For tools whose dynamics use the profile; apply
  // it with model::select_payload(profile, tool.payload()).
  void add_payload();
  // --seed N (default 1): every random process of the tool derives from it.
  void add_seed();

  // Parses argv and runs `body`. Handles --help (stdout, 0), --version, usage errors (one
  // line on stderr, 2), momentum::Error (`name: error: what`, 1), a closed output pipe (quiet
  // 0), a failed write to standard output (a full disk: `name: error: standard output: why`,
  // 1, also after --help), and routes momentum::warn to stderr (silenced by --quiet). Returns
  // the exit status.
  int run(int argc, char** argv, const std::function<int()>& body);

  // Options after parsing.
  const std::vector<std::string>& inputs() const { return inputs_; }
  const std::string& output() const { return output_; }
  const std::string& profile() const { return profile_; }
  const std::string& payload() const { return payload_; }  // empty when not given
  std::uint64_t seed() const { return seed_; }
  bool quiet() const { return quiet_; }
  bool strict() const { return strict_; }

  // One provenance comment for output streams: tool name, version and the arguments.
  std::string provenance() const;

  // Opens one input with the tool's --strict setting (and --separator, --rename, --preset,
  // --topic and the chain's joints when the tool has them and `options` sets none of its own);
  // its rows count for the no-rows policy.
  std::unique_ptr<stream::Reader> open_input(const std::string& path, stream::ReaderOptions options = {});
  // Rows the inputs opened by open_input have returned so far, and rows skipped (every kind).
  std::uint64_t rows_returned() const { return rows_returned_; }
  std::uint64_t rows_skipped() const { return rows_skipped_; }
  // Opens the -o output in the encoding --output-format names (default: `like`'s), copies
  // `like`'s leading comments and adds the provenance line. Flushing: every row with
  // --line-buffered; otherwise whenever `like` is about to wait for input, so that a live
  // pipeline sees each row at once while file input stays buffered.
  std::unique_ptr<stream::Writer> open_output(stream::Reader& like) const;

  // True when progress may be drawn: stderr is a terminal and --quiet is off.
  bool show_progress() const;

 private:
  int run_body(int argc, char** argv, const std::function<int()>& body);
  std::string name_;
  CLI::App app_;
  std::vector<std::string> args_;
  std::vector<std::string> inputs_;
  std::string output_ = "-";
  std::string output_format_;
  std::string profile_;
  std::string payload_;
  std::string topic_;
  std::vector<std::string> chain_joints_;
  std::uint64_t seed_ = 1;
  bool quiet_ = false;
  bool strict_ = false;
  bool line_buffered_ = false;
  bool strict_added_ = false;
  // --separator, --rename, --preset (add_stream_inputs), and the mappings they make.
  std::string separator_option_;
  std::vector<std::string> rename_options_;
  std::string preset_option_;
  stream::Separator separator_ = stream::Separator::detect;
  std::vector<stream::ColumnRename> renames_;
  // Reads the options above after parsing; throws UsageError for a bad one.
  void prepare_stream_inputs();
  // The rows policy.
  std::optional<int> skipped_rows_status_ = kFailure;
  bool check_no_rows_ = true;
  int no_rows_status_ = kFailure;
  int error_status_ = kFailure;
  bool no_rows_warning_ = false;
  std::uint64_t inputs_opened_ = 0;
  std::uint64_t rows_returned_ = 0;
  std::uint64_t rows_skipped_ = 0;
  std::map<std::string, std::uint64_t, std::less<>> skipped_by_kind_;
  std::vector<std::string> input_names_;
  // The summary line of skipped rows (and of warnings not shown); applies the status policy.
  int finish_rows(int status);
  void report_skipped_rows();
};

// A one-line progress display on a terminal (rewritten in place, at most 10 times a second);
// does nothing when disabled, so callers need no branches.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled) {}
  ~Progress() { finish(); }
  void update(const std::string& line);
  void finish();

 private:
  bool enabled_;
  bool drawn_ = false;
  double last_ = -1;
};

// A CLI11 check that accepts only a whole number >= 0 written in digits.
const CLI::Validator& whole_number();

// Parses "1.5,2,3" into doubles; throws UsageError naming `option` on a bad number.
std::vector<double> parse_number_list(const std::string& text, const std::string& option);

// Takes the lock (core::FileLock) of the profile file `path` a run will write (in place, or
// -o), before the profile is read, so that a concurrent run's read-compare-write cannot
// interleave with this one (its worse fit cannot slip past the refusal, its section is not
// lost); warns once when it has to wait. Throws what core::FileLock throws (a profile that is
// not a regular file, for one).
std::unique_ptr<core::FileLock> lock_for_update(const std::string& path);

}  // namespace momentum::cli
