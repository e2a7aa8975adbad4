// Robot profiles: parsing (comments, defaults, types), error messages with file and line,
// unknown-key warnings, atomic saving and provenance.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "momentum/core/error.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/version.hpp"

namespace {

namespace fs = std::filesystem;
namespace mm = momentum::model;

class ProfileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir = fs::temp_directory_path() /
          ("momentum_profile_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
    previous = momentum::set_warning_sink(
        [this](std::string_view message) { warnings.emplace_back(message); });
  }
  void TearDown() override {
    momentum::set_warning_sink(previous);
    fs::remove_all(dir);
  }
  fs::path write(const std::string& name, const std::string& text) {
    const fs::path path = dir / name;
    std::ofstream(path) << text;
    return path;
  }
  std::string error_of(const fs::path& path) {
    try {
      mm::load_profile(path);
    } catch (const momentum::Error& e) {
      return e.what();
    }
    return "(no error)";
  }
  fs::path dir;
  std::vector<std::string> warnings;
  momentum::WarningSink previous;
};

TEST_F(ProfileTest, SmallestProfileGetsDefaults) {
  const fs::path path =
      write("arm.json", R"({"urdf": "ur5_robot.urdf", "root": "base_link", "tip": "tool0"})");
  const mm::Profile profile = mm::load_profile(path);
  EXPECT_EQ(profile.path, path);
  EXPECT_EQ(profile.urdf, dir / "ur5_robot.urdf");  // relative to the profile's folder
  EXPECT_EQ(profile.root, "base_link");
  EXPECT_EQ(profile.tip, "tool0");
  EXPECT_EQ(profile.gravity, Eigen::Vector3d(0, 0, -9.81));
  EXPECT_TRUE(profile.joints.empty());
  EXPECT_TRUE(warnings.empty());
}

TEST_F(ProfileTest, CommentsAndAllModelKeys) {
  const fs::path path = write("arm.json", R"(// a robot
{
  /* block comment */
  "urdf": "/abs/robot.urdf",   // absolute path kept
  "root": "a", "tip": "b",
  "gravity": [0.1, 0, -9.8],
  "joints": [{"k_i": 2.5, "rotor_inertia": 0.3}, {"name": "elbow"}],
  "observer": {"order": 2}, "friction": {}, "thresholds": {}, "provenance": []
})");
  const mm::Profile profile = mm::load_profile(path);
  EXPECT_EQ(profile.urdf, fs::path("/abs/robot.urdf"));
  EXPECT_EQ(profile.gravity, Eigen::Vector3d(0.1, 0, -9.8));
  ASSERT_EQ(profile.joints.size(), 2u);
  EXPECT_EQ(profile.joints[0].k_i, 2.5);
  EXPECT_EQ(profile.joints[0].rotor_inertia, 0.3);
  EXPECT_EQ(profile.joints[1].k_i, 1.0);
  EXPECT_EQ(profile.joints[1].rotor_inertia, 0.0);
  EXPECT_EQ(profile.document["observer"]["order"], 2);  // other sections kept whole
  EXPECT_TRUE(warnings.empty());
}

TEST_F(ProfileTest, UnknownKeysWarnOnce) {
  const fs::path path = write(
      "arm.json",
      R"({"urdf": "x.urdf", "root": "a", "tip": "b", "colour": 1, "joints": [{"torque": 3}]})");
  const mm::Profile profile = mm::load_profile(path);
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_EQ(warnings[0], path.string() + ": unknown key \"colour\" ignored");
  EXPECT_EQ(warnings[1], path.string() + ": unknown key \"torque\" in \"joints\"[0] ignored");
  EXPECT_EQ(profile.joints[0].k_i, 1.0);
}

// A misspelt known key used to warn and leave its section at the defaults: "joint" for "joints"
// made every torque constant 1. A near miss (case, '_', one or two edits) is an error naming the
// key it resembles and its line.
TEST_F(ProfileTest, ANearMissOfAKnownKeyIsAnErrorNamingIt) {
  struct Case {
    std::string members, message;
  };
  const std::vector<Case> cases = {
      {R"("joint": [{"k_i": 11}])", ":3: unknown key \"joint\": did you mean \"joints\"?"},
      {R"("Joints": [{"k_i": 11}])", ":3: unknown key \"Joints\": did you mean \"joints\"?"},
      {R"("treshold": {})", ":3: unknown key \"treshold\": did you mean \"thresholds\"?"},
      {R"("fricton": {})", ":3: unknown key \"fricton\": did you mean \"friction\"?"},
      {R"("active-payload": "none")", ":3: unknown key \"active-payload\": did you mean \"active_payload\"?"},
      {R"("joints": [{"ki": 11}])", ":3: unknown key \"ki\" in \"joints\"[0]: did you mean \"k_i\"?"},
      {R"("joints": [{"rotor_inertai": 1}])",
       ":3: unknown key \"rotor_inertai\" in \"joints\"[0]: did you mean \"rotor_inertia\"?"},
      {R"("payloads": {"box": {"Mass": 1}})",
       ":3: unknown key \"Mass\" in \"payloads\".box: did you mean \"mass\"?"},
  };
  for (const auto& c : cases) {
    const fs::path path = write("near.json", "{\"urdf\": \"x.urdf\", \"root\": \"a\", \"tip\": \"b\",\n\n  " +
                                                 c.members + "\n}\n");
    const std::string message = error_of(path);
    EXPECT_EQ(message.rfind(path.string() + c.message, 0), 0u) << message;
  }
  // Keys of one's own that resemble none stay warnings.
  const fs::path own = write("own.json", R"({"urdf": "x", "root": "a", "tip": "b", "site": "lab 2", "notes": 1})");
  EXPECT_NO_THROW(mm::load_profile(own));
  EXPECT_EQ(warnings.size(), 2u);
}

// The JSON parser takes a NUL byte for the end of input: a profile with one loaded the part in
// front of it and dropped the rest unseen (found by the profile fuzz target).
TEST_F(ProfileTest, NulByteIsAnErrorWithItsLine) {
  const fs::path path = write("nul.json", std::string("{\"urdf\": \"x\", \"root\": \"a\", \"tip\": \"b\"}\n") + '\0' +
                                                "\n{\"joints\": []}");
  EXPECT_EQ(error_of(path), path.string() + ":2: NUL byte in profile text (not a text file?)");
}

// A profile nested thousands deep took 27 s (3,000 levels) or crashed (30,000): the depth is
// bounded before the document is parsed.
TEST_F(ProfileTest, DeepNestingIsAnErrorWithItsLine) {
  for (const int depth : {65, 3000, 30000}) {
    const fs::path path = write("deep.json", "{\"urdf\": \"x\", \"root\": \"a\", \"tip\": \"b\",\n\"x\": " +
                                                 std::string(static_cast<std::size_t>(depth), '[') +
                                                 std::string(static_cast<std::size_t>(depth), ']') + "}\n");
    const std::string message = error_of(path);
    EXPECT_EQ(message, path.string() + ":2: arrays and objects nest deeper than 64 levels") << depth;
  }
  // 64 levels, brackets in strings and comments not counted.
  const fs::path ok = write("ok.json", "{\"urdf\": \"x\", \"root\": \"a\", \"tip\": \"b\", \"name\": \"[[[[\", // {{{{\n" +
                                           std::string("\"x\": ") + std::string(63, '[') + std::string(63, ']') + "}");
  EXPECT_NO_THROW(mm::load_profile(ok));
}

TEST_F(ProfileTest, ANumberBeyondDoubleIsAnErrorNamingFileAndLine) {
  const fs::path path = write("big.json", "{\"urdf\": \"x\", \"root\": \"a\", \"tip\": \"b\",\n"
                                          "  \"joints\": [\n    {\"k_i\": 1e999}\n  ]\n}\n");
  EXPECT_EQ(error_of(path), path.string() + ":3: invalid json: number out of range: 1e999");
}

// A byte order mark (an editor's) was read but the profile could not be written back.
TEST_F(ProfileTest, AProfileWithAByteOrderMarkIsWrittenBackWithIt) {
  const std::string bom = "\xEF\xBB\xBF";
  const fs::path path = write("bom.json", bom + "// arm\n{\"urdf\": \"x\", \"root\": \"a\", \"tip\": \"b\"}\n");
  const mm::Profile profile = mm::load_profile(path);
  nlohmann::json document = profile.document;
  document["thresholds"] = {{"mu", 1}};
  mm::save_profile_as(document, profile, path);
  std::ifstream in(path, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  // (an object written on one line that gains a member is rewritten whole, on one line)
  EXPECT_EQ(text, bom + "// arm\n{\"root\": \"a\", \"thresholds\": {\"mu\": 1}, \"tip\": \"b\", \"urdf\": \"x\"}\n");
  EXPECT_EQ(mm::load_profile(path).document["thresholds"]["mu"], 1);
}

TEST_F(ProfileTest, SyntaxErrorNamesFileAndLine) {
  const fs::path path = write("bad.json", "{\n  \"urdf\": \"x.urdf\",\n  \"root\": ,\n}\n");
  const std::string message = error_of(path);
  EXPECT_EQ(message.rfind(path.string() + ":3: invalid json: ", 0), 0u) << message;
}

TEST_F(ProfileTest, MissingFile) {
  const std::string message = error_of(dir / "none.json");
  EXPECT_EQ(message, (dir / "none.json").string() + ": cannot open profile: No such file or directory");
}

TEST_F(ProfileTest, BadValues) {
  struct Case {
    std::string text, message;
  };
  const std::vector<Case> cases = {
      {R"([1, 2])", "a profile must be a json object, not array"},
      {R"({"root": "a", "tip": "b"})", "missing required key \"urdf\""},
      {R"({"urdf": 3, "root": "a", "tip": "b"})", "\"urdf\" must be a string, not number"},
      {R"({"urdf": "x", "root": "", "tip": "b"})", "\"root\" is empty"},
      {R"({"urdf": "x", "root": "a"})", "missing required key \"tip\""},
      {R"({"urdf": "x", "root": "a", "tip": "b", "gravity": [0, 0]})",
       "\"gravity\" must be an array of 3 numbers (m/s^2, root frame)"},
      {R"({"urdf": "x", "root": "a", "tip": "b", "gravity": [0, "0", 1]})",
       "\"gravity\"[1] must be a number, not string"},
      {R"({"urdf": "x", "root": "a", "tip": "b", "joints": {}})",
       "\"joints\" must be an array of objects, one per joint"},
      {R"({"urdf": "x", "root": "a", "tip": "b", "joints": [3]})",
       "\"joints\"[0] must be an object, not number"},
      {R"({"urdf": "x", "root": "a", "tip": "b", "joints": [{}, {"rotor_inertia": -1}]})",
       "\"joints\"[1].rotor_inertia must be >= 0"},
      {R"({"urdf": "x", "root": "a", "tip": "b", "joints": [{"k_i": null}]})",
       "\"joints\"[0].k_i must be a number, not null"},
  };
  for (const Case& c : cases) {
    const fs::path path = write("p.json", c.text);
    EXPECT_EQ(error_of(path), path.string() + ": " + c.message) << c.text;
  }
}

TEST_F(ProfileTest, SaveAtomicallyRoundTripsAndKeepsMode) {
  const fs::path path = write("arm.json", "{}");
  ASSERT_EQ(::chmod(path.c_str(), 0640), 0);
  nlohmann::json document = {{"urdf", "ur5_robot.urdf"}, {"root", "base_link"},
                             {"tip", "tool0"}, {"friction", {{"model", "lugre"}}}};
  mm::save_profile_atomically(document, path);
  const mm::Profile back = mm::load_profile(path);
  EXPECT_EQ(back.document, document);
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640u);
  // Nothing but the profile is left in the folder.
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir)) files.push_back(entry.path());
  EXPECT_EQ(files, std::vector<fs::path>{path});
  // A new profile.
  mm::save_profile_atomically(document, dir / "new.json");
  EXPECT_EQ(mm::load_profile(dir / "new.json").document, document);
}

TEST_F(ProfileTest, SaveIntoMissingFolderFails) {
  try {
    mm::save_profile_atomically(nlohmann::json::object(), dir / "no" / "arm.json");
    FAIL() << "no error";
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()), (dir / "no" / "arm.json").string() +
                                         ": cannot create a temporary file: No such file or "
                                         "directory");
  }
}

TEST_F(ProfileTest, Provenance) {
  nlohmann::json document = {{"urdf", "x"}};
  mm::append_provenance(document, "mo-lugre-fit", {{"log", "day.csv"}, {"rms", 0.7}});
  mm::append_provenance(document, "mo-calibrate", nlohmann::json::object());
  ASSERT_EQ(document["provenance"].size(), 2u);
  const auto& first = document["provenance"][0];
  EXPECT_EQ(first["tool"], "mo-lugre-fit");
  EXPECT_EQ(first["version"], momentum::kVersion);
  EXPECT_EQ(first["details"]["rms"], 0.7);
  // YYYY-MM-DDTHH:MM:SSZ (no std::regex: GCC 12 warns inside it under the sanitizers)
  const std::string time = first["time"].get<std::string>();
  const std::string shape = "dddd-dd-ddTdd:dd:ddZ";
  ASSERT_EQ(time.size(), shape.size()) << time;
  for (std::size_t k = 0; k < shape.size(); ++k) {
    if (shape[k] == 'd') {
      EXPECT_TRUE(std::isdigit(static_cast<unsigned char>(time[k]))) << time;
    } else {
      EXPECT_EQ(time[k], shape[k]) << time;
    }
  }
  EXPECT_EQ(document["provenance"][1]["tool"], "mo-calibrate");
  nlohmann::json broken = {{"provenance", 3}};
  EXPECT_THROW(mm::append_provenance(broken, "x", {}), momentum::Error);
}

}  // namespace
