// Progress wording: whole percents and a time left rounded as people read it.
#include <gtest/gtest.h>

#include "momentum/cli/progress_text.hpp"

namespace {

using momentum::cli::progress_text;

TEST(ProgressText, PercentOnlyUntilTheEstimateMeansSomething) {
  EXPECT_EQ(progress_text(0.0, 0.0), "0%");
  EXPECT_EQ(progress_text(0.005, 10.0), "0%");   // under 1% done
  EXPECT_EQ(progress_text(0.5, 0.5), "50%");     // under 1 s elapsed
  EXPECT_EQ(progress_text(1.0, 100.0), "100%");
  EXPECT_EQ(progress_text(1.5, 100.0), "100%");
  EXPECT_EQ(progress_text(-1.0, 100.0), "0%");
}

TEST(ProgressText, TimeLeftAtTheAverageRateRounded) {
  // 37% after 10 s: 17.03 s left, up to 20 s.
  EXPECT_EQ(progress_text(0.37, 10.0), "37%, about 20 s left");
  // 90% after 9 s: 1 s left shows as 5 s (never "0 s").
  EXPECT_EQ(progress_text(0.9, 9.0), "90%, about 5 s left");
  // 25% after 60 s: 180 s left.
  EXPECT_EQ(progress_text(0.25, 60.0), "25%, about 3 min left");
  // 10% after 600 s: 5400 s = 1 h 30 min.
  EXPECT_EQ(progress_text(0.10, 600.0), "10%, about 1 h 30 min left");
  // 2% after 180 s: 8820 s = 2 h 27 min, to 2 h 30 min; 50% after 2 h: 2 h.
  EXPECT_EQ(progress_text(0.02, 180.0), "2%, about 2 h 30 min left");
  EXPECT_EQ(progress_text(0.5, 7200.0), "50%, about 2 h left");
  // 99.9% shows 99, not 100, until done.
  EXPECT_EQ(progress_text(0.999, 100.0), "99%, about 5 s left");
}

}  // namespace
