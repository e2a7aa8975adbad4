// mo-sim's run as library calls (sim/log.hpp): the campaign's ranges as the command line gives
// them, --mixed, the default length of a run, and which outputs go together.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "momentum/sim/log.hpp"

namespace momentum::sim {
namespace {

TEST(ContactRanges, ParseIntoTheOptionsOrNameTheBadOne) {
  ContactRanges ranges;
  ranges.force = "40:90";
  ranges.clamp_hold = "1";  // one number: MIN = MAX
  ContactOptions contacts;
  std::string why;
  ASSERT_TRUE(ranges.parse(&contacts, &why)) << why;
  EXPECT_EQ(contacts.force_min, 40);
  EXPECT_EQ(contacts.force_max, 90);
  EXPECT_EQ(contacts.rise_min, 0.02);
  EXPECT_EQ(contacts.rise_max, 0.1);
  EXPECT_EQ(contacts.clamp_hold_min, 1);
  EXPECT_EQ(contacts.clamp_hold_max, 1);
  ranges.hold = "0.3:0.1";
  EXPECT_FALSE(ranges.parse(&contacts, &why));
  EXPECT_EQ(why, "--hold: '0.3:0.1' is not a range MIN:MAX of numbers with MIN <= MAX");
}

TEST(MixedCampaign, SetsWhatWasNotGiven) {
  ContactOptions contacts;
  ContactRanges ranges;
  ranges.rise = "0.5:0.6";
  const std::set<std::string> given = {"--rise", "--clamping"};
  contacts.clamp_fraction = 0.2;
  apply_mixed_campaign([&](const char* option) { return given.count(option) > 0; }, &contacts, &ranges);
  EXPECT_EQ(contacts.clamp_fraction, 0.2);
  EXPECT_EQ(ranges.rise, "0.5:0.6");
  EXPECT_EQ(contacts.clamp_stiffness, 300000.0);
  EXPECT_EQ(ranges.clamp_hold, "0.01:0.05");
  EXPECT_EQ(ranges.force, "40:150");
}

TEST(DefaultDuration, IsAMinuteOrWhatTheCampaignNeeds) {
  RunOptions run;
  EXPECT_EQ(default_duration(run), 60.0);
  run.contacts.count = 50;  // 50 * (0.1 + 0.3 + 0.1) + 49 * 2 = 123 s of contacts
  EXPECT_DOUBLE_EQ(default_duration(run), 2 * run.trajectory.blend + 1.0 + 2.0 * 123.0);
  run.trajectory.kind = TrajectoryKind::ptp;  // no blends
  EXPECT_DOUBLE_EQ(default_duration(run), 1.0 + 2.0 * 123.0);
}

TEST(LogOutput, CandumpNeedsADbcAndTakesNoStreamOptions) {
  LogOutput output;
  std::string why;
  EXPECT_TRUE(output.IsValid(&why));
  output.candump = true;
  EXPECT_FALSE(output.IsValid(&why));
  EXPECT_EQ(why, "--candump needs --dbc FILE");
  output.dbc_path = "arm.dbc";
  EXPECT_TRUE(output.IsValid(&why));
  output.format = "bin";
  EXPECT_FALSE(output.IsValid(&why));
  output.format = "csv";
  output.truth_columns = true;
  EXPECT_FALSE(output.IsValid(&why));
}

}  // namespace
}  // namespace momentum::sim
