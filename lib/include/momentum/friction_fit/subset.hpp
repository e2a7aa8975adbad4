// The global search's share of long logs: a constant-size set of contiguous windows of one
// joint's data that keeps what the friction parameters show in (speed, acceleration, both
// directions, reversals), so that the search's cost does not grow with hours of data. The
// polish and the uncertainties then use every sample (friction_fit.hpp).
//
// Why windows and not samples: the model compared with r is a recursion over time (the friction
// state and the observer's filter), so a sample can only be predicted from the samples before
// it. Each window is preceded by a warm-up that the model runs through without counting it
// (the friction state and the filter's fast pole settle there); what the warm-up cannot settle,
// the filter's slow pole (the second-order observer's K2: seconds), is a known decaying
// response whose size the fit solves for per window (Problem in friction_fit.cpp), so the
// warm-up stays short.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "momentum/friction_fit/data.hpp"
#include "momentum/observer/filter.hpp"

namespace momentum::friction_fit {

struct SubsetOptions {
  // Counted samples the search uses at most; a joint with no more counted samples than this is
  // searched on all of them. 0: always all (the search's cost then grows with the data).
  std::size_t max_samples = 2000;
  // Windows the budget is split into (their length is max_samples / windows samples); adjacent
  // chosen windows join into one segment. >= 1.
  int windows = 16;
  // Seconds the model runs before each segment without counting them; <= 0: 5 / K1 (five time
  // constants of the observer's fast pole), at least 3 samples.
  double warmup = 0;
  // Seconds a window lasts at least (fewer, longer windows when max_samples / windows samples
  // last less); < 0: 2 / K2 for the second-order observer, 0 for the first-order one. The slow
  // state's response, solved for per segment, then decays to e^-2 within a window, which tells
  // it from a constant offset: in short windows it absorbs the friction level of every window
  // without a reversal, and the cost is flat in the levels (a 1 kHz log cut into 0.25 s windows
  // fitted the Stribeck velocity 10 times too small).
  double min_window = 0;

  // False (reason in `why`) for windows < 1, or a window budget below 8 samples per window.
  bool IsValid(std::string* why) const;
};

// What the subset holds and what it was chosen from.
struct SubsetSummary {
  bool used = false;               // false: the joint was searched on all its samples
  std::size_t segments = 0;        // contiguous pieces of the data
  std::size_t samples = 0;         // samples the model runs over (warm-ups included)
  std::size_t counted = 0;         // of which counted in the cost
  std::size_t counted_total = 0;   // counted samples of the whole data
  // Counted samples per stratum (speed quartile x direction x acceleration above or below its
  // median, then samples just after a reversal), in the data and in the subset.
  std::vector<std::size_t> strata_total;
  std::vector<std::size_t> strata_chosen;
};

// The strata: 16 = 4 speed quartiles x 2 directions x 2 acceleration halves, and 1 for counted
// samples within 0.25 s after a reversal of the direction of motion.
inline constexpr int kSubsetStrata = 17;

// Chooses the windows greedily: each pick is the window (on a fixed grid) that adds the most
// counted samples to the strata still short of an equal share of the budget (strata with fewer
// samples than their share give all they have, the rest is shared among the others), until the
// budget is spent. Deterministic. The result is a JointSeries of the chosen segments in time
// order, each beginning with its warm-up (uncounted, restart = 2 at its first sample), times
// shifted as append_series does; `segment_start` receives the index in the result of each
// segment's first sample, `origin` (when non-null) the index in `data` of every sample.
// When the data have no more counted samples than options.max_samples (or it is 0) the result
// is a copy of `data` and summary->used is false. Throws std::invalid_argument for invalid
// options or gains.
JointSeries search_subset(const JointSeries& data, const observer::Gains& gains,
                          const SubsetOptions& options, std::vector<std::size_t>* segment_start,
                          SubsetSummary* summary, std::vector<std::size_t>* origin = nullptr);

}  // namespace momentum::friction_fit
