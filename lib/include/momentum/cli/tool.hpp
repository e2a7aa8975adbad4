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
#include <memory>
#include <string>
#include <vector>

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
  // -o FILE, --output-format csv|bin, --line-buffered, --strict: for tools that read and
  // write sample streams.
  void add_stream_output();
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
  // 0), and routes momentum::warn to stderr (silenced by --quiet). Returns the exit status.
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

  // Opens one input with the tool's --strict setting.
  std::unique_ptr<stream::Reader> open_input(const std::string& path,
                                             stream::ReaderOptions options = {}) const;
  // Opens the -o output in the encoding --output-format names (default: `like`'s), copies
  // `like`'s leading comments and adds the provenance line. Flushing: every row with
  // --line-buffered; otherwise whenever `like` is about to wait for input, so that a live
  // pipeline sees each row at once while file input stays buffered.
  std::unique_ptr<stream::Writer> open_output(stream::Reader& like) const;

  // True when progress may be drawn: stderr is a terminal and --quiet is off.
  bool show_progress() const;

 private:
  std::string name_;
  CLI::App app_;
  std::vector<std::string> args_;
  std::vector<std::string> inputs_;
  std::string output_ = "-";
  std::string output_format_;
  std::string profile_;
  std::string payload_;
  std::uint64_t seed_ = 1;
  bool quiet_ = false;
  bool strict_ = false;
  bool line_buffered_ = false;
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

// Splits "a,b,c" into parts; empty string gives no parts.
std::vector<std::string> split_list(const std::string& text, char separator = ',');
// Parses "1.5,2,3" into doubles; throws UsageError naming `option` on a bad number.
std::vector<double> parse_number_list(const std::string& text, const std::string& option);

// Writes `text` (a report, a document) to the file `path`, replacing it, or to stdout when path
// is "-". Throws momentum::Error "PATH: cannot write the WHAT" when the file cannot be written.
void write_text(const std::string& path, const std::string& text, const std::string& what);

}  // namespace momentum::cli
