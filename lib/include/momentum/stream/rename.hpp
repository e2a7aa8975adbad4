#pragma once
// Renaming, dropping and scaling the columns of a stream that has a header, as it is read
// (--rename, --preset): "actual_q_0..5=q1..6,actual_current_0..5=i1..6,x=_,pos_0..5=q1..6:deg".
// A preset is a named list of such mappings for one vendor's recordings (share/momentum/presets/,
// compiled in), or a file of the same form.

#include <string>
#include <string_view>
#include <vector>

namespace momentum::stream {

// One column of the input's header renamed, dropped or scaled.
struct ColumnRename {
  std::string from;  // a name of the input's header
  std::string to;    // the name the tools see; "_" drops the column
  // Values are multiplied by this as they are read (a unit: "deg" is pi/180, "mA" 0.001; a
  // factor "*0.5"; both multiply).
  double scale = 1.0;
  // A preset's mapping that applies only when the header has its columns (all of a range, or
  // none of them: some of them is an error).
  bool optional = false;
  // Where it was written, for messages: "--rename 'q0..5=q1..6'", "--preset ur-rtde line 4".
  std::string origin;
  // The renames that came from the same item (a range), for "all or none" of an optional one.
  std::size_t group = 0;
};

// Parses a comma-separated list of mappings. An item is FROM=TO with optional modifiers after
// TO: ":UNIT" (deg = pi/180, for degrees and degrees/s to rad and rad/s; mA, ms = 1e-3; us =
// 1e-6; ns = 1e-9) and "*FACTOR" or "/FACTOR"; each multiplies. FROM and TO may be ranges of
// numbered names, "actual_q_0..5" or "actual_q_0-5" (a name, then first..last), of the same
// length; TO "_" drops FROM. `origin` prefixes every message ("--rename"). Throws
// momentum::Error naming the item for an empty item, no "=", an empty side, ranges of
// different lengths, a backwards or too long range, an unknown unit, a factor that is not a
// finite non-zero number, or a column renamed twice in the list.
std::vector<ColumnRename> parse_renames(std::string_view text, std::string_view origin, std::size_t first_group = 0);

// A named set of mappings.
struct ColumnPreset {
  std::string name;
  std::vector<ColumnRename> renames;
};

// Parses a preset's text: one mapping item per line (as in --rename, commas allowed), "#"
// starts a comment, a line "optional ITEM" maps only when the header has the item's columns.
// Throws momentum::Error (`name line N: ...`) on a bad line.
ColumnPreset parse_preset(std::string_view text, const std::string& name);

// The built-in preset `name_or_path` ("ur-rtde"), or else the preset file at that path.
// Throws momentum::Error naming the built-in presets when it is neither.
ColumnPreset load_preset(const std::string& name_or_path);

// Names of the built-in presets (share/momentum/presets/*.preset, compiled in).
std::vector<std::string> builtin_preset_names();

// The built-in presets whose required mappings all find their columns in `header` (a
// recording --preset NAME would read), in name order.
std::vector<std::string> presets_matching(const std::vector<std::string>& header);

// What a header becomes under `renames`: for each input column its new name ("_" when
// dropped) and scale.
struct RenamedHeader {
  std::vector<std::string> names;
  std::vector<double> scales;
};

// Applies `renames` to `header`. Throws momentum::Error (`where: ORIGIN: message`) when a
// required mapping names a column the header does not have (the message lists the header's
// columns, compactly), when an optional range is only partly there, or when two columns end
// up with one name.
RenamedHeader apply_renames(const std::vector<std::string>& header, const std::vector<ColumnRename>& renames,
                            const std::string& where);

// The column names as a short list with numbered runs folded: "timestamp, actual_q_0..5,
// actual_qd_0..5". At most `max_chars` characters, then ", ...".
std::string compact_column_list(const std::vector<std::string>& columns, std::size_t max_chars = 300);

}  // namespace momentum::stream
