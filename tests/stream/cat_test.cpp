// mo-cat's driver: columns selected and scaled, t shifted, inputs concatenated, --head, the
// --stats reports, and the errors it owes the user.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "momentum/stream/cat.hpp"

namespace fs = std::filesystem;
namespace ms = momentum::stream;

namespace {

struct Files {
  fs::path dir;
  Files() {
    dir = fs::path(::testing::TempDir()) / ("momentum_cat_" + std::to_string(::getpid()) + "_" +
                                             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~Files() { fs::remove_all(dir); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(dir / name, std::ios::binary) << text;
    return (dir / name).string();
  }
  std::string read(const std::string& name) const {
    std::ifstream in(dir / name, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
};

ms::CatResult run(const ms::CatOptions& options, const std::string& output) {
  return ms::cat(
      options, [](const std::string& path, const ms::ReaderOptions& o) { return ms::Reader::open(path, o); },
      [&](ms::Reader&) { return ms::Writer::open(output); });
}

}  // namespace

TEST(Cat, SelectsScalesShiftsAndConcatenates) {
  Files f;
  const std::string a = f.write("a.csv", "t,q1,q2\n10,1,2\n11,3,4\n");
  const std::string b = f.write("b.csv", "t,q1,q2\n12,5,6\n");
  ms::CatOptions o;
  o.inputs = {a, b};
  o.columns = "q2,t";
  o.scales = {"q2=2"};
  o.zero_time = true;
  const auto result = run(o, (f.dir / "out.csv").string());
  EXPECT_EQ(result.rows, 3u);
  EXPECT_TRUE(result.report.empty());
  EXPECT_EQ(f.read("out.csv"), "q2,t\n4,0\n8,1\n12,2\n");
}

TEST(Cat, HeadStopsAndStatsDescribe) {
  Files f;
  const std::string a = f.write("a.csv", "t,q1\n0,1\n0.5,2\n1,3\n");
  ms::CatOptions o;
  o.inputs = {a};
  o.head = 2;
  EXPECT_EQ(run(o, (f.dir / "out.csv").string()).rows, 2u);
  EXPECT_EQ(f.read("out.csv"), "t,q1\n0,1\n0.5,2\n");
  o.head.reset();
  o.stats = ms::CatOptions::Stats::jsonl;
  const auto result = run(o, (f.dir / "unused.csv").string());
  EXPECT_FALSE(fs::exists(f.dir / "unused.csv"));  // describing writes no stream
  EXPECT_NE(result.report.find("\"rows\":3"), std::string::npos) << result.report;
  EXPECT_EQ(result.report.back(), '\n');
  o.stats = ms::CatOptions::Stats::text;
  EXPECT_EQ(run(o, "").report.rfind("rows        3\n", 0), 0u);
}

TEST(Cat, NamesTheProblems) {
  Files f;
  const std::string a = f.write("a.csv", "t,q1\n0,1\n");
  const std::string other = f.write("other.csv", "t,q2\n0,1\n");
  const std::string headerless = f.write("h.csv", "0,1\n1,2\n");
  ms::CatOptions o;
  o.inputs = {a, other};
  EXPECT_THROW(run(o, (f.dir / "out.csv").string()), momentum::Error);
  o.inputs = {a};
  o.scales = {"q9=2"};
  EXPECT_THROW(run(o, (f.dir / "out.csv").string()), ms::OptionError);
  o.scales.clear();
  o.inputs = {headerless};
  EXPECT_THROW(run(o, (f.dir / "out.csv").string()), momentum::Error);
  o.names = {"t", "q1"};
  EXPECT_EQ(run(o, (f.dir / "out.csv").string()).rows, 2u);
}
