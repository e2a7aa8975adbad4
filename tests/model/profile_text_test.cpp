// Text-preserving profile updates (edit_profile_text, format_profile_value) and where a profile
// written elsewhere points its URDF (urdf_reference, save_profile_as).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "momentum/model/profile.hpp"
#include "momentum/model/profile_text.hpp"

namespace {

namespace fs = std::filesystem;
namespace mm = momentum::model;
using nlohmann::json;

json parse(const std::string& text) { return json::parse(text, nullptr, true, true); }

// A profile as people write them: comments above and beside members, keys in a reading order
// (not sorted), short arrays on one line.
const std::string kProfile = R"(// The arm in cell 3.
{
  "urdf": "arm.urdf",   // beside this file
  "root": "base", "tip": "tool",
  /* drives */
  "joints": [{"k_i": 11.0}, {"k_i": 6.0}],
  "thresholds": {
    "mu": {"joints": [{"moving": 1.5}, {"moving": 2.0}]}
  },
  "provenance": [
    {"tool": "mo-calibrate", "time": "2026-01-01T00:00:00Z"}
  ]
}
)";

TEST(ProfileText, UnchangedDocumentKeepsTheTextByteForByte) {
  EXPECT_EQ(mm::edit_profile_text(kProfile, parse(kProfile)), kProfile);
}

TEST(ProfileText, UpdateChangesOnlyTheUpdatedMembers) {
  json updated = parse(kProfile);
  updated["thresholds"]["mu"]["joints"][0]["moving"] = 0.75;
  updated["provenance"].push_back({{"tool", "mo-calibrate"}, {"time", "2026-01-02T00:00:00Z"}});
  const std::string edited = mm::edit_profile_text(kProfile, updated);
  const std::string expected = R"(// The arm in cell 3.
{
  "urdf": "arm.urdf",   // beside this file
  "root": "base", "tip": "tool",
  /* drives */
  "joints": [{"k_i": 11.0}, {"k_i": 6.0}],
  "thresholds": {
    "mu": {"joints": [{"moving": 0.75}, {"moving": 2.0}]}
  },
  "provenance": [
    {"tool": "mo-calibrate", "time": "2026-01-01T00:00:00Z"},
    {"time": "2026-01-02T00:00:00Z", "tool": "mo-calibrate"}
  ]
}
)";
  EXPECT_EQ(edited, expected);
  EXPECT_EQ(parse(edited), updated);
}

TEST(ProfileText, NewMembersGoAtTheEndIndentedLikeTheirSiblings) {
  json updated = parse(kProfile);
  updated["thresholds"]["r"] = {{"joints", json::array({json{{"moving", 3.0}}})}};
  updated["friction"] = {{"model", "coulomb-viscous"}};
  const std::string edited = mm::edit_profile_text(kProfile, updated);
  EXPECT_EQ(parse(edited), updated);
  // Old text intact up to the end of the thresholds' last member.
  const std::string head = kProfile.substr(0, kProfile.find("\n  },"));
  EXPECT_EQ(edited.substr(0, head.size()), head);
  EXPECT_NE(edited.find("{\"moving\": 2.0}]},\n    \"r\": {\n      \"joints\": [{\"moving\": 3.0}]\n    }\n  },"),
            std::string::npos)
      << edited;
  EXPECT_NE(edited.find("  ],\n  \"friction\": {\"model\": \"coulomb-viscous\"}\n}\n"), std::string::npos)
      << edited;
}

TEST(ProfileText, CommaGoesBeforeATrailingLineComment) {
  const std::string text = "{\n  \"a\": 1, // one\n  \"b\": 2 // two\n}\n";
  json updated = parse(text);
  updated["c"] = 3;
  const std::string edited = mm::edit_profile_text(text, updated);
  EXPECT_EQ(edited, "{\n  \"a\": 1, // one\n  \"b\": 2, // two\n  \"c\": 3\n}\n");
}

TEST(ProfileText, ChangedValueReformattedInPlace) {
  const std::string text = "{\n  // tuned by hand\n  \"observer\": {\"order\": 2, \"k1\": 50},\n  \"x\": \"keep\"\n}";
  json updated = parse(text);
  updated["observer"] = {{"order", 1}, {"k1", 25}};
  EXPECT_EQ(mm::edit_profile_text(text, updated),
            "{\n  // tuned by hand\n  \"observer\": {\"order\": 1, \"k1\": 25},\n  \"x\": \"keep\"\n}");
  // A value of another type is written whole, at the old one's indentation.
  updated["observer"] = json::array({json{{"joints", json::array({1, 2})}, {"more", json{{"a", json::array()}}}}});
  const std::string edited = mm::edit_profile_text(text, updated);
  EXPECT_EQ(parse(edited), updated);
  EXPECT_NE(edited.find("  \"observer\": [\n    {\n      \"joints\": [1, 2],\n"), std::string::npos) << edited;
}

TEST(ProfileText, RemovedMemberRewritesItsObjectOnly) {
  const std::string text = "{\n  \"keep\": [1, 2], // stays\n  \"section\": {\"a\": 1, \"b\": 2}\n}";
  json updated = parse(text);
  updated["section"].erase("b");
  EXPECT_EQ(mm::edit_profile_text(text, updated), "{\n  \"keep\": [1, 2], // stays\n  \"section\": {\"a\": 1}\n}");
}

TEST(ProfileText, StringsWithBracketsAndCommentMarkers) {
  const std::string text = R"({"a": "x // not a comment, }", /* c */ "b": [ "]", 1e-3 ]})";
  json updated = parse(text);
  updated["b"][1] = 0.5;
  EXPECT_EQ(mm::edit_profile_text(text, updated), R"({"a": "x // not a comment, }", /* c */ "b": [ "]", 0.5 ]})");
}

TEST(ProfileText, OneLineContainerThatGrowsIsRewrittenWhole) {
  // The smallest profile, then thresholds and provenance added: spread out, in the profile's
  // style, since they do not fit on the line.
  const std::string text = "{\"urdf\": \"arm.urdf\", \"root\": \"base\", \"tip\": \"tool\"}\n";
  json updated = parse(text);
  updated["thresholds"] = {{"mu", {{"joints", json::array({json{{"moving", 1.5}, {"band", 0.5}}})}}}};
  const std::string edited = mm::edit_profile_text(text, updated);
  EXPECT_EQ(parse(edited), updated);
  EXPECT_EQ(edited,
            "{\n  \"root\": \"base\",\n  \"thresholds\": {\n    \"mu\": {\n      \"joints\": [{\"band\": 0.5, \"moving\": 1.5}]\n"
            "    }\n  },\n  \"tip\": \"tool\",\n  \"urdf\": \"arm.urdf\"\n}\n");
}

TEST(ProfileText, RejectsWhatIsNotJson) {
  EXPECT_THROW(mm::edit_profile_text("{\"a\": ", json::object()), json::parse_error);
}

TEST(ProfileText, FormatKeepsShortArraysOnOneLine) {
  const json value = {{"gravity", {0, 0, -9.81}}, {"joints", json::array({json{{"k_i", 1}}, json{{"k_i", 2}}})}};
  EXPECT_EQ(mm::format_profile_value(value),
            "{\n  \"gravity\": [0, 0, -9.81],\n  \"joints\": [{\"k_i\": 1}, {\"k_i\": 2}]\n}");
  json wide = json::array();
  for (int k = 0; k < 40; ++k) wide.push_back(k * 1000);
  const std::string text = mm::format_profile_value(wide);
  EXPECT_EQ(json::parse(text), wide);
  EXPECT_NE(text.find("\n  0,\n  1000,"), std::string::npos);
}

TEST(UrdfReference, RelativeOnlyWhenTheUrdfTravelsWithTheProfile) {
  EXPECT_EQ(mm::urdf_reference("/opt/robots/arm/arm.urdf", "/opt/robots/arm"), fs::path("arm.urdf"));
  EXPECT_EQ(mm::urdf_reference("/opt/robots/arm/urdf/arm.urdf", "/opt/robots/arm"), fs::path("urdf/arm.urdf"));
  EXPECT_EQ(mm::urdf_reference("/opt/robots/arm/arm.urdf", "/etc/momentum"), fs::path("/opt/robots/arm/arm.urdf"));
  EXPECT_EQ(mm::urdf_reference("/opt/robots/arm/../arm/arm.urdf", "/opt/robots"), fs::path("arm/arm.urdf"));
}

class SaveProfileAs : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() / ("momentum_profile_text_" + std::to_string(::getpid()) + "_" +
                                       ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir / "robot");
    fs::create_directories(dir / "elsewhere");
    fs::create_directories(dir / "etc");
  }
  void TearDown() override { fs::remove_all(dir); }
  static std::string read(const fs::path& path) {
    std::ifstream in(path);
    std::ostringstream out;
    out << in.rdbuf();
    return out.str();
  }
  fs::path dir;
};

TEST_F(SaveProfileAs, WrittenElsewhereAndCopiedStillFindsItsUrdf) {
  std::ofstream(dir / "robot" / "arm.json") << kProfile;
  std::ofstream(dir / "robot" / "arm.urdf") << "<robot name=\"arm\"/>\n";
  const mm::Profile source = mm::load_profile(dir / "robot" / "arm.json");
  json document = source.document;
  document["thresholds"]["mu"]["joints"][1]["moving"] = 2.5;
  mm::save_profile_as(document, source, dir / "elsewhere" / "arm.json");
  // Copied alone to a third folder, and read from a fourth working directory.
  fs::copy_file(dir / "elsewhere" / "arm.json", dir / "etc" / "arm.json");
  const fs::path cwd = fs::current_path();
  fs::current_path(fs::temp_directory_path());
  const mm::Profile copied = mm::load_profile(dir / "etc" / "arm.json");
  fs::current_path(cwd);
  EXPECT_EQ(copied.urdf, fs::absolute(dir / "robot" / "arm.urdf").lexically_normal());
  EXPECT_TRUE(fs::exists(copied.urdf));
  EXPECT_EQ(copied.document["thresholds"]["mu"]["joints"][1]["moving"], 2.5);
  // Only the urdf and the changed threshold differ from the source text.
  std::string expected = kProfile;
  expected.replace(expected.find("\"arm.urdf\""), 10, json(copied.urdf.generic_string()).dump());
  expected.replace(expected.find("{\"moving\": 2.0}"), 15, "{\"moving\": 2.5}");
  EXPECT_EQ(read(dir / "etc" / "arm.json"), expected);
}

TEST_F(SaveProfileAs, BesideItsUrdfStaysRelative) {
  std::ofstream(dir / "robot" / "arm.json") << kProfile;
  const mm::Profile source = mm::load_profile(dir / "robot" / "arm.json");
  mm::save_profile_as(source.document, source, dir / "robot" / "candidate.json");
  EXPECT_EQ(read(dir / "robot" / "candidate.json"), kProfile);
  // In a subfolder of the profile's, the URDF is outside: absolute.
  fs::create_directories(dir / "robot" / "backups");
  mm::save_profile_as(source.document, source, dir / "robot" / "backups" / "arm.json");
  EXPECT_EQ(mm::load_profile(dir / "robot" / "backups" / "arm.json").document["urdf"],
            (fs::absolute(dir) / "robot" / "arm.urdf").lexically_normal().generic_string());
}

}  // namespace
