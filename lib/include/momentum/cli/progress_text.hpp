#pragma once
// Wording of progress lines: the share done as a whole percent and the time left, rounded the
// way people read it ("37%, about 2 min left"), not to the second.
#include <string>

namespace momentum::cli {

// "37%, about 2 min left" for `done` (fraction in [0, 1]) after `elapsed` seconds, the time left
// extrapolated at the average rate so far: under a minute rounded up to 5 s ("about 45 s
// left"), under an hour to whole minutes, else to hours and 10 minutes ("about 1 h 20 min
// left"). Only the percent ("2%") while the estimate is not worth printing yet (under 1% done or
// under 1 s elapsed); "100%" when done.
std::string progress_text(double done, double elapsed);

}  // namespace momentum::cli
