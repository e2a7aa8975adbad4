// The profile's "thresholds" section: round trip, other sections untouched, validation.
#include <gtest/gtest.h>

#include "momentum/core/error.hpp"
#include "momentum/detect/thresholds.hpp"

using namespace momentum::detect;

TEST(Thresholds, StoreAndReadBackKeepsEverythingElse) {
  nlohmann::json doc = {{"urdf", "a.urdf"}, {"friction", {{"model", "lugre"}}}};
  Thresholds t;
  t.signal = Signal::mu;
  t.rest_rule = RestRule{0.02, 0.3, 0.05};
  t.margin_nm = 0.5;
  JointThreshold a;
  a.moving = 2.5;
  a.band = 1.25;
  a.rest = 0.75;
  a.rest_band = 0.25;
  a.rest_absolute = true;
  JointThreshold b;
  b.moving = 3;
  b.envelope = JointThreshold::Envelope{1.5, 0.5};
  t.joints = {a, b};
  t.friction_band = 3;
  store_thresholds(doc, t);
  Thresholds r = constant_thresholds(Signal::r, {7.8}, 2);
  store_thresholds(doc, r);
  EXPECT_EQ(doc["friction"]["model"], "lugre");
  EXPECT_EQ(doc["urdf"], "a.urdf");

  auto back = thresholds_from_profile(doc, Signal::mu, "p.json");
  ASSERT_TRUE(back);
  EXPECT_EQ(back->rest_rule.velocity, 0.02);
  EXPECT_EQ(back->rest_rule.time, 0.3);
  EXPECT_EQ(back->rest_rule.hangover, 0.05);
  EXPECT_EQ(*back->margin_nm, 0.5);
  EXPECT_EQ(back->friction_band, 3.0);
  ASSERT_EQ(back->joints.size(), 2u);
  EXPECT_EQ(back->joints[0].moving, 2.5);
  EXPECT_EQ(back->joints[0].band, 1.25);
  EXPECT_EQ(*back->joints[0].rest, 0.75);
  EXPECT_EQ(back->joints[0].rest_band, 0.25);
  EXPECT_TRUE(back->joints[0].rest_absolute);
  EXPECT_FALSE(back->joints[0].envelope);
  EXPECT_FALSE(back->joints[1].rest);
  EXPECT_EQ(back->joints[1].envelope->a, 1.5);
  EXPECT_EQ(back->joints[1].envelope->b, 0.5);
  auto rr = thresholds_from_profile(doc, Signal::r, "p.json");
  ASSERT_TRUE(rr);
  EXPECT_EQ(rr->joints[1].moving, 7.8);

  // Replacing mu keeps r, and the keys of mu's entry that another stage owns (the contact
  // classification rule); the margin the new thresholds leave out goes.
  doc["thresholds"]["mu"]["classify"] = {{"rise", 0.05}};
  store_thresholds(doc, constant_thresholds(Signal::mu, {1, 2}, 2));
  EXPECT_EQ(thresholds_from_profile(doc, Signal::mu, "p")->joints[1].moving, 2);
  EXPECT_EQ(thresholds_from_profile(doc, Signal::r, "p")->joints[0].moving, 7.8);
  EXPECT_EQ(doc["thresholds"]["mu"]["classify"]["rise"], 0.05);
  EXPECT_FALSE(doc["thresholds"]["mu"].contains("margin"));
  EXPECT_FALSE(doc["thresholds"]["mu"].contains("friction_band"));  // constant thresholds have none
}

TEST(Thresholds, AbsentSectionOrSignal) {
  EXPECT_FALSE(thresholds_from_profile({{"urdf", "x"}}, Signal::mu, "p"));
  nlohmann::json doc;
  store_thresholds(doc, constant_thresholds(Signal::r, {1}, 1));
  EXPECT_FALSE(thresholds_from_profile(doc, Signal::mu, "p"));
}

TEST(Thresholds, MalformedEntriesAreErrorsNamingTheProfile) {
  auto expect_error = [](nlohmann::json section, const std::string& text) {
    nlohmann::json doc = {{"thresholds", section}};
    try {
      thresholds_from_profile(doc, Signal::mu, "arm.json");
      ADD_FAILURE() << "no error for " << section.dump();
    } catch (const momentum::Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("arm.json: ", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
    }
  };
  expect_error(nlohmann::json::array(), "\"thresholds\" must be an object");
  expect_error({{"mu", {{"joints", 3}}}}, "thresholds.mu.joints must be an array");
  expect_error({{"mu", {{"joints", {{{"band", 1}}}}}}}, "has no \"moving\" threshold");
  expect_error({{"mu", {{"joints", {{{"moving", -1}}}}}}}, "moving threshold must be > 0");
  expect_error({{"mu", {{"joints", {{{"moving", "7"}}}}}}}, "must be a number");
  expect_error({{"mu", {{"joints", {{{"moving", 1}, {"envelope", {{"a", 1}, {"b", -1}}}}}}}}}, "envelope b must be >= 0");
  expect_error({{"mu", {{"joints", {{{"moving", 1}, {"rest", 1}, {"rest_statistic", "median"}}}}}}}, "rest_statistic");
  expect_error({{"mu", {{"rest", {{"velocity", 0}}}, {"joints", {{{"moving", 1}}}}}}}, "rest velocity must be > 0");
  EXPECT_THROW(constant_thresholds(Signal::mu, {1, 2}, 3), momentum::Error);
  EXPECT_THROW(constant_thresholds(Signal::mu, {0}, 3), momentum::Error);
  EXPECT_THROW(parse_signal("tau"), momentum::Error);
  EXPECT_EQ(parse_signal_list("mu,r"), (std::vector<Signal>{Signal::mu, Signal::r}));
  EXPECT_TRUE(parse_signal_list("").empty());
  EXPECT_THROW(parse_signal_list("mu,"), momentum::Error);
  EXPECT_THROW(parse_signal_list("r,tau"), momentum::Error);
}
