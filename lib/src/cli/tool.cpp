#include "momentum/cli/tool.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <iostream>

#include "momentum/core/error.hpp"
#include "momentum/core/text.hpp"
#include "momentum/version.hpp"

namespace momentum::cli {

Tool::Tool(std::string name, std::string summary) : name_(std::move(name)), app_(std::move(summary), name_) {
  app_.set_version_flag("--version", name_ + " (momentum) " + kVersion);
  app_.add_flag("-q,--quiet", quiet_, "no warnings or progress on stderr");
  app_.get_formatter()->column_width(32);
}

void Tool::add_inputs(const std::string& description) {
  app_.add_option("inputs", inputs_, description)->type_name("FILE");
}

void Tool::add_stream_inputs(const std::string& description) {
  add_inputs(description);
  app_.add_option("--separator", separator_option_,
                  "CSV field separator: auto (default: from the header), comma, semicolon, tab or space")
      ->type_name("SEP");
  app_.add_option("--rename", rename_options_,
                  "rename columns of the header: OLD=NEW, ranges a_0..5=q1..6, NEW _ drops, :deg or *F scales (repeatable)")
      ->type_name("LIST")
      ->allow_extra_args(false);
  std::string presets;
  for (const auto& name : stream::builtin_preset_names()) presets += (presets.empty() ? "" : ", ") + name;
  app_.add_option("--preset", preset_option_, "a vendor recording's column mapping: " + presets + ", or a preset file")
      ->type_name("NAME");
  app_.add_option("--topic", topic_, "ROS 2 bag: the sensor_msgs/msg/JointState topic (default: the only one)")
      ->type_name("NAME");
}

void Tool::prepare_stream_inputs() {
  try {
    if (!separator_option_.empty()) separator_ = stream::parse_separator(separator_option_);
  } catch (const Error& e) {
    throw UsageError(std::string("--separator: ") + e.what());
  }
  std::vector<stream::ColumnRename> renames;
  std::size_t group = 0;
  try {
    for (const auto& text : rename_options_) {
      auto more = stream::parse_renames(text, "--rename", group);
      for (const auto& r : more) {
        for (const auto& earlier : renames)
          if (earlier.from == r.from)
            throw Error(r.origin + ": column '" + core::printable(r.from) + "' is mapped twice (also by " + earlier.origin + ")");
        group = std::max(group, r.group + 1);
      }
      renames.insert(renames.end(), more.begin(), more.end());
    }
  } catch (const Error& e) {
    throw UsageError(e.what());
  }
  if (!preset_option_.empty()) {
    stream::ColumnPreset preset;
    try {
      preset = stream::load_preset(preset_option_);
    } catch (const Error& e) {
      throw UsageError(e.what());
    }
    // The preset first; a --rename of one of its columns replaces the preset's mapping.
    std::vector<stream::ColumnRename> merged;
    for (auto& r : preset.renames) {
      r.group += group;
      const bool overridden = std::any_of(renames.begin(), renames.end(), [&](const auto& o) { return o.from == r.from; });
      if (!overridden) merged.push_back(std::move(r));
    }
    merged.insert(merged.end(), renames.begin(), renames.end());
    renames = std::move(merged);
  }
  renames_ = std::move(renames);
}

void Tool::add_stream_output() {
  app_.add_option("-o,--output", output_, "output file (default: stdout)")->type_name("FILE");
  app_.add_option("--output-format", output_format_, "csv or bin (default: the input's encoding)")
      ->check(CLI::IsMember({"csv", "bin"}));
  app_.add_flag("--line-buffered", line_buffered_, "flush every row (for live pipelines)");
  add_strict();
}

void Tool::add_strict() {
  if (strict_added_) return;
  strict_added_ = true;
  app_.add_flag("--strict", strict_, "stop at the first bad row instead of skipping it");
}

void Tool::add_profile(bool required) {
  auto* option = app_.add_option("-p,--profile", profile_, "robot profile (JSON)")->type_name("FILE");
  if (required) option->required();
}

void Tool::add_payload() {
  app_.add_option("--payload", payload_, "the profile's payload to include, or none (default: its active_payload)")
      ->type_name("NAME");
}

void Tool::add_seed() {
  app_.add_option("--seed", seed_, "seed of every random process (default 1)")->type_name("N");
}

std::string Tool::provenance() const {
  std::string line = " " + name_ + " " + kVersion;
  for (const auto& arg : args_) {
    line += ' ';
    bool plain = !arg.empty() && arg.find_first_of(" \t'\"\\$*?#") == std::string::npos;
    line += plain ? arg : "'" + arg + "'";
  }
  return line;
}

std::unique_ptr<stream::Reader> Tool::open_input(const std::string& path, stream::ReaderOptions options) {
  options.strict = options.strict || strict_;
  options.rows_returned = &rows_returned_;
  if (options.topic.empty()) options.topic = topic_;
  if (options.joint_names.empty()) options.joint_names = chain_joints_;
  if (options.separator == stream::Separator::detect) options.separator = separator_;
  if (options.renames.empty()) options.renames = renames_;
  auto reader = stream::Reader::open(path, std::move(options));
  ++inputs_opened_;
  if (input_names_.size() < 3) input_names_.push_back(reader->name());
  return reader;
}

void Tool::report_skipped_rows() {
  if (rows_skipped_ == 0) return;
  std::string kinds;
  for (const auto& [kind, count] : skipped_by_kind_) {
    if (count > kShownPerKind)
      warn(std::to_string(count - kShownPerKind) + " more '" + kind + "' warning" +
           (count - kShownPerKind == 1 ? "" : "s") + " not shown");
    kinds += (kinds.empty() ? "" : ", ") + std::to_string(count) + " " + kind;
  }
  warn(std::to_string(rows_skipped_) + " bad row" + (rows_skipped_ == 1 ? "" : "s") + " skipped: " + kinds);
  rows_skipped_ = 0;
  skipped_by_kind_.clear();
}

int Tool::finish_rows(int status) {
  const bool skipped = rows_skipped_ > 0;
  report_skipped_rows();
  if (status == kSuccess && check_no_rows_ && inputs_opened_ > 0 && rows_returned_ == 0) {
    std::string names;
    for (const auto& n : input_names_) names += (names.empty() ? "" : ", ") + n;
    if (inputs_opened_ > input_names_.size()) names += ", ...";
    if (no_rows_warning_) {
      warn("no rows in " + names);
    } else {
      std::cerr << name_ << ": error: no rows in " << names << "\n";
    }
    return no_rows_status_;
  }
  if (status == kSuccess && skipped && skipped_rows_status_) return *skipped_rows_status_;
  return status;
}

std::unique_ptr<stream::Writer> Tool::open_output(stream::Reader& like) const {
  stream::WriterOptions options;
  // A bag is read, not written: its rows go out as CSV unless --output-format says bin.
  const stream::Encoding input = like.encoding() == stream::Encoding::mcap ? stream::Encoding::csv : like.encoding();
  options.encoding = output_format_.empty() ? input : stream::parse_encoding(output_format_);
  options.line_buffered = line_buffered_;
  auto writer = stream::Writer::open(output_, options);
  for (const auto& c : like.leading_comments()) writer->comment(c);
  writer->comment(provenance());
  stream::Writer* raw = writer.get();
  if (raw->interactive() || line_buffered_) like.before_read([raw] { raw->flush(); });
  return writer;
}

bool Tool::show_progress() const { return !quiet_ && ::isatty(STDERR_FILENO); }

namespace {

// Standard output's last words: what is still buffered is written now, and a write that failed
// on the way (a full disk, an I/O error) is an error, not a success. A closed pipe is the
// reader's choice and stays quiet. Returns the reason, empty when all went out.
std::string standard_output_failure() {
  errno = 0;
  std::cout.flush();
  const bool flushed = std::fflush(stdout) == 0;
  if (flushed && !std::ferror(stdout) && !std::cout.fail()) return {};
  if (errno == EPIPE) return {};
  return errno != 0 ? std::strerror(errno) : "write error";
}

}  // namespace

int Tool::run(int argc, char** argv, const std::function<int()>& body) {
  const int status = run_body(argc, argv, body);
  const std::string failure = standard_output_failure();
  if (failure.empty()) return status;
  std::cerr << name_ << ": error: standard output: " << failure << "\n";
  return error_status_;
}

int Tool::run_body(int argc, char** argv, const std::function<int()>& body) {
  // A closed pipe shows as EPIPE from write(2), turned into a quiet exit by the Writer.
  std::signal(SIGPIPE, SIG_IGN);
  for (int i = 1; i < argc; ++i) args_.emplace_back(argv[i]);
  try {
    app_.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    std::cout << app_.help();
    return kSuccess;
  } catch (const CLI::CallForAllHelp& e) {
    std::cout << app_.help("", CLI::AppFormatMode::All);
    return kSuccess;
  } catch (const CLI::CallForVersion& e) {
    std::cout << e.what() << "\n";
    return kSuccess;
  } catch (const CLI::ParseError& e) {
    std::string what = e.what();
    if (!what.empty()) what[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(what[0])));
    std::cerr << name_ << ": error: " << what << " (see " << name_ << " --help)\n";
    return kUsage;
  }
  try {
    prepare_stream_inputs();
  } catch (const UsageError& e) {
    std::cerr << name_ << ": error: " << e.what() << " (see " << name_ << " --help)\n";
    return kUsage;
  }
  // The inputs named, and standard input when read, are files no output of this run may
  // overwrite, also those read only after the output is opened (mo-cat a.csv b.csv -o b.csv).
  for (const auto& input : inputs_) core::expect_input(input);
  if (inputs_.empty() || std::find(inputs_.begin(), inputs_.end(), "-") != inputs_.end())
    core::expect_input("/dev/stdin", "<stdin>");
  std::string prefix = name_ + ": warning: ";
  set_warning_sink([this, prefix](std::string_view message) {
    if (!quiet_) {
      std::string line = prefix + std::string(message) + "\n";
      std::fwrite(line.data(), 1, line.size(), stderr);
    }
  });
  set_row_warning_sink([this](std::string_view kind, std::string_view message) {
    ++rows_skipped_;
    auto it = skipped_by_kind_.find(kind);
    if (it == skipped_by_kind_.end()) it = skipped_by_kind_.emplace(std::string(kind), 0).first;
    if (++it->second <= kShownPerKind) warn(message);
  });
  try {
    int status = body();
    std::cout.flush();
    return finish_rows(status);
  } catch (const stream::BrokenPipe&) {
    return kSuccess;
  } catch (const UsageError& e) {
    std::cerr << name_ << ": error: " << e.what() << " (see " << name_ << " --help)\n";
    return kUsage;
  } catch (const Error& e) {
    report_skipped_rows();
    std::cerr << name_ << ": error: " << e.what() << "\n";
    return error_status_;
  } catch (const std::exception& e) {
    report_skipped_rows();
    std::cerr << name_ << ": error: " << e.what() << "\n";
    return error_status_;
  }
}

void Progress::update(const std::string& line) {
  if (!enabled_) return;
  using clock = std::chrono::steady_clock;
  double now = std::chrono::duration<double>(clock::now().time_since_epoch()).count();
  if (drawn_ && now - last_ < 0.1) return;
  last_ = now;
  drawn_ = true;
  std::string text = "\r" + line + "\x1b[K";
  std::fwrite(text.data(), 1, text.size(), stderr);
  std::fflush(stderr);
}

void Progress::finish() {
  if (enabled_ && drawn_) {
    std::fwrite("\r\x1b[K", 1, 4, stderr);
    std::fflush(stderr);
    drawn_ = false;
  }
}

const CLI::Validator& whole_number() {
  static const CLI::Validator check(
      [](std::string& text) -> std::string {
        bool digits = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
        return digits ? std::string() : "'" + text + "' is not a whole number >= 0";
      },
      "");
  return check;
}


std::vector<double> parse_number_list(const std::string& text, const std::string& option) {
  std::vector<double> values;
  for (const auto& part : core::split(text)) {
    auto value = stream::parse_double(part);
    if (!value) throw UsageError(option + ": '" + part + "' is not a number");
    values.push_back(*value);
  }
  return values;
}

std::unique_ptr<core::FileLock> lock_for_update(const std::string& path) {
  return std::make_unique<core::FileLock>(path, [](const std::string& name) {
    warn(name + ": another run is updating this profile; waiting for it to finish");
  });
}

}  // namespace momentum::cli
