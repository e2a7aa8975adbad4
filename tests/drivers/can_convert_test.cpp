// mo-can2csv's driver: options that do not go together, the frame source over several files
// with its counters, the conversion into cycle rows and signal rows, and the --stats reports.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "momentum/drivers/can_convert.hpp"
#include "momentum/core/error.hpp"

namespace fs = std::filesystem;
using namespace momentum::can;
using namespace momentum::drivers;

namespace {

const std::string kFormats = std::string(MOMENTUM_TEST_DATA) + "/can/formats/";

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

fs::path temp(const std::string& name) {
  return fs::path(::testing::TempDir()) / ("momentum_convert_" + std::to_string(::getpid()) + "_" + name);
}

ConvertOptions log_options(const fs::path& output) {
  ConvertOptions o;
  o.dbc = kFormats + "arm2.dbc";
  o.inputs = {kFormats + "log.log"};
  o.output = output.string();
  return o;
}

}  // namespace

TEST(ConvertOptions, DefaultsAreValidAndConflictsAreNamed) {
  ConvertOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.sync = "80";
  o.period = 0.001;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "--sync, --cycle-message and --period are alternatives: give one");
  o = {};
  o.sync = "zz";
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why.rfind("--sync: ", 0), 0u) << why;
  o = {};
  o.long_format = true;
  o.encoding = momentum::stream::Encoding::binary;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "--long writes csv only");
  o = {};
  o.interface = "can0";
  o.inputs = {"a.log"};
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  o.period = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_THROW(Converter{o}, std::invalid_argument);
}

TEST(Converter, MakesOneRowPerCycleAndCountsWhatItSaw) {
  const fs::path out = temp("cycles.csv");
  ConvertOptions o = log_options(out);
  o.provenance = "test";
  Converter converter(o);
  converter.run();
  EXPECT_NO_THROW(converter.require_rows());
  const ConvertSummary s = converter.summary();
  EXPECT_EQ(s.mode, ConvertSummary::Mode::cycles);
  // The same numbers as the golden case mo-can2csv/stdin-pipe.
  EXPECT_EQ(s.source.frames, 40u);
  EXPECT_EQ(s.cycles.decoded, 30u);
  EXPECT_EQ(s.cycles.sync_frames, 6u);
  EXPECT_EQ(s.cycles.complete_cycles, 5u);
  EXPECT_EQ(s.rows, 6u);
  const std::string text = read(out);
  EXPECT_EQ(text.rfind("#test\nt,q1,q2,dq1,dq2,i1,i2,tau_m1,tau_m2\n", 0), 0u) << text;
  EXPECT_EQ(format_summary(s, "x: ").substr(0, 55), "x: frames read 40, decoded 30, unknown ids 2, sync 6, e");
  const std::string json = summary_json_line(s);
  // Keys sorted, as nlohmann::json writes an object (what mo-can2csv wrote before).
  EXPECT_EQ(json,
            "{\"bad_lines\":0,\"bad_records\":0,\"before_first_cycle\":1,\"cycles_complete\":5,"
            "\"cycles_incomplete\":1,\"decoded\":30,\"empty_periods\":0,\"error_frames\":1,\"filtered\":0,"
            "\"frames_read\":40,\"lost_frames\":0,\"remote\":1,\"short\":0,\"sync\":6,\"unknown_ids\":2,"
            "\"values_held\":0,\"values_missing\":1,\"values_repeated\":0}\n");
  fs::remove(out);
}

TEST(Converter, ReadsFilesOneAfterTheOtherAndSumsTheirCounters) {
  const fs::path out = temp("twice.csv");
  ConvertOptions o = log_options(out);
  o.inputs = {kFormats + "log.log", kFormats + "log.log"};
  Converter converter(o);
  converter.run();
  EXPECT_EQ(converter.summary().source.frames, 80u);
  fs::remove(out);
}

TEST(Converter, StopsWhenKeepGoingSaysSo) {
  const fs::path out = temp("stopped.csv");
  Converter converter(log_options(out));
  int asked = 0;
  converter.set_keep_going([&] { return ++asked < 10; });
  converter.run();
  EXPECT_LT(converter.summary().source.frames, 10u);
  fs::remove(out);
}

TEST(Converter, LongRowsAndNoRowsAtAll) {
  const fs::path out = temp("long.csv");
  {
    // (one converter at a time: two outputs of one process open on one file are refused)
    ConvertOptions o = log_options(out);
    o.long_format = true;
    Converter converter(o);
    converter.run();
    EXPECT_EQ(converter.summary().mode, ConvertSummary::Mode::signals);
    EXPECT_EQ(read(out).rfind("t,can_id,message,signal,raw,value\n", 0), 0u);
    EXPECT_NO_THROW(converter.require_rows());  // signal rows: no cycle needed
  }
  // A boundary id that never comes: frames but no cycle.
  ConvertOptions none = log_options(out);
  none.sync = "7ff";
  Converter empty(none);
  empty.run();
  EXPECT_THROW(empty.require_rows(), momentum::Error);
  fs::remove(out);
}
