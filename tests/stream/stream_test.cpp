// Sample streams: exact round trips between the encodings, and every kind of bad input
// reported with its place, skipped by default and fatal in strict mode.
#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>
#include <random>
#include <sstream>

#include "momentum/core/error.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/stats.hpp"
#include "momentum/stream/writer.hpp"

namespace ms = momentum::stream;

namespace {

std::string temp_path(const std::string& name) {
  return ::testing::TempDir() + "/momentum_stream_" + std::to_string(::getpid()) + "_" + name;
}

void write_file(const std::string& path, const std::string& content) {
  std::ofstream(path, std::ios::binary) << content;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Collects warnings instead of printing them.
struct CapturedWarnings {
  std::vector<std::string> messages;
  momentum::WarningSink previous;
  CapturedWarnings() {
    previous = momentum::set_warning_sink([this](std::string_view m) { messages.emplace_back(m); });
  }
  ~CapturedWarnings() { momentum::set_warning_sink(previous); }
};

std::vector<std::vector<double>> read_all(ms::Reader& reader) {
  std::vector<std::vector<double>> rows;
  while (const double* row = reader.next()) rows.emplace_back(row, row + reader.columns().size());
  return rows;
}

void copy(const std::string& from, const std::string& to, ms::Encoding encoding) {
  auto in = ms::Reader::open(from);
  auto out = ms::Writer::open(to, {encoding, false});
  for (const auto& c : in->leading_comments()) out->comment(c);
  out->header(in->columns());
  in->on_comment([&](std::string_view c) { out->comment(c); });
  while (const double* row = in->next()) out->row(row);
  out->close();
}

std::vector<double> special_values() {
  return {0.0, -0.0, 1.0, -1.5, 0.1, 1.0 / 3.0, 1e308, -1e308, 1.7976931348623157e308,
          5e-324, -5e-324, 2.2250738585072014e-308, 2.225073858507201e-308 /* subnormal */,
          std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::quiet_NaN(), -std::numeric_limits<double>::quiet_NaN(),
          123456789012345678.0, 9007199254740993.0, 6.02214076e23};
}

}  // namespace

TEST(Stream, CsvBinaryCsvIsBitExactForEveryKindOfDouble) {
  std::vector<double> values = special_values();
  std::mt19937_64 rng(42);
  for (int i = 0; i < 2000; ++i) {
    std::uint64_t bits = rng();
    double v;
    std::memcpy(&v, &bits, 8);
    if (!std::isnan(v)) values.push_back(v);  // NaN payloads do not survive text; signs do
  }
  std::string csv = temp_path("exact.csv"), bin = temp_path("exact.bin"), csv2 = temp_path("exact2.csv");
  {
    auto out = ms::Writer::open(csv);
    out->comment(" made by the test");
    out->header({"t", "x"});
    for (std::size_t i = 0; i < values.size(); ++i) {
      double row[2] = {double(i), values[i]};
      out->row(row);
      if (i == 3) out->comment(" in the middle");
    }
    out->close();
  }
  copy(csv, bin, ms::Encoding::binary);
  copy(bin, csv2, ms::Encoding::csv);
  EXPECT_EQ(read_file(csv), read_file(csv2));
  auto in = ms::Reader::open(bin);
  EXPECT_EQ(in->encoding(), ms::Encoding::binary);
  std::vector<std::string> comments;
  in->on_comment([&](std::string_view c) { comments.emplace_back(c); });
  auto rows = read_all(*in);
  ASSERT_EQ(rows.size(), values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (std::isnan(values[i])) {
      EXPECT_TRUE(std::isnan(rows[i][1]));
      EXPECT_EQ(std::signbit(values[i]), std::signbit(rows[i][1]));
    } else {
      EXPECT_EQ(std::bit_cast<std::uint64_t>(values[i]), std::bit_cast<std::uint64_t>(rows[i][1])) << i;
    }
  }
  EXPECT_EQ(comments, std::vector<std::string>{" in the middle"});
  EXPECT_EQ(in->leading_comments(), std::vector<std::string>{" made by the test"});
}

TEST(Stream, BinaryRowWhoseFirstValueLooksLikeACommentMarkerIsWrittenAsNaN) {
  std::string bin = temp_path("marker.bin");
  {
    auto out = ms::Writer::open(bin, {ms::Encoding::binary, false});
    out->header({"a", "b"});
    double row[2] = {std::bit_cast<double>(ms::kCommentRecordBits), 2.0};
    out->row(row);
    out->close();
  }
  auto in = ms::Reader::open(bin);
  auto rows = read_all(*in);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_TRUE(std::isnan(rows[0][0]));
  EXPECT_EQ(rows[0][1], 2.0);
}

TEST(Stream, BadRowsAreReportedWithTheirLineAndSkipped) {
  CapturedWarnings warnings;
  std::string path = temp_path("bad.csv");
  write_file(path, "# c\nt,q1\n0,1\n0.1,x\n0.2\n0.3,1,2\n\n0.4,+4\n0.5, 5 \r\n");
  auto in = ms::Reader::open(path);
  auto rows = read_all(*in);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[1][1], 4.0);
  EXPECT_EQ(rows[2][1], 5.0);
  EXPECT_EQ(in->rows_skipped(), 3u);
  ASSERT_EQ(warnings.messages.size(), 3u);
  EXPECT_EQ(warnings.messages[0], path + ":4: bad number 'x' in column 'q1'");
  EXPECT_EQ(warnings.messages[1], path + ":5: expected 2 fields, got 1");
  EXPECT_EQ(warnings.messages[2], path + ":6: expected 2 fields, got 3");
}

// rows_skipped() runs ahead of the rows returned while the time-order policy holds rows (at
// the start, and around a time that does not fit); rows_skipped_before() says how many lay
// before each row returned, so that mo-detect can tell between which two rows they were.
TEST(Stream, RowsSkippedBeforeEachRowFollowTheInputOrder) {
  CapturedWarnings warnings;
  std::string path = temp_path("skipped-before.csv");
  // Line 4 a bad number, line 7 a wild time, lines 9 and 10 bad, line 12 a cut last row.
  write_file(path, "t,q1\n0,1\n0.01,1\n0.02,x\n0.03,1\n0.04,1\n99,1\n0.05,1\nbad\nbad\n0.06,1\n0.07");
  auto in = ms::Reader::open(path);
  std::vector<std::pair<double, std::uint64_t>> seen;
  while (const double* row = in->next()) seen.emplace_back(row[0], in->rows_skipped_before());
  const std::vector<std::pair<double, std::uint64_t>> expected = {
      {0, 0}, {0.01, 0}, {0.03, 1}, {0.04, 1}, {0.05, 2}, {0.06, 4}};
  EXPECT_EQ(seen, expected);
  EXPECT_EQ(in->rows_skipped(), 5u);
  EXPECT_EQ(in->rows_skipped_before(), 5u);  // at the end, the cut last row too
}

TEST(Stream, StrictModeStopsAtTheFirstBadRow) {
  std::string path = temp_path("strict.csv");
  write_file(path, "t,q1\n0,1\n0.1,nanx\n0.2,3\n");
  ms::ReaderOptions options;
  options.strict = true;
  auto in = ms::Reader::open(path, options);
  try {
    // The time policy compares the first rows before returning them, so the error may come
    // with the first call.
    in->next();
    in->next();
    FAIL() << "no error";
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()), path + ":3: bad number 'nanx' in column 'q1'");
  }
}

TEST(Stream, HeaderErrorsNameTheFile) {
  auto expect_error = [](const std::string& content, const std::string& fragment) {
    std::string path = temp_path("header.csv");
    write_file(path, content);
    try {
      ms::Reader::open(path);
      ADD_FAILURE() << "no error for " << fragment;
    } catch (const momentum::Error& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind(path, 0), 0u) << e.what();
    }
  };
  expect_error("", "empty input");
  expect_error("# only a comment\n", "no header line");
  expect_error("t,q1,t\n", "duplicate column name 't'");
  expect_error("t,,q1\n", "empty column name (column 2)");
  expect_error(std::string("\x89MOLOX\r\n", 8), "wrong magic");
  std::string wrong_version("\x89MOLOG\r\n\x07\0\0\0", 12);
  expect_error(wrong_version, "unsupported binary version 7");
  std::string cut_header("\x89MOLOG\r\n\x01\0\0\0\x02\0\0\0", 16);
  expect_error(cut_header, "truncated header");
}

TEST(Stream, TruncatedBinaryRecordIsReportedWithItsByteOffset) {
  CapturedWarnings warnings;
  std::string bin = temp_path("cut.bin");
  {
    auto out = ms::Writer::open(bin, {ms::Encoding::binary, false});
    out->header({"t", "q1"});
    double row[2] = {0, 1};
    out->row(row);
    out->row(row);
    out->close();
  }
  std::string bytes = read_file(bin);
  write_file(bin, bytes.substr(0, bytes.size() - 3));
  auto in = ms::Reader::open(bin);
  auto rows = read_all(*in);
  EXPECT_EQ(rows.size(), 1u);
  ASSERT_EQ(warnings.messages.size(), 1u);
  std::size_t header_size = bytes.size() - 32;
  EXPECT_EQ(warnings.messages[0],
            bin + ": byte " + std::to_string(header_size + 16) + ": truncated record (13 of 16 bytes)");
}

TEST(Stream, MissingColumnIsAnErrorNamingIt) {
  std::string path = temp_path("cols.csv");
  write_file(path, "t,q1\n0,1\n");
  auto in = ms::Reader::open(path);
  EXPECT_EQ(in->require("q1"), 1u);
  try {
    in->require("dq1");
    FAIL();
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()), path + ": missing column 'dq1'");
  }
}

TEST(Stream, HeaderlessCsvTakesNamesAndDropsUnderscoreColumns) {
  std::string path = temp_path("vendor.csv");
  write_file(path, "1,2,3\n4,5,6\n");
  ms::ReaderOptions options;
  options.names = {"t", "_", "q1"};
  auto in = ms::Reader::open(path, options);
  EXPECT_EQ(in->columns(), (std::vector<std::string>{"t", "q1"}));
  auto rows = read_all(*in);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0], (std::vector<double>{1, 3}));
  EXPECT_EQ(rows[1], (std::vector<double>{4, 6}));
}

TEST(Stream, RowsArriveFromAPipeBeforeItCloses) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  int saved = ::dup(0);
  ::dup2(fds[0], 0);
  ::close(fds[0]);
  // The time policy decides the start on the first three rows; after them every regular row
  // comes out as soon as its line is complete.
  const char first[] = "t,q1\n0,1\n0.1,2\n0.2,3\n";
  ASSERT_EQ(::write(fds[1], first, sizeof first - 1), ssize_t(sizeof first - 1));
  auto in = ms::Reader::open("-");
  EXPECT_TRUE(in->live());
  for (double q : {1.0, 2.0, 3.0}) {
    const double* row = in->next();  // must not wait for end of input
    ASSERT_NE(row, nullptr);
    EXPECT_EQ(row[1], q);
  }
  const char next[] = "0.3,4\n";
  ASSERT_EQ(::write(fds[1], next, sizeof next - 1), ssize_t(sizeof next - 1));
  const double* row = in->next();
  ASSERT_NE(row, nullptr);
  EXPECT_EQ(row[1], 4.0);
  ::close(fds[1]);
  EXPECT_EQ(in->next(), nullptr);
  ::dup2(saved, 0);
  ::close(saved);
}

TEST(Stream, LongStreamsUseABoundedBuffer) {
  // A line longer than the initial window still parses (the window grows to the line), and
  // many lines do not grow it: the reader keeps no rows.
  std::string path = temp_path("long.csv");
  {
    std::ofstream out(path);
    out << "t";
    for (int i = 0; i < 40000; ++i) out << ",c" << i;
    out << "\n";
    for (int r = 0; r < 3; ++r) {
      out << r;
      for (int i = 0; i < 40000; ++i) out << ",0.123456789012345";
      out << "\n";
    }
  }
  auto in = ms::Reader::open(path);
  EXPECT_EQ(in->columns().size(), 40001u);
  EXPECT_EQ(read_all(*in).size(), 3u);
}

TEST(Columns, RangesExpandAndMissingColumnsAreNamed) {
  EXPECT_EQ(ms::expand_column_list("t,q1-3,tau_m2"),
            (std::vector<std::string>{"t", "q1", "q2", "q3", "tau_m2"}));
  EXPECT_THROW(ms::expand_column_list("q3-1"), momentum::Error);
  EXPECT_THROW(ms::expand_column_list("t,,q1"), momentum::Error);
  EXPECT_EQ(ms::count_joint_columns({"t", "q1", "q2", "dq1"}, "q"), 2u);
}

TEST(Stats, CountsGapsBackwardsDuplicatesFrozenAndNaN) {
  ms::StreamStats stats({"t", "q1"});
  auto add = [&](double t, double q, int line) {
    double row[2] = {t, q};
    stats.add(row, "f:" + std::to_string(line));
  };
  int line = 2;
  double t = 0;
  for (int i = 0; i < 100; ++i, t += 0.001) add(t, i, line++);  // regular 1 ms
  add(t + 0.004, 1000, line++);                                 // gap of 5 periods
  add(t + 0.0035, 1001, line++);                                // backwards
  add(t + 0.0035, 1001, line++);                                // exact duplicate
  for (int i = 0; i < 12; ++i) add(t + 0.005 + 0.001 * i, 7, line++);  // frozen
  add(t + 0.02, std::nan(""), line++);
  auto s = stats.summary();
  EXPECT_EQ(s.rows, 116u);
  EXPECT_DOUBLE_EQ(s.dt_median, 0.001);
  EXPECT_EQ(s.gaps.count, 2u);  // the 5-period gap and the last step (1.5 periods is no gap)
  EXPECT_EQ(s.gaps.first.front(), "f:102");
  EXPECT_EQ(s.backwards.count, 1u);
  EXPECT_EQ(s.backwards.first.front(), "f:103");
  EXPECT_EQ(s.duplicates.count, 1u);
  EXPECT_EQ(s.frozen.count, 1u);
  EXPECT_EQ(s.nan_per_column[1], 1u);
}

TEST(Stats, AGapJustAboveTheLimitIsCountedWhereItIsListed) {
  // 1 ms steps and one of 1.502 ms: above 1.5 periods, in the histogram bin that straddles
  // the limit. Once with few distinct steps (exact counts), once with thousands (jittered
  // by less than 5%, so the histogram decides), and the count must agree with the places.
  for (bool jitter : {false, true}) {
    ms::StreamStats stats({"t"});
    double t = 0;
    int line = 2;
    for (int i = 0; i < 6000; ++i) {
      t += i == 3000 ? 1.502e-3 : 1e-3 * (jitter ? 1 + 0.04 * std::sin(0.37 * i) : 1.0);
      stats.add(&t, "f:" + std::to_string(line++));
    }
    const auto s = stats.summary();
    EXPECT_EQ(s.gaps.count, 1u) << "jitter " << jitter;
    ASSERT_EQ(s.gaps.first.size(), 1u);
    EXPECT_EQ(s.gaps.first.front(), "f:3002");
    EXPECT_EQ(s.irregular, 0u) << "jitter " << jitter;  // 4% is within the 10% band
  }
}

TEST(Stats, IrregularStepsAreCountedButGapsAreNot) {
  ms::StreamStats stats({"t"});
  double t = 0;
  for (int i = 0; i < 100; ++i) {
    // 90 steps of 1 ms, 5 of 0.8 ms, 3 of 1.3 ms, 2 of 3 ms (gaps).
    t += i < 90 ? 1e-3 : i < 95 ? 0.8e-3 : i < 98 ? 1.3e-3 : 3e-3;
    stats.add(&t, "x");
  }
  const auto s = stats.summary();
  EXPECT_EQ(s.irregular, 8u);
  EXPECT_EQ(s.gaps.count, 2u);
}


TEST(Writer, AnOutputThatCannotBeOpenedIsAnErrorNotACrash) {
  // The writer used to close an output it never opened (SIGSEGV) when the path failed.
  const std::string missing = temp_path("no-such-folder") + "/out.csv";
  const std::string folder = ::testing::TempDir();
  for (const std::string& path : {missing, folder}) {
    for (auto encoding : {ms::Encoding::csv, ms::Encoding::binary}) {
      ms::WriterOptions options;
      options.encoding = encoding;
      try {
        auto writer = ms::Writer::open(path, options);
        ADD_FAILURE() << "opened " << path;
      } catch (const momentum::Error& e) {
        EXPECT_EQ(std::string(e.what()).rfind(path + ": cannot create: ", 0), 0u) << e.what();
      }
    }
  }
}

TEST(Writer, AnOutputThatIsTheInputBeingReadIsRefusedAndTheInputKept) {
  const std::string path = temp_path("same.csv");
  write_file(path, "t,q1\n0,1\n1,2\n");
  {
    auto in = ms::Reader::open(path);
    try {
      auto out = ms::Writer::open(path);
      ADD_FAILURE() << "the input was opened as the output";
    } catch (const momentum::Error& e) {
      EXPECT_EQ(std::string(e.what()), path + ": is also an input (" + path + "); not overwritten");
    }
    EXPECT_NE(in->next(), nullptr);
  }
  EXPECT_EQ(read_file(path), "t,q1\n0,1\n1,2\n");
  std::remove(path.c_str());
}

// A list expands to at most kMaxListedColumns names, checked before expanding: "q1-20000000"
// once took a gigabyte before "missing column". A column listed twice is found.
TEST(Columns, ListsAreBoundedAndDuplicatesFound) {
  EXPECT_EQ(ms::expand_column_list("q1-65536").size(), ms::kMaxListedColumns);
  EXPECT_THROW(ms::expand_column_list("t,q1-65536"), momentum::Error);
  try {
    ms::expand_column_list("q1-20000000");
    FAIL();
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()), "range 'q1-20000000' in column list is too long (a list names at most 65536 columns)");
  }
  // Plain names count too: 65,536 of them pass, one more does not.
  std::string many = "c0";
  for (std::size_t i = 1; i < ms::kMaxListedColumns; ++i) many += ",c" + std::to_string(i);
  EXPECT_EQ(ms::expand_column_list(many).size(), ms::kMaxListedColumns);
  EXPECT_THROW(ms::expand_column_list(many + ",x"), momentum::Error);

  EXPECT_EQ(ms::first_duplicate({"t", "q1", "q2"}), std::nullopt);
  EXPECT_EQ(ms::first_duplicate({"t", "q1", "t", "q1"}), std::optional<std::string>("t"));
}

// Text from a binary stream (or any caller) written as CSV cannot become a data row, a header
// or another column order: a comment's line breaks start new comment lines, and a column name
// that holds a separator, a quote or a leading '#' or 0x89 is quoted.
TEST(Stream, CommentsAndNamesCannotBecomeRowsOrHeadersInCsv) {
  const std::string bin = temp_path("inject.bin"), csv = temp_path("inject.csv");
  const std::vector<std::string> names = {"t", "q,1", "#x", "say \"hi\"", " pad", "a;b"};
  {
    auto out = ms::Writer::open(bin, {ms::Encoding::binary, false});
    out->comment("header comment\nq1,t\r\n9,9");  // would have replaced the header
    out->header(names);
    const double row[6] = {0, 1, 2, 3, 4, 5};
    out->row(row);
    out->comment("row comment\n7,7,7,7,7,7\rlast");  // would have been a data row
    const double row2[6] = {1, 1, 2, 3, 4, 5};
    out->row(row2);
    out->close();
  }
  {
    ms::ReaderOptions as_written;
    as_written.time_order = false;  // comments in place between the rows
    auto in = ms::Reader::open(bin, as_written);
    auto out = ms::Writer::open(csv, {ms::Encoding::csv, false});
    for (const auto& c : in->leading_comments()) out->comment(c);
    out->header(in->columns());
    in->on_comment([&](std::string_view c) { out->comment(c); });
    while (const double* row = in->next()) out->row(row);
    out->close();
  }
  EXPECT_EQ(read_file(csv),
            "#header comment\n#q1,t\n#9,9\n"
            "t,\"q,1\",\"#x\",\"say \"\"hi\"\"\",\" pad\",\"a;b\"\n"
            "0,1,2,3,4,5\n"
            "#row comment\n#7,7,7,7,7,7\n#last\n"
            "1,1,2,3,4,5\n");
  ms::ReaderOptions as_written;
  as_written.time_order = false;
  auto in = ms::Reader::open(csv, as_written);
  EXPECT_EQ(in->columns(), names);
  EXPECT_EQ(in->leading_comments(), (std::vector<std::string>{"header comment", "q1,t", "9,9"}));
  std::vector<std::string> comments;
  in->on_comment([&](std::string_view c) { comments.emplace_back(c); });
  auto rows = read_all(*in);
  EXPECT_EQ(rows, (std::vector<std::vector<double>>{{0, 1, 2, 3, 4, 5}, {1, 1, 2, 3, 4, 5}}));
  EXPECT_EQ(comments, (std::vector<std::string>{"row comment", "7,7,7,7,7,7", "last"}));
  EXPECT_EQ(in->rows_skipped(), 0u);

  // A first name that starts with byte 0x89 would make the file's first byte the binary
  // encodings' (found by fuzzing: "\x89MCAP" read back as a broken bag): quoted, it reads back.
  {
    const std::string first = temp_path("first-byte.csv");
    const std::vector<std::string> magic = {"\x89MCAP", "\x89MOLOG"};
    auto out = ms::Writer::open(first, {ms::Encoding::csv, false});
    out->header(magic);
    const double row[2] = {1, 2};
    out->row(row);
    out->close();
    EXPECT_EQ(read_file(first), "\"\x89MCAP\",\"\x89MOLOG\"\n1,2\n");
    auto back = ms::Reader::open(first, as_written);
    EXPECT_EQ(back->columns(), magic);
    EXPECT_EQ(read_all(*back), (std::vector<std::vector<double>>{{1, 2}}));
  }

  // A name with a line break cannot be a CSV header field at all: refused, naming it.
  auto out = ms::Writer::open(temp_path("refused.csv"), {ms::Encoding::csv, false});
  try {
    out->header({"t", "q1\nevil"});
    FAIL();
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()), temp_path("refused.csv") + ": column 2 name 'q1\\x0Aevil' holds a control character, which a CSV header cannot") << e.what();
  }
}

// The separator is detected from the header: comma, semicolon, tab or blanks; fields may be
// quoted in the header and in rows. A semicolon-separated export once gave "missing column 't'".
TEST(Stream, SeparatorIsDetectedAndQuotedFieldsRead) {
  CapturedWarnings warnings;
  const std::vector<std::pair<std::string, std::string>> files = {
      {"semicolon", "t;q1;\"dq 1\"\n0;1.5;-2\n0.5;\"2.5\";3e-3\n"},
      {"tab", "t\tq1\tdq 1\n0\t1.5\t-2\n0.5\t2.5\t3e-3\n"},
      {"blanks", "  t   q1  \"dq 1\"\n 0 1.5   -2\n0.5\t2.5 3e-3  \n"},
      {"quoted", "\"t\",\"q1\",\"dq 1\"\n\"0\",\"1.5\",\"-2\"\n0.5, 2.5 ,\"3e-3\"\n"},
      {"crlf", "t;q1;dq 1\r\n0;1.5;-2\r\n0.5;2.5;3e-3\r\n"},
  };
  for (const auto& [name, content] : files) {
    const std::string path = temp_path(name + ".csv");
    write_file(path, content);
    auto in = ms::Reader::open(path);
    EXPECT_EQ(in->columns(), (std::vector<std::string>{"t", "q1", "dq 1"})) << name;
    EXPECT_EQ(read_all(*in), (std::vector<std::vector<double>>{{0, 1.5, -2}, {0.5, 2.5, 3e-3}})) << name;
  }
  EXPECT_TRUE(warnings.messages.empty());

  // What cannot be read says what it saw: a decimal comma, a quote left open, a separator
  // that is none of the four.
  const std::string comma = temp_path("decimal_comma.csv");
  write_file(comma, "t;q1\n0;1,5\n0;\"1\n");
  auto in = ms::Reader::open(comma);
  EXPECT_TRUE(read_all(*in).empty());
  ASSERT_EQ(warnings.messages.size(), 2u);
  EXPECT_EQ(warnings.messages[0],
            comma + ":2: bad number '1,5' in column 'q1' (a decimal comma? numbers are read with a decimal point)");
  EXPECT_EQ(warnings.messages[1], comma + ":3: unterminated quote");
  const std::string pipe = temp_path("pipe.csv");
  write_file(pipe, "t|q1\n0|1\n");
  try {
    ms::Reader::open(pipe)->require("t");
    FAIL();
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()), pipe + ": missing column 't' (the header is one column, 't|q1': columns are "
                                            "separated by commas, semicolons, tabs or blanks)");
  }
  // Headerless input with --names: the separator of the first row.
  const std::string vendor = temp_path("vendor_semicolon.csv");
  write_file(vendor, "1;2;3\n4;5;6\n");
  ms::ReaderOptions options;
  options.names = {"t", "_", "q1"};
  auto named = ms::Reader::open(vendor, options);
  EXPECT_EQ(read_all(*named), (std::vector<std::vector<double>>{{1, 3}, {4, 6}}));
}

// Reader::peek: the rows after the one last returned that are already read, as next() returns
// them, without consuming them; never past a comment record or a partial record; nothing from
// CSV, or while the time-order policy holds rows.
TEST(Stream, PeekShowsTheRowsAlreadyReadWithoutTakingThem) {
  CapturedWarnings warnings;
  const std::string bin = temp_path("peek.bin");
  {
    auto out = ms::Writer::open(bin, {ms::Encoding::binary, false});
    out->header({"t", "q1"});
    for (int k = 0; k < 6; ++k) {
      // Row 3 goes back in time: the policy holds row 2 until it has seen row 4.
      const double row[2] = {k == 3 ? 0.5 : 0.01 * k, 10.0 + k};
      out->row(row);
      if (k == 4) out->comment("between rows 4 and 5");
    }
    out->close();
  }
  // Without the time-order policy: every row as written.
  {
    ms::ReaderOptions options;
    options.time_order = false;
    auto in = ms::Reader::open(bin, options);
    double ahead[3 * 2];
    ASSERT_NE(in->next(), nullptr);  // row 0
    ASSERT_EQ(in->peek(ahead, 3), 3u);
    EXPECT_EQ(ahead[0], 0.01);
    EXPECT_EQ(ahead[1], 11.0);
    EXPECT_EQ(ahead[4], 0.5);
    EXPECT_EQ(ahead[5], 13.0);
    EXPECT_EQ(in->peek(ahead, 1), 1u);  // no more than asked
    const double* row = in->next();      // peeking took nothing
    ASSERT_NE(row, nullptr);
    EXPECT_EQ(row[1], 11.0);
    ASSERT_NE(in->next(), nullptr);  // row 2
    ASSERT_NE(in->next(), nullptr);  // row 3
    EXPECT_EQ(in->peek(ahead, 3), 1u);  // row 4, then the comment record
    EXPECT_EQ(ahead[1], 14.0);
    ASSERT_NE(in->next(), nullptr);  // row 4
    EXPECT_EQ(in->peek(ahead, 3), 0u);  // the comment record comes first
    ASSERT_NE(in->next(), nullptr);  // row 5
    EXPECT_EQ(in->peek(ahead, 3), 0u);
    EXPECT_EQ(in->next(), nullptr);
    EXPECT_EQ(in->peek(ahead, 3), 0u);
  }
  // With it: nothing while it holds rows (the first two, until it knows the time line); row 3,
  // shown after row 2, is then dropped for its time: a hint, not a promise.
  {
    CapturedWarnings dropped;
    auto in = ms::Reader::open(bin);
    double ahead[3 * 2];
    std::vector<std::size_t> shown;
    std::vector<double> q;
    while (const double* row = in->next()) {
      q.push_back(row[1]);
      shown.push_back(in->peek(ahead, 3));
      if (row[1] == 12.0) {
        EXPECT_EQ(ahead[1], 13.0);
        EXPECT_EQ(ahead[3], 14.0);
      }
    }
    EXPECT_EQ(q, (std::vector<double>{10, 11, 12, 14, 15}));
    EXPECT_EQ(shown, (std::vector<std::size_t>{0, 0, 2, 0, 0}));
  }
  // A partial record at the end is not shown.
  {
    const std::string bytes = read_file(bin);
    const std::string cut = temp_path("peek_cut.bin");
    write_file(cut, bytes.substr(0, bytes.size() - 3));
    ms::ReaderOptions options;
    options.time_order = false;
    auto in = ms::Reader::open(cut, options);
    double ahead[3 * 2];
    for (int k = 0; k < 5; ++k) ASSERT_NE(in->next(), nullptr);
    EXPECT_EQ(in->peek(ahead, 3), 0u);  // the comment, then 13 of 16 bytes
  }
  // CSV: nothing.
  {
    const std::string csv = temp_path("peek.csv");
    write_file(csv, "t,q1\n0,1\n0.01,2\n0.02,3\n");
    auto in = ms::Reader::open(csv);
    double ahead[3 * 2];
    ASSERT_NE(in->next(), nullptr);
    EXPECT_EQ(in->peek(ahead, 3), 0u);
  }
}
