#pragma once
// The tail of a residual's excursions, for thresholds that state the false-alarm rate they
// stand for (peaks over threshold, extreme-value statistics).
//
// A detector raises a false alarm each time the statistic crosses its threshold on
// collision-free motion, so the rate that matters is the rate of independent excursions above
// a level, not the share of samples above it. The peaks of those excursions (declustered: each
// the largest value within `window` seconds after it, and at least that far from the previous
// peak) above a high level follow a generalised Pareto distribution (Pickands-Balkema-de Haan),
// whatever the distribution of the samples. Fitting it to the largest peaks gives the level
// crossed once per given number of hours, also beyond the data's own length, and tells a lone
// excursion far beyond that tail (a glitch, an unmarked bump, an abrupt stop) from the tail
// itself, so that one such row cannot set a threshold.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace momentum::calibrate {

// One declustered peak: |x| (signal units), time (s) and location (`file:line`).
struct TailPeak {
  double m = 0;
  double t = 0;
  std::string where;
  // The lowest |x| between the previous peak of the stream and this one (0 for the first): the
  // peak starts an excursion over a level u (an up-crossing, which the detector raises an event
  // for) only when valley < u. Peaks over u of one persistent excursion, `window` apart, are
  // one event, not one each.
  double valley = 0;
};

// Declustered peaks of one signal, the largest `keep` of them, in constant memory.
class TailSampler {
 public:
  // `window`: seconds that separate independent excursions (> 0); `keep`: peaks kept (>= 8).
  explicit TailSampler(double window = 0.2, std::size_t keep = 256);

  // Rows after this belong to a new stream: the open excursion is closed first.
  void begin_stream();

  // One sample |x| at time t (s) that lasted dt seconds of exposure. `where()` gives the row's
  // location; it is called only when the sample may become one of the kept peaks. NaN ignored.
  template <class Where>
  void add(double m, double t, double dt, Where&& where) {
    if (std::isnan(m)) return;
    seconds_ += dt;
    if (has_candidate_ && t - candidate_.t >= window_) close();
    const double previous = previous_m_;
    previous_m_ = m;
    if (!has_candidate_) {
      // After a peak, the excursion's fall belongs to it: the next one starts where the signal
      // rises again.
      if (descending_ && m <= previous) {
        since_peak_ = std::min(since_peak_, m);
        return;
      }
      descending_ = false;
      has_candidate_ = true;
      candidate_.m = -1;
      candidate_.valley = since_peak_;
    }
    if (m > candidate_.m) {
      candidate_.m = m;
      candidate_.t = t;
      candidate_.valley = std::min(candidate_.valley, since_peak_);
      since_peak_ = INFINITY;
      if (could_keep(m)) candidate_.where = where();
      else candidate_.where.clear();
    } else {
      since_peak_ = std::min(since_peak_, m);
    }
  }

  // Closes the open excursion (end of a stream or of the data).
  void close();
  // Peaks found (kept or not) and seconds of exposure.
  std::uint64_t peaks() const { return peaks_; }
  double seconds() const { return seconds_; }
  // The kept peaks, largest first (the open excursion included).
  std::vector<TailPeak> largest() const;
  // Adds another sampler's peaks (other streams) and exposure.
  void merge(const TailSampler& other);

 private:
  bool could_keep(double m) const { return kept_.size() < keep_ || m > kept_.front().m; }
  void push(const TailPeak& peak);
  double window_;
  std::size_t keep_;
  std::vector<TailPeak> kept_;  // a min-heap on m
  std::uint64_t peaks_ = 0;
  double seconds_ = 0;
  bool has_candidate_ = false;
  TailPeak candidate_;
  bool descending_ = false;
  double previous_m_ = 0;
  double since_peak_ = 0;  // lowest |x| since the last peak's row (0 at a stream's start)
};

// A generalised Pareto tail: P(peak > u0 + y | peak > u0) = (1 + xi y / sigma)^(-1/xi), with
// peaks over u0 arriving at `rate` per hour.
struct ParetoTail {
  double u0 = 0;     // base level, signal units
  double sigma = 0;  // scale, signal units, > 0
  double xi = 0;     // shape: < 0 bounded tail, 0 exponential, > 0 heavy
  double rate = 0;   // peaks over u0 per hour of exposure
  int peaks = 0;     // peaks over u0 the fit used
  // The level whose peaks exceed it `per_hour` times an hour on average, signal units.
  double level(double per_hour) const;
  // Peaks per hour over level u.
  double rate_over(double u) const;
  // The rarest rate these peaks vouch for, per hour: the rate r at which one standard error of
  // the estimated rate is a factor `uncertainty` (> 1). For the exponential tail fitted to k
  // exceedances (scale their mean excess, rate k per exposure), the delta method gives
  // sd(ln r) = sqrt(1 + L^2) / sqrt(k) with L = ln(rate / r) the extrapolation in scales, so
  // L may reach sqrt(k ln^2(uncertainty) - 1) (0 when that is negative: only the base level's
  // own rate is vouched for). Rarer rates are the tail's extrapolation, not the data's word.
  double supported_rate(double uncertainty) const;
};

struct TailFitOptions {
  // Shape bounds: probability-weighted moments are unreliable for xi < -0.5, and a heavier
  // tail than xi = 0.5 (infinite variance beyond xi = 0.5) is not what residual noise does; a
  // fit outside is clamped and the scale refitted.
  double xi_min = -0.5, xi_max = 0.5;
  // Outliers, a generalised extreme Studentized deviate procedure (Rosner 1983) on the
  // declustered peaks: for i = 1..max, the i-th largest peak is judged against the tail fitted
  // to the peaks below it (its predictive distribution: for k exceedances, the scale's own
  // uncertainty makes it a generalised Pareto of shape 1/k, or the fitted shape when heavier);
  // it is extreme when the chance that any of those peaks reaches it is under
  // outlier_probability. The outliers are the i largest for the largest extreme i, so a second
  // glitch beside the first (which would widen the tail the first is judged by) cannot mask it.
  // On outlier-free exponential peaks 0.01 leaves an ordinary one out in 1 to 2% of the states
  // (tail_test). 0.05, the procedure's usual level, took three ordinary peaks of a simulated
  // UR5's joint 1 (halving its threshold: false alarms), while 0.01 keeps a glitch that only a
  // few dozen peaks judge (p = 0.0104 for an abrupt stop against 6 peaks on the UR10e), and
  // the tail then extrapolates it.
  double outlier_probability = 0.01;
  // The level for a peak that fit_tail's caller calls corroborated: one at the time another
  // joint's peak was left out as an outlier (an abrupt stop, a glitch seen by several joints).
  // Two joints extreme at once is evidence of its own, so the procedure's usual level suffices
  // there; elsewhere the stricter outlier_probability keeps the ordinary tail.
  double corroborated_probability = 0.05;
  // At most this many outliers are removed (the largest first), and never more than a tenth of
  // the peaks.
  int max_outliers = 5;
  // The rate's one-standard-error factor up to which the data vouch for a rate (see
  // ParetoTail::supported_rate), > 1.
  double rate_uncertainty = 2;
  // Fewest peaks over the base level for a fit.
  int min_peaks = 4;
  // With fewer peaks over the base level than this the shape is not estimated (TailFit::shape
  // stays NaN).
  int min_shape_peaks = 30;
  // Levels and rates from the fitted shape instead of the exponential tail (see above); for
  // data known to follow a generalised Pareto tail.
  bool fitted_shape = false;
  bool IsValid(std::string* why) const;
};

// The fit of the tail of declustered peaks.
struct TailFit {
  bool ok = false;          // false: too few peaks (see why)
  std::string why;          // when !ok
  ParetoTail tail;          // when ok: exponential (xi = 0) unless options.fitted_shape
  double shape = NAN;       // the shape xi fitted to the same peaks (NaN: too few to estimate)
  std::vector<TailPeak> outliers;  // peaks removed as outliers, largest first
  std::vector<bool> corroborated;  // per outlier: judged at the corroborated level
  double largest_kept = 0;  // the largest peak that is not an outlier (0 when none)
  double seconds = 0;       // exposure, s
  std::uint64_t peaks = 0;  // independent peaks found in the exposure (outliers included)
  // The rarest false-alarm rate the peaks vouch for, per hour (ParetoTail::supported_rate;
  // without a fit, one per exposure: the largest peak's own rate). NaN without exposure.
  double supported_per_hour = NAN;
};

// Fits a generalised Pareto tail to the largest peaks (probability-weighted moments, Hosking and
// Wallis 1987), after removing outliers. `total_peaks`: the peaks found in `seconds` of
// exposure, of which `largest` are the top ones, largest first. The base level is the
// (k+1)-th largest peak with k = min(kept - 1, max(min_peaks, sqrt(total))), or total/5 for a
// fitted shape; fewer than min_peaks + 1 peaks in all: no fit.
// `corroborated` (may be empty): peaks judged at options.corroborated_probability instead of
// options.outlier_probability.
TailFit fit_tail(const std::vector<TailPeak>& largest, std::uint64_t total_peaks, double seconds,
                 const TailFitOptions& options = {},
                 const std::function<bool(const TailPeak&)>& corroborated = {});

}  // namespace momentum::calibrate
