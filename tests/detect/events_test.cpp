// The event CSV format: exact round trip through the writer and the reader, the documented
// header, and clear errors on damaged files.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "momentum/core/error.hpp"
#include "momentum/detect/events.hpp"

using namespace momentum::detect;

namespace {

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("momentum_events_" + std::to_string(::getpid()) + "_" + name)).string();
}

void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

Event sample(std::uint64_t id, EventKind kind) {
  Event e;
  e.id = id;
  e.kind = kind;
  e.t_onset_estimate = 7.104 + 0.1 / 3;  // not short in decimal: must still round-trip
  e.t_detect = 7.184;
  e.link = kind == EventKind::onset ? 2 : 3;
  e.joints = kind == EventKind::onset ? std::vector<int>{1, 2} : std::vector<int>{1, 2, 3};
  e.t_end = kind == EventKind::end ? 7.9 : NAN;
  e.ended_by = kind == EventKind::end ? EndReason::release : EndReason::none;
  e.peaks = {8.31, 9.12 + 1e-13, 0.52};
  return e;
}

}  // namespace

TEST(Events, HeaderAndLinesAsDocumented) {
  EXPECT_EQ(event_header(3), "t_onset_estimate,t_detect,link,joints,kind,event,t_end,ended_by,peak1,peak2,peak3");
  Event e = sample(1, EventKind::onset);
  e.t_onset_estimate = 7.104;
  e.peaks = {8.31, 9.12, 0.52};
  EXPECT_EQ(format_event(e), "7.104,7.184,2,1;2,onset,1,,,8.31,9.12,0.52");
  Event end = sample(1, EventKind::end);
  end.t_onset_estimate = 7.104;
  end.peaks = {12.1, 15.03, 8.2};
  EXPECT_EQ(format_event(end), "7.104,7.184,3,1;2;3,end,1,7.9,release,12.1,15.03,8.2");
}

TEST(Events, WriterReaderRoundTripIsExact) {
  const std::string path = temp_path("roundtrip.csv");
  {
    EventWriter w(path, 3, {" mo-detect test", " second comment"});
    w.write(sample(1, EventKind::onset));
    w.write(sample(1, EventKind::end));
    Event eof = sample(2, EventKind::end);
    eof.ended_by = EndReason::eof;
    w.write(sample(2, EventKind::onset));
    w.write(eof);
    EXPECT_EQ(w.rows_written(), 4u);
    Event wrong = sample(3, EventKind::onset);
    wrong.peaks.pop_back();
    EXPECT_THROW(w.write(wrong), momentum::Error);
  }
  auto r = EventReader::open(path);
  EXPECT_EQ(r->joints(), 3u);
  ASSERT_EQ(r->comments().size(), 2u);
  EXPECT_EQ(r->comments()[0], " mo-detect test");
  const Event expect[] = {sample(1, EventKind::onset), sample(1, EventKind::end), sample(2, EventKind::onset)};
  for (const Event& x : expect) {
    auto e = r->next();
    ASSERT_TRUE(e);
    EXPECT_EQ(e->id, x.id);
    EXPECT_EQ(e->kind, x.kind);
    EXPECT_EQ(e->t_onset_estimate, x.t_onset_estimate);  // bit for bit
    EXPECT_EQ(e->t_detect, x.t_detect);
    EXPECT_EQ(e->link, x.link);
    EXPECT_EQ(e->joints, x.joints);
    EXPECT_EQ(e->peaks, x.peaks);
    EXPECT_EQ(e->ended_by, x.ended_by);
    if (x.kind == EventKind::end) EXPECT_EQ(e->t_end, x.t_end);
    else EXPECT_TRUE(std::isnan(e->t_end));
  }
  auto last = r->next();
  ASSERT_TRUE(last);
  EXPECT_EQ(last->ended_by, EndReason::eof);
  EXPECT_FALSE(r->next());

  const auto events = read_events(path);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].kind, EventKind::end);
  EXPECT_EQ(events[0].link, 3);
  EXPECT_EQ(events[1].ended_by, EndReason::eof);
  std::remove(path.c_str());
}

TEST(Events, CutShortFileKeepsTheOpenEvent) {
  const std::string path = temp_path("cut.csv");
  write_text(path, "t_onset_estimate,t_detect,link,joints,kind,event,t_end,ended_by,peak1\n1,1.5,1,1,onset,1,,,3\n");
  const auto events = read_events(path);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].ended_by, EndReason::none);
  EXPECT_TRUE(std::isnan(events[0].t_end));
  std::remove(path.c_str());
}

// mo-detect writes the identification at detection in a row of its own after the onset row:
// read as kind identified; read_events gives a cut-short event its link and contact.
TEST(Events, IdentifiedRowReadsAndCompletesAnOpenEvent) {
  const std::string path = temp_path("identified.csv");
  {
    EventWriter w(path, 3, {}, /*contact=*/true);
    w.write(sample(1, EventKind::onset));
    Event identified = sample(1, EventKind::identified);
    identified.link = 2;
    identified.contact.force = 41.5;
    identified.contact.seen = "force";
    w.write(identified);
  }
  auto r = EventReader::open(path);
  ASSERT_TRUE(r->next());
  const auto e = r->next();
  ASSERT_TRUE(e);
  EXPECT_EQ(e->kind, EventKind::identified);
  EXPECT_EQ(e->link, 2);
  EXPECT_EQ(e->joints, std::vector<int>({1, 2, 3}));
  EXPECT_TRUE(std::isnan(e->t_end));
  EXPECT_EQ(e->contact.force, 41.5);
  const auto events = read_events(path);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, EventKind::onset);
  EXPECT_EQ(events[0].ended_by, EndReason::none);
  EXPECT_EQ(events[0].link, 2);
  EXPECT_EQ(events[0].contact.force, 41.5);
  EXPECT_EQ(events[0].contact.seen, "force");
  std::remove(path.c_str());
}

TEST(Events, ExtraColumnsAndOtherOrderStillRead) {
  const std::string path = temp_path("extra.csv");
  write_text(path, "# c\nevent,kind,joints,link,t_detect,t_onset_estimate,note,peak1,peak2\n"
                   "1,onset,2,2,1.5,1.25,x,0,4\n");
  auto r = EventReader::open(path);
  auto e = r->next();
  ASSERT_TRUE(e);
  EXPECT_EQ(e->t_onset_estimate, 1.25);
  EXPECT_EQ(e->link, 2);
  EXPECT_EQ(e->peaks, std::vector<double>({0, 4}));
  std::remove(path.c_str());
}

TEST(Events, DamageIsAnErrorWithFileAndLine) {
  const std::string path = temp_path("bad.csv");
  const std::string head = "t_onset_estimate,t_detect,link,joints,kind,event,t_end,ended_by,peak1,peak2\n";
  struct Case {
    std::string row, message;
  };
  const Case cases[] = {
      {"1,2,1,1,onset,1,,,3\n", ":2: 9 fields, header has 10"},
      {"1,x,1,1,onset,1,,,3,4\n", ":2: bad t_detect 'x'"},
      {"1,2,3,1,onset,1,,,3,4\n", ":2: link 3 out of 1..2"},
      {"1,2,1,1;5,onset,1,,,3,4\n", ":2: joint 5 out of 1..2"},
      {"1,2,1,1,begin,1,,,3,4\n", ":2: bad kind 'begin' (onset, identified or end)"},
      {"1,2,1,,onset,1,,,3,4\n", ":2: no joints in an event"},
      {"1,2,1,1,end,1,3,later,3,4\n", ":2: bad ended_by 'later'"},
  };
  for (const auto& c : cases) {
    write_text(path, head + c.row);
    auto r = EventReader::open(path);
    try {
      r->next();
      ADD_FAILURE() << "no error for " << c.row;
    } catch (const momentum::Error& e) {
      EXPECT_EQ(std::string(e.what()), path + c.message);
    }
  }
  write_text(path, "t,mu1\n0,1\n");
  try {
    EventReader::open(path);
    ADD_FAILURE();
  } catch (const momentum::Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing column 't_onset_estimate'"), std::string::npos);
  }
  write_text(path, "# only a comment\n");
  EXPECT_THROW(EventReader::open(path), momentum::Error);
  EXPECT_THROW(EventReader::open(path + ".absent"), momentum::Error);
  std::remove(path.c_str());
}

TEST(Events, OtherDetectorsFilesReadWithTheirFewColumns) {
  const std::string path = temp_path("other.csv");
  // Spreadsheet quotes, kinds in any case, a kind the reader does not know, an empty link.
  write_text(path, "\"link\",score,\"t_detect\",kind\n2,0.9,10.1,ONSET\n3,0.5,20.2,heartbeat\n,0.1,30.3,onset\n");
  EXPECT_THROW(EventReader::open(path), momentum::Error);  // not mo-detect's format
  auto r = EventReader::open(path, {.other_detectors = true});
  auto e = r->next();
  ASSERT_TRUE(e);
  EXPECT_EQ(e->link, 2);
  EXPECT_EQ(e->t_detect, 10.1);
  EXPECT_EQ(e->id, 0u);
  EXPECT_TRUE(std::isnan(e->t_onset_estimate));
  EXPECT_TRUE(e->joints.empty());
  EXPECT_EQ(r->where(), path + ":2");
  e = r->next();  // the heartbeat row is skipped
  ASSERT_TRUE(e);
  EXPECT_EQ(e->link, 0);
  EXPECT_EQ(e->t_detect, 30.3);
  EXPECT_EQ(r->where(), path + ":4");
  EXPECT_FALSE(r->next());
  write_text(path, "t_detect,joints\n1,2\n");
  try {
    EventReader::open(path, {.other_detectors = true});
    ADD_FAILURE();
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()), path + ":1: event file needs columns t_detect and link (missing link)");
  }
  std::remove(path.c_str());
}

TEST(Events, DamagedRowsSkippedAndCountedUnlessStrict) {
  const std::string path = temp_path("skip.csv");
  write_text(path, "t_detect,link\n10.1,2\nsoon,3\n20.2,3,7\nnan,1\n30,2\n");
  std::vector<std::string> kinds, messages;
  auto previous = momentum::set_row_warning_sink([&](std::string_view kind, std::string_view message) {
    kinds.emplace_back(kind);
    messages.emplace_back(message);
  });
  auto r = EventReader::open(path, {.other_detectors = true, .strict = false});
  std::vector<double> times;
  while (auto e = r->next()) times.push_back(e->t_detect);
  momentum::set_row_warning_sink(previous);
  EXPECT_EQ(times, std::vector<double>({10.1, 30}));
  ASSERT_EQ(messages.size(), 3u);
  EXPECT_EQ(kinds[0], "bad event row");
  EXPECT_EQ(messages[0], path + ":3: bad t_detect 'soon'; row skipped");
  EXPECT_EQ(messages[1], path + ":4: 3 fields, header has 2; row skipped");
  EXPECT_EQ(messages[2], path + ":5: bad t_detect 'nan'; row skipped");
  r = EventReader::open(path, {.other_detectors = true});
  r->next();
  EXPECT_THROW(r->next(), momentum::Error);
  std::remove(path.c_str());
}

namespace {

// The link columns (issue 29) go out after seen and come back as written; damage in them is an
// error with the file and line.
TEST(Events, LinkProbabilitiesRoundTripAndDamageIsAnError) {
  const std::string path = temp_path("links.csv");
  {
    EventWriter w(path, 3, {}, /*contact=*/true);
    Event e = sample(1, EventKind::end);
    e.contact.seen = "point";
    e.contact.link_probabilities = {{3, 0.6123456}, {2, 0.3876544}, {1, 1.23456e-9}};
    e.contact.link_set = {2, 3};
    e.contact.set_probability = 1 - 1.23456e-9;
    e.contact.collision_probability = 0.25;
    e.contact.peak_force_sd = 12.5;
    w.write(e);
  }
  const std::string text = [&] {
    std::ifstream in(path);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  EXPECT_NE(text.find(",seen,links,link_set,p_set,p_collision,f_peak_sd\n"), std::string::npos) << text;
  EXPECT_NE(text.find(",point,3:0.612;2:0.388;1:1.23e-09,2;3,1,0.25,12.5\n"), std::string::npos) << text;
  auto r = EventReader::open(path);
  const auto e = r->next();
  ASSERT_TRUE(e);
  ASSERT_EQ(e->contact.link_probabilities.size(), 3u);
  EXPECT_EQ(e->contact.link_probabilities[0], (std::pair<int, double>{3, 0.612}));
  EXPECT_EQ(e->contact.link_probabilities[2], (std::pair<int, double>{1, 1.23e-9}));
  EXPECT_EQ(e->contact.link_set, (std::vector<int>{2, 3}));
  EXPECT_EQ(e->contact.set_probability, 1);
  EXPECT_EQ(e->contact.collision_probability, 0.25);
  EXPECT_EQ(e->contact.peak_force_sd, 12.5);
  const std::string head = "t_onset_estimate,t_detect,link,joints,kind,event,t_end,ended_by,peak1,peak2,links,link_set,p_set,p_collision,f_peak_sd\n";
  const std::pair<std::string, std::string> cases[] = {
      {"1,2,1,1,onset,1,,,3,4,1:0.5;2,,,,\n", ":2: bad links entry '2' (link:probability)"},
      {"1,2,1,1,onset,1,,,3,4,3:0.5,,,,\n", ":2: link 3 out of 1..2"},
      {"1,2,1,1,onset,1,,,3,4,1:1.5,,,,\n", ":2: bad probability in links '1.5' (a probability, 0..1)"},
      {"1,2,1,1,onset,1,,,3,4,,1;x,,,\n", ":2: bad link in link_set 'x'"},
      {"1,2,1,1,onset,1,,,3,4,,,-0.1,,\n", ":2: bad p_set '-0.1' (a probability, 0..1)"},
      {"1,2,1,1,onset,1,,,3,4,,,,nan,\n", ":2: bad p_collision 'nan' (a probability, 0..1)"},
      {"1,2,1,1,onset,1,,,3,4,,,,,-1\n", ":2: bad f_peak_sd '-1' (a standard deviation, >= 0)"},
      {"1,2,1,1,onset,1,,,3,4,,,,,x\n", ":2: bad f_peak_sd 'x'"},
  };
  for (const auto& [row, message] : cases) {
    write_text(path, head + row);
    auto reader = EventReader::open(path, {.strict = true});
    try {
      reader->next();
      ADD_FAILURE() << "no error for " << row;
    } catch (const momentum::Error& error) {
      EXPECT_EQ(std::string(error.what()), path + message);
    }
  }
  std::remove(path.c_str());
}

}  // namespace
