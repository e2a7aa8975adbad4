#pragma once
// Reads a sample stream (CSV, binary, or a ROS 2 bag in MCAP, detected from the first bytes) row
// by row in constant memory, from a file or from stdin ("-"). Reading uses read(2) on the descriptor, so a row that
// arrives on a pipe is returned as soon as its line is complete.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "momentum/stream/format.hpp"
#include "momentum/stream/rename.hpp"
#include "momentum/stream/time_order.hpp"

namespace momentum::stream {

// How the fields of a CSV line are separated: detected from the header (the first of comma,
// semicolon and tab outside quotes, else runs of blanks), or one of them named.
enum class Separator { detect, comma, semicolon, tab, blanks };

// "auto", "comma", "semicolon", "tab", "space" (runs of spaces and tabs; also "blanks",
// "whitespace"), or the character itself (",", ";", "\t" as a tab); throws momentum::Error
// for anything else.
Separator parse_separator(std::string_view name);

struct ReaderOptions {
  // Stop with momentum::Error at the first bad row instead of reporting, counting and skipping.
  bool strict = false;
  // For header-less CSV (vendor exports): the column names to use; the first line is then data.
  // A name "_" drops that column. Empty: the first non-comment line is the header.
  std::vector<std::string> names;
  // CSV only: how fields are separated (Separator::detect: from the header, or with `names`
  // from the first row).
  Separator separator = Separator::detect;
  // Columns renamed, dropped and scaled as they are read (--rename, --preset), applied to the
  // header (or to `names`): the reader's columns() and rows are the renamed ones, and the
  // time-order policy uses the column that ends up named "t". Open fails when a mapping names
  // a column the header lacks (apply_renames).
  std::vector<ColumnRename> renames;
  // Display name of the input in messages; defaults to the path, or "<stdin>" for "-".
  std::string display_name;
  // Called before every read of the input from the first one, the header's included, until
  // Reader::before_read() replaces it: a live tool waits there for a signal, and may throw to
  // stop waiting (the exception leaves open()).
  std::function<void()> before_read;
  // Apply the suite's time-order policy (time_order.hpp) to the column "t" when the stream has
  // one: rows whose time does not fit their neighbours are reported, counted and skipped like
  // other bad rows, and a kept row after a clock step is marked (time_mark()). Off: rows come
  // as written (mo-cat, mo-cat --stats).
  bool time_order = true;
  // When set, incremented for every row next() returns (a tool's count over its inputs).
  std::uint64_t* rows_returned = nullptr;
  // For a ROS 2 bag (MCAP): the topic of sensor_msgs/msg/JointState messages to read. Empty:
  // the bag's only JointState topic (an error listing them when it has several).
  std::string topic;
  // For a ROS 2 bag: the joints of the profile's chain, root to tip. The columns' joint j is the
  // message's joint of this name, whatever the message's order; a chain joint missing from a
  // message is an error (first message) or a bad row (later ones), and joints not in the chain
  // are left out with one warning. Empty: the joints and order of the first message.
  std::vector<std::string> joint_names;
};

class Reader {
 public:
  // Opens `path` ("-" or "" for stdin) and reads up to the end of the header. Throws
  // momentum::Error (`file: message`) when the file cannot be opened, is empty, or its header is
  // unusable (no header, duplicate or empty column name, wrong binary magic or version). A ROS 2
  // bag (MCAP magic) is read up to its first usable JointState message, which fixes the columns
  // (t, q<j>, dq<j>, tau_m<j>: mo-log(5)); see the MCAP reader's errors in mcap_reader.hpp.
  static std::unique_ptr<Reader> open(const std::string& path, ReaderOptions options = {});
  virtual ~Reader() = default;

  // Column names, in order. Stable for the life of the reader.
  const std::vector<std::string>& columns() const { return columns_; }
  // Comment lines before the header, without the leading '#'.
  const std::vector<std::string>& leading_comments() const { return leading_comments_; }
  Encoding encoding() const { return encoding_; }
  const std::string& name() const { return name_; }
  // True when the input is a pipe, socket or terminal (rows may arrive live).
  bool live() const { return live_; }

  // Index of a column, or nullopt.
  std::optional<std::size_t> find(std::string_view column) const;
  // Index of a column; throws momentum::Error `file: missing column 'x'`.
  std::size_t require(std::string_view column) const;

  // The next good row (columns().size() values, valid until the next call), or nullptr at end
  // of input. Bad rows (ragged, non-numeric, truncated binary record, and with the time-order
  // policy a time that does not fit) are reported through momentum::warn with their location,
  // counted and skipped; in strict mode they throw momentum::Error. Comment lines after the
  // header are handed to the comment handler in stream order.

  // With the time-order policy, a row that follows a suspicious time is returned only once the
  // next row has been read (constant memory: at most three rows are held).
  const double* next();

  // Up to `max` rows after the row last returned that are already in memory, copied into
  // `rows` (max x columns().size() values), as next() would return them if none is skipped or
  // held: a hint for work a caller can do ahead (the observer's dynamics, several rows at
  // once), never a promise. Reads nothing, so never blocks a live stream. Returns the count: 0
  // for CSV and MCAP input, with renames, and while the time-order policy holds rows; binary
  // input stops at a comment record or a partial record.
  std::size_t peek(double* rows, std::size_t max);

  // Reads nothing more: the rows the time-order policy still holds are decided as at the end
  // of input and returned by the next calls of next(), then nullptr. For a tool that stops
  // early (a signal), so that no row it already read is lost.
  void stop();

  // Location of the row last returned: `file:line` for CSV, `file: byte N` for binary, `file:
  // byte N` or `file: byte N, chunk record K` (its record, or its chunk's) for MCAP.
  std::string where() const { return location(position_); }
  // The location of a row at `position` (a line number or a byte offset).
  virtual std::string location(std::uint64_t position) const = 0;
  // Line number (CSV), byte offset (binary) or packed record position (MCAP) of the row last
  // returned; positions grow through the input.
  std::uint64_t position() const { return position_; }

  // Rows parsed, and rows skipped (bad rows and rows dropped for their time).
  std::uint64_t rows_read() const { return rows_read_; }
  std::uint64_t rows_skipped() const { return rows_skipped_; }
  // Rows skipped before the row last returned, in input order (all of them after next()
  // returned nullptr). rows_skipped() runs ahead of it by the rows the time-order policy holds:
  // with this, a tool knows between which two rows it returned each skipped row lay.
  std::uint64_t rows_skipped_before() const { return skipped_before_; }
  // How the row last returned follows the one before it (TimeMark::none without the policy).
  TimeMark time_mark() const { return time_mark_; }
  // The time-order policy's counts, or nullptr when it is off (option, or no column "t").
  const TimeOrder::Summary* time_summary() const { return time_order_ ? &time_order_->summary() : nullptr; }

  // Called with each comment line after the header (text without '#').
  void on_comment(std::function<void(std::string_view)> handler) { comment_handler_ = std::move(handler); }
  // Called before every read(2) that may block; tools flush their output here so that a live
  // consumer sees every row already produced while batch input stays fully buffered.
  void before_read(std::function<void()> hook) { before_read_ = std::move(hook); }

  // Reports (momentum::warn_row) and counts the row last returned, which the caller rejects
  // for its own reasons: `kind` is a short fixed phrase ("time goes backwards"), `detail` more
  // (may be empty); the reader adds the location. Throws momentum::Error in strict mode.
  void reject_row(std::string_view kind, std::string_view detail = {});

  // Whether the row last returned, at time t (s), may follow the caller's previous row at
  // t_previous: always with the time-order policy on (it drops the rows that do not fit, and
  // marks a clock step, after which the caller starts a new time line); with it off
  // (ReaderOptions::time_order false), only when t is finite and after t_previous; a row that
  // is not is rejected (reject_row, in the policy's words) and false returned.
  bool follows_in_time(double t, double t_previous);

  // Warns (momentum::warn) at a row marked TimeMark::clock_step: `where: the clock stepped
  // back: ` and what the tool does with the rows from here (`consequence`).
  void warn_clock_step(std::string_view consequence) const;

 protected:
  Reader() = default;
  std::vector<std::string> columns_;
  std::vector<std::string> leading_comments_;
  Encoding encoding_ = Encoding::csv;
  std::string name_;
  bool live_ = false;
  bool strict_ = false;
  std::uint64_t position_ = 0;      // the row last returned
  std::uint64_t raw_position_ = 0;  // the row last parsed
  std::uint64_t rows_read_ = 0;
  std::uint64_t rows_skipped_ = 0;
  std::function<void(std::string_view)> comment_handler_;
  std::function<void()> before_read_;
  // Reports (momentum::warn_row with `kind`), counts and skips the row last parsed (throws in
  // strict mode).
  void skip_bad(std::string_view kind, std::string_view message);
  // The next parsed row (raw_position_ set), or nullptr at end of input.
  virtual const double* read_row() = 0;
  // Up to `max` whole rows that read_row() would return next without reading, as Reader::peek
  // (before renames); changes nothing.
  virtual std::size_t peek_rows(double* rows, std::size_t max) const {
    (void)rows;
    (void)max;
    return 0;
  }

 private:
  // Renames (ReaderOptions::renames): the input's values at `mapped_from_` times
  // `mapped_scale_` make the row; empty when no mapping is set.
  void start_renames(const std::vector<ColumnRename>& renames);
  const double* mapped(const double* raw);
  std::vector<std::size_t> mapped_from_;
  std::vector<double> mapped_scale_;
  std::vector<double> mapped_row_;
  void start_time_order(const ReaderOptions& options);
  // Counts a skipped row at `position` for rows_skipped_before(): a run of skipped rows with
  // no good row among them is one entry, so memory stays constant.
  void note_skip(std::uint64_t position);
  void settle_skips(bool at_end);
  struct SkipRun {
    std::uint64_t last = 0, count = 0;
  };
  std::vector<SkipRun> pending_skips_;  // after the row last returned, in position order
  std::uint64_t skipped_before_ = 0;
  std::uint64_t last_good_position_ = 0;  // the last row parsed and handed on
  bool have_good_ = false;
  std::unique_ptr<TimeOrder> time_order_;
  TimeMark time_mark_ = TimeMark::none;
  std::uint64_t* rows_returned_ = nullptr;
  bool ended_ = false;
};

}  // namespace momentum::stream
