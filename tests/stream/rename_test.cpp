// Renaming, dropping and scaling columns as a stream is read (--rename, --preset), and the
// CSV separator named instead of detected (--separator).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "momentum/core/error.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/rename.hpp"

namespace ms = momentum::stream;

namespace {

std::string temp_path(const std::string& name) {
  return ::testing::TempDir() + "/momentum_rename_" + std::to_string(::getpid()) + "_" + name;
}

void write_file(const std::string& path, const std::string& content) {
  std::ofstream(path, std::ios::binary) << content;
}

std::vector<std::vector<double>> read_all(ms::Reader& reader) {
  std::vector<std::vector<double>> rows;
  while (const double* row = reader.next()) rows.emplace_back(row, row + reader.columns().size());
  return rows;
}

// The message of the momentum::Error that `f` throws, or "" when it throws none.
template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const momentum::Error& e) {
    return e.what();
  }
  return "";
}

// A header of UR's RTDE client (record.py): space-separated, vectors as NAME_0..NAME_5, CR LF
// line ends (Python's csv module), the controller's seconds since start as the time.
std::string rtde_header(bool with_torque) {
  std::string h = "timestamp";
  for (const char* v : {"actual_q", "actual_qd", "actual_current"})
    for (int j = 0; j < 6; ++j) h += std::string(" ") + v + "_" + std::to_string(j);
  if (with_torque)
    for (int j = 0; j < 6; ++j) h += " target_moment_" + std::to_string(j);
  h += " robot_mode\r\n";
  return h;
}

std::string rtde_row(double t, double base, bool with_torque) {
  std::string row = std::to_string(t);
  for (int k = 0; k < (with_torque ? 24 : 18); ++k) row += " " + std::to_string(base + k);
  return row + " 7\r\n";
}

}  // namespace

TEST(Rename, RangesInBothSpellingsPairTheirNamesInOrder) {
  auto renames = ms::parse_renames("actual_q_0..2=q1..3, x_4-5=dq1-2 ,time=t", "--rename");
  ASSERT_EQ(renames.size(), 6u);
  EXPECT_EQ(renames[0].from, "actual_q_0");
  EXPECT_EQ(renames[0].to, "q1");
  EXPECT_EQ(renames[2].from, "actual_q_2");
  EXPECT_EQ(renames[2].to, "q3");
  EXPECT_EQ(renames[3].from, "x_4");
  EXPECT_EQ(renames[4].to, "dq2");
  EXPECT_EQ(renames[5].from, "time");
  EXPECT_EQ(renames[5].to, "t");
  // One item is one group (an optional range applies all or nothing).
  EXPECT_EQ(renames[0].group, renames[2].group);
  EXPECT_NE(renames[2].group, renames[3].group);
}

TEST(Rename, UnitsAndFactorsMultiply) {
  auto renames = ms::parse_renames("a=q1:deg,b=i1*0.001,c=i2/1000:mA,d=t:ms*-1,e=_", "--rename");
  ASSERT_EQ(renames.size(), 5u);
  EXPECT_EQ(renames[0].scale, std::numbers::pi / 180.0);
  EXPECT_EQ(renames[1].scale, 0.001);
  EXPECT_DOUBLE_EQ(renames[2].scale, 1e-6);
  EXPECT_EQ(renames[3].scale, -0.001);
  EXPECT_EQ(renames[4].to, "_");
}

TEST(Rename, BadMappingsSayWhichItemAndWhy) {
  auto message = [](const char* text) { return error_of([&] { ms::parse_renames(text, "--rename"); }); };
  EXPECT_EQ(message("a"), "--rename 'a': no '=' (write OLD=NEW)");
  EXPECT_EQ(message("=q1"), "--rename '=q1': no column name before '='");
  EXPECT_EQ(message("a="), "--rename 'a=': no new name after '='");
  EXPECT_EQ(message("a=b,,c=d"), "--rename: empty item in 'a=b,,c=d'");
  EXPECT_EQ(message("q0..5=q1..5"), "--rename 'q0..5=q1..5': the ranges differ in length (6 and 5 columns)");
  EXPECT_EQ(message("q5..0=q1..6"), "--rename 'q5..0=q1..6': backwards range 'q5..0'");
  EXPECT_EQ(message("q0..5=x"),
            "--rename 'q0..5=x': 6 columns cannot all be named 'x' (write a range, e.g. q1..6, or _ to drop them)");
  EXPECT_EQ(message("a=q1..6"), "--rename 'a=q1..6': one column cannot become the range 'q1..6'");
  EXPECT_EQ(message("a=q1:furlong"), "--rename 'a=q1:furlong': unknown unit 'furlong' (units: deg, mA, ms, us, ns; or *FACTOR)");
  EXPECT_EQ(message("a=q1*0"), "--rename 'a=q1*0': '0' is not a finite non-zero factor");
  EXPECT_EQ(message("a=q1*x"), "--rename 'a=q1*x': 'x' is not a finite non-zero factor");
  EXPECT_EQ(message("a=_:deg"), "--rename 'a=_:deg': a dropped column takes no unit or factor");
  EXPECT_EQ(message("a=b,a=c"), "--rename 'a=c': column 'a' is mapped twice");
  EXPECT_NE(message("q0..99999999=x_0..99999999").find("is too long"), std::string::npos);
}

TEST(Rename, ReaderRenamesDropsAndScalesAsItReads) {
  const std::string path = temp_path("rtde.txt");
  write_file(path, rtde_header(false) + rtde_row(100.0, 1.0, false) + rtde_row(100.008, 2.0, false));
  ms::ReaderOptions options;
  options.renames = ms::parse_renames("timestamp=t,actual_q_0..5=q1..6:deg,actual_qd_0..5=_,robot_mode=_", "--rename");
  auto in = ms::Reader::open(path, options);
  std::vector<std::string> expected{"t", "q1", "q2", "q3", "q4", "q5", "q6", "actual_current_0", "actual_current_1",
                                    "actual_current_2", "actual_current_3", "actual_current_4", "actual_current_5"};
  EXPECT_EQ(in->columns(), expected);
  // The time-order policy follows the column renamed t.
  EXPECT_NE(in->time_summary(), nullptr);
  auto rows = read_all(*in);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0][0], 100.0);
  EXPECT_EQ(rows[0][1], 1.0 * (std::numbers::pi / 180.0));
  EXPECT_EQ(rows[1][6], 7.0 * (std::numbers::pi / 180.0));  // actual_q_5 of the second row: 2 + 5
  EXPECT_EQ(rows[1][7], 14.0);                               // actual_current_0: 2 + 12
}

TEST(Rename, ANameTheHeaderLacksIsAnErrorListingTheHeader) {
  const std::string path = temp_path("lacks.txt");
  write_file(path, rtde_header(false) + rtde_row(0, 1, false));
  ms::ReaderOptions options;
  options.renames = ms::parse_renames("actual_q_0..6=q1..7", "--rename");
  EXPECT_EQ(error_of([&] { ms::Reader::open(path, options); }),
            path + ": --rename 'actual_q_0..6=q1..7': no column 'actual_q_6' in the header; its columns: "
                   "timestamp, actual_q_0..5, actual_qd_0..5, actual_current_0..5, robot_mode");
}

TEST(Rename, TwoColumnsWithOneNameAreAnError) {
  const std::string path = temp_path("twice.csv");
  write_file(path, "t,q0,q1\n0,1,2\n");
  ms::ReaderOptions options;
  options.renames = ms::parse_renames("q0=q1", "--rename");
  EXPECT_EQ(error_of([&] { ms::Reader::open(path, options); }),
            path + ": --rename 'q0=q1': two columns would be named 'q1' ('q0' and 'q1' of the header)");
  // Renamed together, as a zero-based stream is, they do not collide.
  options.renames = ms::parse_renames("q0..1=q1..2", "--rename");
  auto in = ms::Reader::open(path, options);
  EXPECT_EQ(in->columns(), (std::vector<std::string>{"t", "q1", "q2"}));
}

TEST(Rename, TheUrRtdePresetMapsARecordingAsItIs) {
  const std::string path = temp_path("preset.txt");
  write_file(path, rtde_header(true) + rtde_row(5.0, 1.0, true) + rtde_row(5.008, 2.0, true));
  ms::ReaderOptions options;
  options.renames = ms::load_preset("ur-rtde").renames;
  auto in = ms::Reader::open(path, options);
  std::vector<std::string> expected{"t"};
  for (const char* prefix : {"q", "dq", "i", "tau_target"})
    for (int j = 1; j <= 6; ++j) expected.push_back(prefix + std::to_string(j));
  expected.push_back("robot_mode");  // not the preset's: passed through
  EXPECT_EQ(in->columns(), expected);
  auto rows = read_all(*in);
  ASSERT_EQ(rows.size(), 2u);
  for (int k = 0; k < 24; ++k) EXPECT_EQ(rows[1][1 + k], 2.0 + k) << k;
}

TEST(Rename, APresetsOptionalColumnsMayBeAbsentButNotHalfThere) {
  const std::string path = temp_path("optional.txt");
  write_file(path, rtde_header(false) + rtde_row(5.0, 1.0, false));
  ms::ReaderOptions options;
  options.renames = ms::load_preset("ur-rtde").renames;
  auto in = ms::Reader::open(path, options);
  EXPECT_EQ(in->columns().size(), 1u + 18u + 1u);
  // Half a torque vector is a recording the preset does not understand.
  const std::string half = temp_path("half.txt");
  std::string header = rtde_header(false);
  header.insert(header.size() - 2, " target_moment_0 target_moment_1");
  write_file(half, header);
  EXPECT_EQ(error_of([&] { ms::Reader::open(half, options); }),
            half + ": --preset ur-rtde line 18 'target_moment_0..5=tau_target1..6': no column 'target_moment_2' in the header (2 of the 6 columns are "
                   "there); its columns: timestamp, actual_q_0..5, actual_qd_0..5, actual_current_0..5, robot_mode, "
                   "target_moment_0..1");
  // A required one missing.
  const std::string no_current = temp_path("no_current.txt");
  write_file(no_current, "timestamp actual_q_0 actual_q_1\n");
  EXPECT_NE(error_of([&] { ms::Reader::open(no_current, options); })
                .find(": --preset ur-rtde line 10 'actual_q_0..5=q1..6': no column 'actual_q_2' in the header"),
            std::string::npos);
}

TEST(Rename, BuiltinPresetsAreTheInstalledFiles) {
  // The compiled-in copy of each preset reads as the file installed under share/.
  for (const std::string& name : ms::builtin_preset_names()) {
    const auto builtin = ms::load_preset(name);
    const auto file = ms::load_preset(std::string(MOMENTUM_SOURCE_DIR) + "/share/momentum/presets/" + name + ".preset");
    ASSERT_EQ(builtin.renames.size(), file.renames.size()) << name;
    for (std::size_t k = 0; k < builtin.renames.size(); ++k) {
      const auto& a = builtin.renames[k];
      const auto& b = file.renames[k];
      EXPECT_EQ(a.from, b.from);
      EXPECT_EQ(a.to, b.to);
      EXPECT_EQ(a.scale, b.scale);
      EXPECT_EQ(a.optional, b.optional);
      EXPECT_EQ(a.group, b.group);
      EXPECT_EQ(a.origin.substr(a.origin.find(" line ")), b.origin.substr(b.origin.find(" line "))) << a.origin;
    }
  }
  EXPECT_EQ(ms::builtin_preset_names(), (std::vector<std::string>{"ur-rtde"}));
}

TEST(Rename, PresetFilesAndUnknownNames) {
  const std::string path = temp_path("mine.preset");
  write_file(path, "# a comment\nTime=t:ms\n\noptional Pos_1..2=q1..2:deg  # trailing comment\nbad line\n");
  EXPECT_EQ(error_of([&] { ms::load_preset(path); }), "--preset " + path + " line 5 'bad line': no '=' (write OLD=NEW)");
  write_file(path, "Time=t:ms\noptional Pos_1..2=q1..2:deg\n");
  const auto preset = ms::load_preset(path);
  ASSERT_EQ(preset.renames.size(), 3u);
  EXPECT_FALSE(preset.renames[0].optional);
  EXPECT_TRUE(preset.renames[2].optional);
  EXPECT_EQ(preset.renames[0].scale, 1e-3);
  // A path that is no preset file (a device without end) stops at 1 MiB.
  EXPECT_EQ(error_of([&] { ms::load_preset("/dev/zero"); }), "--preset /dev/zero: larger than 1 MiB, not a preset file");
  EXPECT_EQ(error_of([&] { ms::load_preset("no-such-preset"); }),
            "--preset: 'no-such-preset' is no built-in preset (ur-rtde) and no preset file that can be opened");
}

TEST(Rename, CompactColumnListFoldsNumberedRuns) {
  EXPECT_EQ(ms::compact_column_list({"t", "q1", "q2", "q3", "dq1", "x", "a_0", "a_1", "a_3", "q10"}),
            "t, q1..3, dq1, x, a_0..1, a_3, q10");
  std::vector<std::string> many;
  for (int k = 0; k < 100; ++k) many.push_back("col" + std::to_string(k) + "x");
  const std::string list = ms::compact_column_list(many, 40);
  EXPECT_LE(list.size(), 45u);
  EXPECT_EQ(list.substr(list.size() - 5), ", ...");
}

TEST(Separator, NamedSeparatorReadsWhatDetectionWouldMisread) {
  // A semicolon export with a comma inside a column name: detection takes the comma.
  const std::string path = temp_path("semicolon.csv");
  write_file(path, "t;q1;note,x\n0;1;2\n0.5;3;4\n");
  {
    auto in = ms::Reader::open(path);
    EXPECT_EQ(in->columns(), (std::vector<std::string>{"t;q1;note", "x"}));
  }
  ms::ReaderOptions options;
  options.separator = ms::parse_separator("semicolon");
  auto in = ms::Reader::open(path, options);
  EXPECT_EQ(in->columns(), (std::vector<std::string>{"t", "q1", "note,x"}));
  auto rows = read_all(*in);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1], (std::vector<double>{0.5, 3, 4}));
}

TEST(Separator, BlanksAndTabsNamedOrDetected) {
  // Runs of spaces, blanks at both ends, as fixed-width exports write them: detected. Runs of
  // spaces and tabs mixed: detection takes the tab, --separator space takes the runs.
  const std::string spaces = temp_path("spaces.txt"), mixed = temp_path("mixed.txt");
  write_file(spaces, "  t  q1   q2\n 0  1    2 \n1 3 4\n");
  write_file(mixed, "  t \t q1   q2\n 0\t 1    2 \n1 \t3 4\n");
  for (const char* name : {"auto", "space", "whitespace"}) {
    ms::ReaderOptions options;
    options.separator = ms::parse_separator(name);
    auto in = ms::Reader::open(std::string(name) == "auto" ? spaces : mixed, options);
    EXPECT_EQ(in->columns(), (std::vector<std::string>{"t", "q1", "q2"})) << name;
    auto rows = read_all(*in);
    ASSERT_EQ(rows.size(), 2u) << name;
    EXPECT_EQ(rows[1], (std::vector<double>{1, 3, 4})) << name;
  }
  const std::string tabs = temp_path("tabs.txt");
  write_file(tabs, "t\tq 1\n0\t1\n");
  ms::ReaderOptions options;
  options.separator = ms::parse_separator("tab");
  auto in = ms::Reader::open(tabs, options);
  EXPECT_EQ(in->columns(), (std::vector<std::string>{"t", "q 1"}));
  EXPECT_EQ(error_of([] { ms::parse_separator("pipe"); }),
            "unknown separator 'pipe' (auto, comma, semicolon, tab or space)");
}
