// Every reference capture (tests/data/can/*.log, random frames for every message of a DBC
// file from cantools' test suite) decodes to cantools 45.1's result (*.expected.csv): integers
// exactly, floats to 1e-12 relative, and the same signals in the same order.

#include <gtest/gtest.h>

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "momentum/can/candump.hpp"
#include "momentum/can/codec.hpp"
#include "momentum/can/dbc.hpp"

namespace fs = std::filesystem;
using namespace momentum::can;

namespace {

struct Row {
  std::string t, id, message, signal, raw, phys;
};

std::vector<Row> read_expected(const fs::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "t,can_id,message,signal,raw,phys");
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string field;
    while (std::getline(ss, field, ',')) f.push_back(field);
    EXPECT_EQ(f.size(), 6U) << line;
    if (f.size() == 6) rows.push_back({f[0], f[1], f[2], f[3], f[4], f[5]});
  }
  return rows;
}

bool is_integer_text(const std::string& s) {
  return s.find_first_of(".eEn") == std::string::npos;
}

// Compares a number printed by us with one printed by Python: integers exactly, floats to
// 1e-12 relative.
void expect_number(const std::string& ours, const std::string& theirs, const std::string& what) {
  if (is_integer_text(theirs)) {
    EXPECT_EQ(ours, theirs) << what;
    return;
  }
  const double a = std::stod(ours), b = std::stod(theirs);
  if (b == 0) {
    EXPECT_EQ(a, 0.0) << what;
  } else {
    EXPECT_LE(std::abs(a - b), 1e-12 * std::abs(b)) << what << ": " << ours << " vs " << theirs;
  }
}

std::string format_time(std::int64_t ns) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%lld.%06lld", static_cast<long long>(ns / 1000000000),
                static_cast<long long>((ns % 1000000000) / 1000));
  return buf;
}

std::vector<std::string> reference_names() {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(fs::path(MOMENTUM_TEST_DATA) / "can"))
    if (entry.path().extension() == ".dbc" && fs::exists(fs::path(entry.path()).replace_extension(".log")))
      names.push_back(entry.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

class Reference : public ::testing::TestWithParam<std::string> {};

TEST_P(Reference, DecodesLikeCantools) {
  const fs::path dir = fs::path(MOMENTUM_TEST_DATA) / "can";
  const std::string name = GetParam();
  const Database db = Database::load((dir / (name + ".dbc")).string());
  const std::vector<Row> expected = read_expected(dir / (name + ".expected.csv"));
  ASSERT_FALSE(expected.empty());
  auto reader = CandumpReader::open((dir / (name + ".log")).string());
  Frame frame;
  std::vector<SignalValue> values(512);
  std::size_t at = 0;
  while (reader->next(frame)) {
    const Message* m = db.find(frame.key());
    ASSERT_NE(m, nullptr) << reader->where();
    bool truncated = false;
    const std::size_t n = decode(*m, frame, values.data(), &truncated);
    EXPECT_FALSE(truncated);
    char id[8];
    const std::string id_text(id, format_id(frame, id));
    for (std::size_t k = 0; k < n; ++k, ++at) {
      ASSERT_LT(at, expected.size()) << reader->where() << ": more signals than cantools decoded";
      const Row& row = expected[at];
      const Signal& s = m->signals[values[k].index];
      const std::string where = reader->where() + " " + s.name;
      EXPECT_EQ(format_time(frame.time_ns), row.t) << where;
      EXPECT_EQ(id_text, row.id) << where;
      EXPECT_EQ(m->name, row.message) << where;
      EXPECT_EQ(s.name, row.signal) << where;
      char raw[48], phys[48];
      expect_number(std::string(raw, format_raw(s, values[k].bits, raw)), row.raw, where + " raw");
      expect_number(std::string(phys, format_physical(s, values[k].bits, phys)), row.phys, where + " phys");
      // The double the stream carries: cantools' value to 1e-12 (integers beyond 2^53 are
      // compared exactly as text above; as doubles they round).
      const double b = std::stod(row.phys);
      if (!is_integer_text(row.phys) || std::abs(b) < 0x1p53) {
        if (b == 0) {
          EXPECT_EQ(values[k].value, 0.0) << where << " double value";
        } else {
          EXPECT_LE(std::abs(values[k].value - b), 1e-12 * std::abs(b)) << where << " double value";
        }
      }
    }
  }
  EXPECT_EQ(at, expected.size()) << "fewer signals than cantools decoded";
  EXPECT_EQ(reader->stats().bad_lines, 0U);
}

INSTANTIATE_TEST_SUITE_P(CantoolsReference, Reference, ::testing::ValuesIn(reference_names()),
                         [](const auto& info) { return info.param; });

TEST(Reference, AllTenCapturesPresent) { EXPECT_EQ(reference_names().size(), 10U); }

}  // namespace
