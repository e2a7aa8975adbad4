#include "momentum/calibrate/calibration.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <string_view>
#include <tuple>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

namespace momentum::calibrate {

// Built on the detector's vocabulary (thresholds, motion states, events).
using namespace detect;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// log2 of a positive normal number within 3.6e-4 (a tenth of a bin at 1000 per decade): its
// exponent plus the table's log2 of its mantissa's top 12 bits, at their interval's middle.
constexpr int kMantissaBits = 12;
double table_log2(double x) {
  static const std::array<double, 1 << kMantissaBits> table = [] {
    std::array<double, 1 << kMantissaBits> t{};
    for (std::size_t i = 0; i < t.size(); ++i) t[i] = std::log2(1 + (static_cast<double>(i) + 0.5) / static_cast<double>(t.size()));
    return t;
  }();
  const auto bits = std::bit_cast<std::uint64_t>(x);
  const int exponent = static_cast<int>((bits >> 52) & 0x7ff) - 1023;
  return exponent + table[(bits >> (52 - kMantissaBits)) & ((1u << kMantissaBits) - 1)];
}

// The lower edges of the inner bins 1..bins-2 of histograms of these bins (LogHistogram::lower_),
// made once per set of bins in a process.
std::shared_ptr<const std::vector<double>> inner_bin_edges(double lowest, std::size_t bins, int per_decade) {
  static std::mutex mutex;
  static std::map<std::tuple<double, std::size_t, int>, std::shared_ptr<const std::vector<double>>> made;
  const std::lock_guard<std::mutex> lock(mutex);
  auto& edges = made[{lowest, bins, per_decade}];
  if (edges) return edges;
  // The formula's bin, which the edges must reproduce.
  auto bin = [&](double value) {
    const double position = std::log10(value / lowest) * per_decade;
    return 1 + std::min(static_cast<std::size_t>(position), bins - 3);
  };
  auto lower = std::make_shared<std::vector<double>>(bins - 1, lowest);
  for (std::size_t k = 2; k + 1 < bins; ++k) {
    // From the edge's closed form, a few ulps at most from the formula's, to the smallest
    // value the formula puts in bin k or above.
    double x = lowest * std::pow(10.0, static_cast<double>(k - 1) / per_decade);
    if (bin(x) >= k) {
      for (double y = std::nextafter(x, 0.0); y >= lowest && bin(y) >= k; y = std::nextafter(y, 0.0)) x = y;
    } else {
      while (bin(x) < k) x = std::nextafter(x, INFINITY);
    }
    (*lower)[k] = x;
  }
  edges = std::move(lower);
  return edges;
}

}  // namespace

// ---- LogHistogram ----------------------------------------------------------------------

LogHistogram::LogHistogram(double lowest, double highest, int bins_per_decade)
    : lowest_(lowest), highest_(highest), per_decade_(bins_per_decade) {
  if (!(lowest > 0 && highest > lowest && bins_per_decade > 0))
    throw Error("histogram: need 0 < lowest < highest and bins per decade > 0");
  const double decades = std::log10(highest / lowest);
  bins_.assign(static_cast<std::size_t>(std::ceil(decades * per_decade_)) + 2, 0);
  lower_ = inner_bin_edges(lowest_, bins_.size(), per_decade_);
}

std::size_t LogHistogram::bin(double value) const {
  if (value < lowest_) return 0;
  if (value >= highest_) return bins_.size() - 1;
  const std::vector<double>& lower = *lower_;
  const std::size_t last_inner = bins_.size() - 2;
  const double estimate = (table_log2(value) - table_log2(lowest_)) * per_decade_ * std::log10(2.0);
  std::size_t k = 1 + static_cast<std::size_t>(std::clamp(estimate, 0.0, static_cast<double>(last_inner - 1)));
  while (k > 1 && value < lower[k]) --k;
  while (k < last_inner && value >= lower[k + 1]) ++k;
  return k;
}

void LogHistogram::add(double value) {
  if (std::isnan(value)) return;
  if (value < 0) value = 0;
  ++bins_[bin(value)];
  ++count_;
  min_ = std::min(min_, value);
  max_ = std::max(max_, value);
}

void LogHistogram::merge(const LogHistogram& other) {
  if (other.bins_.size() != bins_.size() || other.lowest_ != lowest_ || other.per_decade_ != per_decade_)
    throw Error("histogram: merging histograms of different bins");
  for (std::size_t k = 0; k < bins_.size(); ++k) bins_[k] += other.bins_[k];
  count_ += other.count_;
  min_ = std::min(min_, other.min_);
  max_ = std::max(max_, other.max_);
}

double LogHistogram::quantile(double p) const {
  if (count_ == 0) return kNaN;
  p = std::clamp(p, 0.0, 1.0);
  const auto rank = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(p * static_cast<double>(count_))));
  if (rank >= count_) return max_;
  std::uint64_t seen = 0;
  for (std::size_t k = 0; k < bins_.size(); ++k) {
    seen += bins_[k];
    if (seen < rank) continue;
    double value;
    if (k == 0) value = std::min(lowest_, max_);
    else if (k == bins_.size() - 1) value = max_;
    else value = lowest_ * std::pow(10.0, (static_cast<double>(k) - 0.5) / per_decade_);
    return std::clamp(value, min_, max_);
  }
  return max_;
}

// ---- PeakTracker -----------------------------------------------------------------------

void PeakTracker::add_slow(double m, double t) {
  auto near = [&](const Peak& p) { return p.stream == stream_ && std::fabs(p.t - t) < window_; };
  std::size_t hit = candidates_.size();
  for (std::size_t i = 0; i < candidates_.size(); ++i)
    if (near(candidates_[i])) {
      hit = i;
      break;
    }
  if (hit < candidates_.size()) {
    if (m <= candidates_[hit].m) return;
    candidates_[hit] = Peak{m, t, stream_};
    // The moved peak may now be near another candidate: keep the larger of the two.
    for (std::size_t i = 0; i < candidates_.size(); ++i)
      if (i != hit && near(candidates_[i])) {
        candidates_.erase(candidates_.begin() + static_cast<std::ptrdiff_t>(i));
        break;
      }
  } else {
    candidates_.push_back(Peak{m, t, stream_});
    if (candidates_.size() > kKeep) {
      auto low = std::min_element(candidates_.begin(), candidates_.end(), [](const Peak& a, const Peak& b) { return a.m < b.m; });
      candidates_.erase(low);
    }
  }
  smallest_ = INFINITY;
  for (const auto& p : candidates_) smallest_ = std::min(smallest_, p.m);
}

void PeakTracker::merge(const PeakTracker& other) {
  // Peaks of other streams: apart from ours by construction.
  for (const auto& p : other.candidates_) {
    candidates_.push_back(Peak{p.m, p.t, p.stream + (std::uint64_t{1} << 40)});
  }
  std::sort(candidates_.begin(), candidates_.end(), [](const Peak& a, const Peak& b) { return a.m > b.m; });
  if (candidates_.size() > kKeep) candidates_.resize(kKeep);
  smallest_ = INFINITY;
  for (const auto& p : candidates_) smallest_ = std::min(smallest_, p.m);
}

double PeakTracker::typical() const {
  if (candidates_.size() < 5) return 0;
  std::vector<double> others;
  for (const auto& p : candidates_) others.push_back(p.m);
  std::sort(others.begin(), others.end());
  others.pop_back();  // the max itself
  const std::size_t n = others.size();
  return n % 2 ? others[n / 2] : 0.5 * (others[n / 2 - 1] + others[n / 2]);
}

// ---- MagnitudeStats --------------------------------------------------------------------

void MagnitudeStats::merge(const MagnitudeStats& other) {
  samples_ += other.samples_;
  seconds_ += other.seconds_;
  squares_ += other.squares_;
  compensation_ += other.compensation_;
  histogram_.merge(other.histogram_);
  peaks_.merge(other.peaks_);
  // The rows judged by this state's rule belong to its tail as well.
  tail_.merge(other.tail_);
  if (other.max_ > max_) {
    max_ = other.max_;
    t_max_ = other.t_max_;
    where_max_ = other.where_max_;
  }
}

MagnitudeSummary MagnitudeStats::summary() const {
  MagnitudeSummary s;
  s.samples = samples_;
  s.seconds = seconds_;
  if (samples_ == 0) {
    s.rms = s.p99 = s.p999 = s.max = s.t_max = kNaN;
    return s;
  }
  s.rms = std::sqrt(std::max(0.0, squares_) / static_cast<double>(samples_));
  s.p99 = histogram_.quantile(0.99);
  s.p999 = histogram_.quantile(0.999);
  s.max = max_;
  s.t_max = t_max_;
  s.where_max = where_max_;
  s.typical_peak = peaks_.typical();
  return s;
}

// ---- EnvelopeFitter --------------------------------------------------------------------

void EnvelopeFitter::add(double v, double m) {
  v = std::fabs(v);
  m = std::fabs(m);
  if (!std::isfinite(v) || !std::isfinite(m)) return;
  const auto key = static_cast<long long>(std::floor(v / bin_width_));
  auto [it, inserted] = bins_.try_emplace(key, Bin{v, m});
  if (!inserted) {
    it->second.v_min = std::min(it->second.v_min, v);
    it->second.m_max = std::max(it->second.m_max, m);
  }
  ++count_;
  sum_v_ += v;
}

double EnvelopeFitter::mean_level(const JointThreshold::Envelope& e) const {
  return count_ ? e.a + e.b * (sum_v_ / static_cast<double>(count_)) : kNaN;
}

std::optional<JointThreshold::Envelope> EnvelopeFitter::fit() const {
  if (bins_.empty()) return std::nullopt;
  // Points in increasing v (bins are disjoint velocity intervals, so v_min is increasing).
  std::vector<Bin> points;
  points.reserve(bins_.size());
  for (const auto& [key, bin] : bins_) points.push_back(bin);
  // Upper convex hull, left to right (Andrew's monotone chain).
  std::vector<Bin> hull;
  for (const auto& p : points) {
    while (hull.size() >= 2) {
      const Bin& o = hull[hull.size() - 2];
      const Bin& a = hull.back();
      const double cross = (a.v_min - o.v_min) * (p.m_max - o.m_max) - (a.m_max - o.m_max) * (p.v_min - o.v_min);
      if (cross >= 0) hull.pop_back();  // a is on or below the segment o-p
      else break;
    }
    hull.push_back(p);
  }
  const double mean_v = sum_v_ / static_cast<double>(count_);
  auto intercept = [&](double b) {
    double a = -INFINITY;
    for (const auto& p : hull) a = std::max(a, p.m_max - b * p.v_min);
    return a;
  };
  // The objective a(b) + b mean_v is convex and piecewise linear in b with breaks at the hull's
  // edge slopes, so its minimum over b >= 0 is at b = 0 or at one of the positive slopes.
  double best_b = 0;
  double best = intercept(0);
  for (std::size_t i = 1; i < hull.size(); ++i) {
    const double dv = hull[i].v_min - hull[i - 1].v_min;
    if (!(dv > 0)) continue;
    const double b = (hull[i].m_max - hull[i - 1].m_max) / dv;
    if (!(b > 0) || !std::isfinite(b)) continue;
    const double level = intercept(b) + b * mean_v;
    if (level < best * (1 - 1e-12)) {
      best = level;
      best_b = b;
    }
  }
  JointThreshold::Envelope e{intercept(best_b), best_b};
  // Exact cover in floating point: raise a until every bin point is on or under the line.
  for (const auto& p : points) {
    while (e.a + e.b * p.v_min < p.m_max) e.a = std::nextafter(e.a, INFINITY);
  }
  return e;
}

// ---- JointTails, OutOfSample -----------------------------------------------------------

JointTails::JointTails(double window, std::size_t drifts)
    : moving(window), slow(window), rest_absolute(window), rest(drifts, TailSampler(window)) {}

void JointTails::begin_stream() {
  moving.begin_stream();
  slow.begin_stream();
  rest_absolute.begin_stream();
  for (auto& r : rest) r.begin_stream();
}

void JointTails::merge(const JointTails& other) {
  moving.merge(other.moving);
  slow.merge(other.slow);
  rest_absolute.merge(other.rest_absolute);
  for (std::size_t d = 0; d < rest.size() && d < other.rest.size(); ++d) rest[d].merge(other.rest[d]);
  moving_rows += other.moving_rows;
  slow_rows += other.slow_rows;
  rest_rows += other.rest_rows;
}

double OutOfSample::chance() const {
  if (!(expected >= 0) || stretches == 0) return NAN;
  if (crossings == 0) return 1;
  // P(N >= n) = 1 - sum_{k<n} e^-m m^k / k!, summed in logs so that a large mean does not
  // underflow its first term.
  double below = 0;
  for (std::uint64_t k = 0; k < crossings; ++k)
    below += std::exp(-expected + static_cast<double>(k) * std::log(expected) - std::lgamma(static_cast<double>(k) + 1));
  return std::clamp(1 - below, 0.0, 1.0);
}

// ---- Calibrator ------------------------------------------------------------------------

bool CalibrationOptions::IsValid(std::string* why) const {
  if (margin_nm && !(std::isfinite(*margin_nm) && *margin_nm >= 0)) return invalid(why, "margin must be >= 0 Nm");
  if (!(std::isfinite(margin_percent) && margin_percent >= 0)) return invalid(why, "margin percent must be >= 0");
  if (!rest_rule.IsValid(why)) return false;
  if (!(envelope_bin > 0 && std::isfinite(envelope_bin))) return invalid(why, "envelope bin width must be > 0");
  if (!(skip >= 0 && std::isfinite(skip))) return invalid(why, "skip must be >= 0 s");
  if (!(contact_ratio > 1 && std::isfinite(contact_ratio))) return invalid(why, "contact ratio must be > 1");
  if (!(false_alarms_per_hour > 0 && std::isfinite(false_alarms_per_hour)))
    return invalid(why, "false-alarm rate must be > 0 per hour");
  if (!(peak_window > 0 && std::isfinite(peak_window))) return invalid(why, "peak window must be > 0 s");
  if (!tail.IsValid(why)) return false;
  if (rest_drift_candidates.empty()) return invalid(why, "need at least one rest drift time");
  for (double d : rest_drift_candidates)
    if (!(d >= 0 && std::isfinite(d))) return invalid(why, "rest drift times must be >= 0 s");
  if (!(contact_rise > 0 && std::isfinite(contact_rise))) return invalid(why, "contact rise time must be > 0 s");
  if (!(min_state_samples >= 1)) return invalid(why, "a state needs at least 1 row");
  return true;
}

ThresholdRule parse_threshold_rule(std::string_view name) {
  if (name == "rate") return ThresholdRule::rate;
  if (name == "max") return ThresholdRule::max;
  throw Error("unknown threshold rule '" + std::string(name) + "' (rate or max)");
}

bool CalibrationResult::any_contact() const {
  for (const auto& j : joints)
    if (j.moving_contact || j.slow_contact || j.rest_contact) return true;
  return false;
}

double CalibrationResult::vouched_false_alarms_per_hour() const {
  CalibrationResult vouched;
  vouched.thresholds = thresholds;
  vouched.joints = joints;
  vouched.false_alarms_per_hour = false_alarms_per_hour;
  for (auto& c : vouched.joints)
    for (ThresholdBasis* b : {&c.moving_basis, &c.slow_basis, &c.rest_basis}) b->per_hour = b->vouched_per_hour;
  return vouched.expected_false_alarms_per_hour();
}

double CalibrationResult::expected_false_alarms_per_hour() const {
  double total = 0;
  bool any = false;
  for (std::size_t j = 0; j < joints.size() && j < thresholds.joints.size(); ++j) {
    const JointCalibration& c = joints[j];
    const JointThreshold& T = thresholds.joints[j];
    const MagnitudeSummary& rest = T.rest_absolute ? c.rest_absolute : c.rest;
    const double seconds = c.moving.seconds + c.slow.seconds + rest.seconds;
    if (!(seconds > 0)) continue;
    any = true;
    auto rate = [&](const ThresholdBasis& basis) {
      return std::isfinite(basis.per_hour) ? basis.per_hour : false_alarms_per_hour;
    };
    // A state without a threshold of its own is judged (and was calibrated) with the next
    // rule down, so its time counts at that rule's rate.
    const double moving = rate(c.moving_basis);
    const double slow = T.slow ? rate(c.slow_basis) : moving;
    const double at_rest = T.rest ? rate(c.rest_basis) : slow;
    total += (moving * c.moving.seconds + slow * c.slow.seconds + at_rest * rest.seconds) / seconds;
  }
  return any ? total : NAN;
}

Calibrator::Calibrator(Signal signal, std::size_t joints, CalibrationOptions options)
    : signal_(signal), options_(std::move(options)) {
  std::string why;
  if (!options_.IsValid(&why)) throw Error(why);
  if (joints == 0) throw Error("no joints to calibrate");
  const std::size_t drifts = options_.rest_drift_candidates.size();
  for (std::size_t j = 0; j < joints; ++j)
    joints_.push_back(Joint{RestTracker(options_.rest_rule), MagnitudeStats(options_.peak_window),
                            MagnitudeStats(options_.peak_window),
                            std::vector<MagnitudeStats>(drifts, MagnitudeStats(options_.peak_window)),
                            std::vector<DriftingBaseline>(drifts), false, MagnitudeStats(options_.peak_window),
                            EnvelopeFitter(options_.envelope_bin)});
}

void Calibrator::begin_part(const std::string& name) {
  // A stretch that holds no row counted yet is continued, not left out on its own.
  if (!parts_.empty()) {
    bool empty = true;
    for (const auto& P : parts_.back().joints) empty = empty && P.moving_rows + P.slow_rows + P.rest_rows == 0;
    if (empty) {
      parts_.back().name = name;
      for (auto& P : parts_.back().joints) P.begin_stream();
      return;
    }
  }
  parts_.push_back(Part{name, std::vector<JointTails>(joints_.size(), JointTails(options_.peak_window, options_.rest_drift_candidates.size()))});
}

void Calibrator::begin_stretch(const std::string& name) {
  begin_part(name);
  begin_joint_streams();
  for (auto& J : joints_) J.tracker.restart();
  t_prev_ = kNaN;
}

void Calibrator::begin_joint_streams() {
  for (auto& J : joints_) {
    J.moving.begin_stream();
    J.slow.begin_stream();
    for (auto& r : J.rest) r.begin_stream();
    J.rest_absolute.begin_stream();
    J.was_rest = false;
  }
}

void Calibrator::begin_stream(const std::string& name, bool have_velocity) {
  begin_part(name);
  streams_.push_back(name);
  begin_joint_streams();
  have_velocity_ = have_velocity_ && have_velocity;
  t_prev_ = kNaN;
  t_start_ = kNaN;
  for (auto& J : joints_) J.tracker.restart();
}

CalibrationResult Calibrator::result() const {
  CalibrationResult out;
  out.rows = rows_;
  out.streams = streams_;
  out.have_velocity = have_velocity_;
  out.states = options_.rest_state;
  out.rule = options_.rule;
  out.rest_drift_candidates = options_.rest_drift_candidates;
  out.false_alarms_per_hour = options_.false_alarms_per_hour;
  out.thresholds.signal = signal_;
  out.thresholds.rest_rule = options_.rest_rule;
  out.thresholds.rest_raw = rest_raw_ && signal_ == Signal::mu;
  if (signal_ == Signal::mu && !options_.friction_band.empty()) {
    out.thresholds.friction_band = options_.friction_band.sigmas();
    for (std::size_t j = 0; j < joints_.size(); ++j) out.friction_band_static.push_back(options_.friction_band.width(j, 0.0));
  }
  if (options_.margin_nm) out.thresholds.margin_nm = *options_.margin_nm;
  else out.thresholds.margin_percent = options_.margin_percent;
  const std::string sig(signal_name(signal_));
  if (!options_.rest_state)
    out.notes.push_back("motion states off (--no-rest): one threshold per joint for every row");
  else if (!have_velocity_)
    out.notes.push_back("a stream without dq columns: its rows count as moving (no slow or rest state" +
                        std::string(options_.envelope ? ", no envelope" : "") + " from it)");
  auto contact = [&](const MagnitudeSummary& s, const ThresholdBasis& basis) {
    if (options_.rule == ThresholdRule::rate && basis.tail.ok) return !basis.tail.outliers.empty();
    const bool above_peaks = s.typical_peak > 0 && s.max > options_.contact_ratio * s.typical_peak;
    const bool above_quantile = s.seconds >= 1000 && s.max > options_.contact_ratio * s.p999;
    return s.samples >= 1000 && (above_peaks || above_quantile);
  };
  std::vector<JointTails> all_tails;
  for (const auto& J : joints_) {
    JointTails& tails = all_tails.emplace_back(options_.peak_window, J.rest.size());
    tails.moving = J.moving.tail();
    tails.slow = J.slow.tail();
    tails.rest_absolute = J.rest_absolute.tail();
    for (std::size_t d = 0; d < J.rest.size(); ++d) tails.rest[d] = J.rest[d].tail();
    tails.moving_rows = J.moving.samples();
    tails.slow_rows = J.slow.samples();
    tails.rest_rows = J.rest.front().samples();
  }
  const std::vector<JointDecision> decisions = decide_joints(all_tails);
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    const auto& J = joints_[j];
    const std::string name = sig + std::to_string(j + 1);
    const std::string joint = "joint " + std::to_string(j + 1);
    JointCalibration c;
    c.moving = J.moving.summary();
    c.slow = J.slow.summary();
    c.rest = J.rest.front().summary();
    c.rest_absolute = J.rest_absolute.summary();
    if (c.moving.samples + c.slow.samples + c.rest.samples == 0) throw Error(name + ": no finite sample to calibrate on");
    const JointDecision& decision = decisions[j];
    JointThreshold T = decision.threshold;
    c.moving_basis = decision.moving_basis;
    c.slow_basis = decision.slow_basis;
    c.rest_basis = decision.rest_basis;
    c.rest_drift_costs = decision.rest_drift_costs;
    // A state with too few rows for a threshold of its own is judged by the next rule down
    // (rest -> slow -> moving), exactly as the detector falls back, so its rows (with |x|)
    // join that state's data here.
    MagnitudeStats slow = J.slow, moving = J.moving;
    EnvelopeFitter envelope = J.envelope;
    if (T.rest) {
      c.rest = J.rest[decision.rest_drift_index].summary();
      c.rest_drift = options_.rest_drift_candidates[decision.rest_drift_index];
      const MagnitudeSummary& chosen = T.rest_absolute ? c.rest_absolute : c.rest;
      T.rest_band = chosen.p99;
      c.rest_contact = contact(chosen, c.rest_basis);
    } else if (decision.rest_judged_slow) {
      slow.merge(J.rest_absolute);
      out.notes.push_back(joint + ": " + std::to_string(c.rest.samples) + " rest rows (fewer than " +
                          std::to_string(options_.min_state_samples) + "): judged by the slow rule");
    }
    const MagnitudeSummary slow_all = slow.summary();
    if (T.slow) {
      T.slow_band = slow_all.p99;
      c.slow_contact = contact(slow_all, c.slow_basis);
    } else if (decision.slow_judged_moving) {
      moving.merge(slow);
      // The envelope must cover these rows too: a point at |dq| = 0 with their largest |x|
      // does, as the line's slope is >= 0.
      envelope.add(0, slow_all.max);
      out.notes.push_back(joint + ": " + std::to_string(slow_all.samples) + " slow or rest rows (fewer than " +
                          std::to_string(options_.min_state_samples) + "): judged by the moving rule");
    }
    const MagnitudeSummary moving_all = moving.summary();
    if (!decision.never_moved) {
      T.band = moving_all.p99;
      c.moving_contact = contact(moving_all, c.moving_basis);
    } else {
      // Never moved: the moving rule still needs a value (it judges rows with unknown speed).
      T.band = std::max(T.slow_band, c.rest_absolute.p99);
      out.notes.push_back(joint + " never moved: its moving threshold is its largest |" + name + "| at low speed");
    }
    if (options_.envelope && envelope.count() > 0) {
      c.envelope_raw = envelope.fit();
      if (c.envelope_raw) {
        JointThreshold::Envelope e = *c.envelope_raw;
        if (options_.margin_nm) {
          e.a += *options_.margin_nm;
        } else {
          e.a *= 1 + options_.margin_percent / 100;
          e.b *= 1 + options_.margin_percent / 100;
        }
        if (e.a > 0) {
          T.envelope = e;
          c.envelope_mean = envelope.mean_level(e);
        }
      }
    }
    auto warn_contact = [&](const char* state, const MagnitudeSummary& s, const ThresholdBasis& basis) {
      if (options_.rule == ThresholdRule::rate && basis.tail.ok) {
        for (std::size_t k = 0; k < basis.tail.outliers.size(); ++k) {
          const TailPeak& o = basis.tail.outliers[k];
          const bool seen_elsewhere = k < basis.tail.corroborated.size() && basis.tail.corroborated[k];
          out.warnings.push_back(
              name + " " + state + ": " + core::significant(o.m, 6) + " Nm at " + o.where + " (t=" + core::significant(o.t, 6) +
              " s) is an outlier, left out of the threshold: the tail of the " + std::to_string(basis.tail.tail.peaks) +
              " largest other peaks reaches it with probability under " +
              core::significant(seen_elsewhere ? options_.tail.corroborated_probability : options_.tail.outlier_probability, 3) +
              (seen_elsewhere ? ", at the time another joint's peak was left out (an abrupt stop or a glitch that several joints saw?)"
                              : " (a glitch, an abrupt stop, or a contact?)"));
        }
        return;
      }
      out.warnings.push_back(name + " " + state + ": max " + core::significant(s.max, 6) + " Nm at " + s.where_max + " (t=" +
                             core::significant(s.t_max, 6) + " s) is " + core::significant(s.max / s.p999, 3) + " times p99.9 and " +
                             (s.typical_peak > 0 ? core::significant(s.max / s.typical_peak, 3) : std::string("?")) +
                             " times the typical peak: looks like a contact, not noise");
    };
    if (c.moving_contact) warn_contact("moving", moving_all, c.moving_basis);
    if (c.slow_contact) warn_contact("slow", slow_all, c.slow_basis);
    if (c.rest_contact)
      warn_contact(T.rest_absolute ? "at rest" : "at rest (deviation)", T.rest_absolute ? c.rest_absolute : c.rest,
                   c.rest_basis);
    if (!(T.moving > 0))
      throw Error(name + ": the residual is 0 on every row; a percent margin gives no threshold (use --margin in Nm)");
    out.thresholds.joints.push_back(T);
    out.joints.push_back(c);
  }
  out.out_of_sample = check_out_of_sample();
  return out;
}

namespace {
// The stream part of a peak's location (`file:line`, or `file: byte N` for binary streams).
std::string_view stream_of(std::string_view where) {
  if (const auto byte = where.rfind(": byte "); byte != std::string_view::npos) return where.substr(0, byte);
  const auto colon = where.rfind(':');
  return colon == std::string_view::npos ? where : where.substr(0, colon);
}
}  // namespace

std::vector<JointDecision> Calibrator::decide_joints(const std::vector<JointTails>& tails) const {
  std::vector<JointDecision> decisions;
  for (const auto& t : tails) decisions.push_back(decide_joint(t));
  std::vector<std::vector<TailPeak>> left_out(tails.size());
  bool any = false;
  for (std::size_t j = 0; j < decisions.size(); ++j)
    for (const ThresholdBasis* b : {&decisions[j].moving_basis, &decisions[j].slow_basis, &decisions[j].rest_basis})
      for (const TailPeak& o : b->tail.outliers) {
        left_out[j].push_back(o);
        any = true;
      }
  if (!any || options_.rule != ThresholdRule::rate) return decisions;
  for (std::size_t j = 0; j < tails.size(); ++j) {
    auto seen_elsewhere = [&](const TailPeak& p) {
      for (std::size_t k = 0; k < left_out.size(); ++k)
        if (k != j)
          for (const TailPeak& o : left_out[k])
            if (std::fabs(o.t - p.t) <= options_.peak_window && stream_of(o.where) == stream_of(p.where)) return true;
      return false;
    };
    decisions[j] = decide_joint(tails[j], seen_elsewhere);
  }
  return decisions;
}

JointDecision Calibrator::decide_joint(const JointTails& tails,
                                       const std::function<bool(const TailPeak&)>& corroborated) const {
  JointDecision out;
  JointThreshold& T = out.threshold;
  auto with_margin = [&](double x) {
    return options_.margin_nm ? x + *options_.margin_nm : x * (1 + options_.margin_percent / 100);
  };
  // The threshold of one state from its peaks, and how it was decided.
  auto decide = [&](const TailSampler& sampler, ThresholdBasis* basis) {
    const std::vector<TailPeak> largest = sampler.largest();
    basis->tail = fit_tail(largest, sampler.peaks(), sampler.seconds(), options_.tail, corroborated);
    double threshold = with_margin(largest.empty() ? 0.0 : largest.front().m);
    if (options_.rule == ThresholdRule::rate && basis->tail.ok) {
      const double floor = with_margin(basis->tail.largest_kept);
      // The level of the asked rate, also where the data cannot vouch for it (thin data):
      // the threshold is then the tail's extrapolation, and vouched_per_hour says what the
      // data do vouch for.
      const double level = basis->tail.tail.level(options_.false_alarms_per_hour);
      basis->from_tail = level > floor;
      threshold = std::max(level, floor);
    }
    if (basis->tail.ok) {
      basis->per_hour = basis->tail.tail.rate_over(threshold);
      basis->vouched_per_hour = std::max(basis->per_hour, basis->tail.supported_per_hour);
    } else {
      // Without a tail, the largest peak + margin: crossed about once per exposure, as far as
      // the data say.
      basis->vouched_per_hour = basis->tail.supported_per_hour;
    }
    return threshold;
  };
  TailSampler slow = tails.slow, moving = tails.moving;
  std::uint64_t slow_rows = tails.slow_rows, moving_rows = tails.moving_rows;
  if (tails.rest_rows >= options_.min_state_samples) {
    // Whichever rest statistic needs the lower threshold on these data: the deviation from
    // the settled baseline (static friction held at rest cancels out), or the plain |x|
    // (better when the residual moves at rest, e.g. a controller ramping torque against
    // stiction before a breakaway, while the friction model holds its level).
    // Among the drift times, the one that sees the smallest contact of the rise time aimed at.
    ThresholdBasis deviation_basis, absolute_basis;
    double deviation = INFINITY, best_cost = INFINITY;
    for (std::size_t d = 0; d < tails.rest.size(); ++d) {
      ThresholdBasis basis;
      const double threshold = decide(tails.rest[d], &basis);
      const double cost = threshold / drift_gain(options_.rest_drift_candidates[d], options_.contact_rise);
      out.rest_drift_costs.emplace_back(threshold, cost);
      if (cost < best_cost) {
        best_cost = cost;
        deviation = threshold;
        deviation_basis = basis;
        out.rest_drift_index = d;
      }
    }
    const double absolute = decide(tails.rest_absolute, &absolute_basis);
    T.rest_absolute = absolute < best_cost;
    T.rest_drift = T.rest_absolute ? 0 : options_.rest_drift_candidates[out.rest_drift_index];
    out.rest_basis = T.rest_absolute ? absolute_basis : deviation_basis;
    T.rest = T.rest_absolute ? absolute : deviation;
  } else if (tails.rest_rows > 0) {
    slow.merge(tails.rest_absolute);
    slow_rows += tails.rest_rows;
    out.rest_judged_slow = true;
  }
  if (slow_rows >= options_.min_state_samples) {
    T.slow = decide(slow, &out.slow_basis);
  } else if (slow_rows > 0) {
    moving.merge(slow);
    moving_rows += slow_rows;
    out.slow_judged_moving = true;
  }
  if (moving_rows > 0) {
    T.moving = decide(moving, &out.moving_basis);
  } else {
    // Never moved: the moving rule still needs a value (it judges rows with unknown speed).
    out.never_moved = true;
    const auto at_rest = tails.rest_absolute.largest();
    T.moving = std::max(T.slow.value_or(0), T.rest_absolute ? T.rest.value_or(0) : with_margin(at_rest.empty() ? 0.0 : at_rest.front().m));
    // Not data of its own: it stands for what the state it was taken from does.
    out.moving_basis.per_hour = T.slow ? out.slow_basis.per_hour : out.rest_basis.per_hour;
    out.moving_basis.vouched_per_hour = T.slow ? out.slow_basis.vouched_per_hour : out.rest_basis.vouched_per_hour;
  }
  return out;
}

OutOfSample Calibrator::check_out_of_sample() const {
  OutOfSample out;
  std::vector<std::size_t> parts;  // the stretches with counted rows
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    std::uint64_t rows = 0;
    for (const auto& P : parts_[i].joints) rows += P.moving_rows + P.slow_rows + P.rest_rows;
    if (rows > 0) parts.push_back(i);
  }
  if (!options_.out_of_sample || parts.size() < 2) return out;
  out.stretches = parts.size();
  const char* names[] = {"moving", "slow", "rest"};
  for (std::size_t j = 0; j < joints_.size(); ++j)
    for (const char* state : names) {
      OutOfSample::State s;
      s.joint = j;
      s.state = state;
      out.states.push_back(s);
    }
  // What each left-out calibration stands for: the rate its data vouch for.
  auto rate = [&](const ThresholdBasis& basis) {
    return std::isfinite(basis.vouched_per_hour) ? basis.vouched_per_hour : options_.false_alarms_per_hour;
  };
  // The full calibration's decisions: which states have a threshold of their own.
  std::vector<JointTails> all;
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    JointTails& merged = all.emplace_back(options_.peak_window, options_.rest_drift_candidates.size());
    for (const std::size_t k : parts) merged.merge(parts_[k].joints[j]);
  }
  const std::vector<JointDecision> full = decide_joints(all);
  for (const std::size_t i : parts) {
    std::vector<JointTails> others;
    for (std::size_t j = 0; j < joints_.size(); ++j) {
      JointTails& merged = others.emplace_back(options_.peak_window, options_.rest_drift_candidates.size());
      for (const std::size_t k : parts)
        if (k != i) merged.merge(parts_[k].joints[j]);
    }
    const std::vector<JointDecision> decisions = decide_joints(others);
    for (std::size_t j = 0; j < joints_.size(); ++j) {
      const JointTails& held = parts_[i].joints[j];
      if (others[j].moving_rows + others[j].slow_rows + others[j].rest_rows == 0) continue;
      const JointDecision& d = decisions[j];
      const JointThreshold& T = d.threshold;
      // Each state's rows judged by the rule the detector applies to them.
      struct Rule {
        double threshold;
        double per_hour;
      };
      const Rule moving{T.moving, rate(d.moving_basis)};
      const Rule slow = T.slow ? Rule{*T.slow, rate(d.slow_basis)} : moving;
      const Rule rest = T.rest ? Rule{*T.rest, rate(d.rest_basis)} : slow;
      const TailSampler& rest_peaks = T.rest && !T.rest_absolute ? held.rest[d.rest_drift_index] : held.rest_absolute;
      const std::pair<const TailSampler*, Rule> judged[] = {{&held.moving, moving}, {&held.slow, slow}, {&rest_peaks, rest}};
      // A state the full calibration decides from rows of its own, but the other stretches hold
      // too few of (all of them are in this one): the left-out calibration judges it by the
      // rule of another state (never moved: the slow threshold for motion), whose rate it never
      // stated for this state's time. Not a test of the calibration: counted apart.
      const JointDecision& f = full[j];
      const bool borrowed[] = {d.never_moved && !f.never_moved, !T.slow && f.threshold.slow.has_value(),
                               !T.rest && f.threshold.rest.has_value()};
      for (std::size_t s = 0; s < 3; ++s) {
        OutOfSample::State& state = out.states[3 * j + s];
        const TailSampler& peaks = *judged[s].first;
        const double seconds = peaks.seconds();
        const double threshold = judged[s].second.threshold;
        const std::vector<TailPeak> largest = peaks.largest();
        // The detector's events: excursions over the threshold, i.e. the peaks over it whose
        // valley before them lies under it (later peaks of one excursion are not new events).
        std::size_t over = 0, events = 0;
        for (; over < largest.size() && largest[over].m > threshold; ++over) events += largest[over].valley < threshold;
        if (borrowed[s]) {
          state.unchecked_seconds += seconds;
          state.unchecked_crossings += events;
          continue;
        }
        state.seconds += seconds;
        state.expected += judged[s].second.per_hour * seconds / 3600;
        state.crossings += events;
        state.at_least = state.at_least || (over == largest.size() && peaks.peaks() > largest.size());
        for (std::size_t k = 0; k < over; ++k)
          if (largest[k].valley < threshold) state.first.push_back(largest[k]);
      }
    }
  }
  for (auto& state : out.states) {
    std::sort(state.first.begin(), state.first.end(), [](const TailPeak& a, const TailPeak& b) { return a.m > b.m; });
    if (state.first.size() > 3) state.first.resize(3);
    out.crossings += state.crossings;
    out.expected += state.expected;
    out.unchecked_seconds += state.unchecked_seconds;
  }
  // The data's time: per joint it is the same, so one joint's states give it.
  for (std::size_t s = 0; s < 3 && s < out.states.size(); ++s) out.seconds += out.states[s].seconds + out.states[s].unchecked_seconds;
  return out;
}

std::string format_out_of_sample(const CalibrationResult& r) {
  const std::string sig(signal_name(r.thresholds.signal));
  const OutOfSample& o = r.out_of_sample;
  if (o.stretches < 2) return "# " + sig + " out of sample: not checked (the data are one stretch)\n";
  const double hours = o.seconds / 3600;
  std::string out = "# " + sig + " out of sample: " + std::to_string(o.stretches) +
                    " stretches, each left out in turn: " + std::to_string(o.crossings) + " false alarms in " +
                    core::significant(hours, 3) + " h (" + core::significant(o.seen_per_hour(), 3) + " per h), stated " +
                    core::significant(o.expected, 3) + " (" + core::significant(o.stated_per_hour(), 3) + " per h); as many or more by chance: " +
                    core::significant(o.chance(), 3) + "\n";
  for (const auto& s : o.states) {
    if (s.unchecked_seconds > 0)
      out += "# out of sample " + sig + std::to_string(s.joint + 1) + " " + s.state + ": " + core::significant(s.unchecked_seconds, 4) +
             " s not checked (left out, the other stretches have too few " + s.state + " rows for a threshold of their own; " +
             std::to_string(s.unchecked_crossings) + " over the one they borrow)\n";
    if (s.crossings == 0) continue;
    out += "# out of sample " + sig + std::to_string(s.joint + 1) + " " + s.state + ": " + (s.at_least ? ">=" : "") +
           std::to_string(s.crossings) + " in " + core::significant(s.seconds, 4) + " s, stated " + core::significant(s.expected, 3);
    for (std::size_t k = 0; k < s.first.size(); ++k)
      out += (k ? ", " : "; largest ") + core::significant(s.first[k].m, 4) + " Nm at " + s.first[k].where + " (t=" +
             core::significant(s.first[k].t, 6) + " s)";
    out += "\n";
  }
  return out;
}

std::string format_calibration_report(const CalibrationResult& r) {
  const std::string sig(signal_name(r.thresholds.signal));
  std::string out;
  out += "# signal " + sig + ": " + std::to_string(r.streams.size()) + " stream" + (r.streams.size() == 1 ? "" : "s") +
         ", " + std::to_string(r.rows) + " rows; margin ";
  out += r.thresholds.margin_nm ? core::significant(*r.thresholds.margin_nm, 6) + " Nm" : core::significant(r.thresholds.margin_percent.value_or(0), 6) + "%";
  if (r.rule == ThresholdRule::rate)
    out += "; rule rate: " + core::significant(r.false_alarms_per_hour, 3) + " false alarms per hour of each state";
  else
    out += "; rule max";
  if (r.states)
    out += "; slow when |dq| < " + core::significant(r.thresholds.rest_rule.velocity, 6) + " rad/s (and " +
           core::significant(r.thresholds.rest_rule.hangover, 6) + " s after), at rest after " + core::significant(r.thresholds.rest_rule.time, 6) +
           " s of it (rest: |" + sig + " - baseline|, rest_abs: |" + sig + "| at rest)\n";
  else
    out += "; no motion states\n";
  char line[512];
  std::snprintf(line, sizeof line, "%-6s %-5s %-8s %10s %10s %10s %10s %10s %10s %10s %10s %10s  %s\n", "signal",
                "joint", "state", "samples", "seconds", "rms", "p99", "p99.9", "max", "t_max", "threshold", "fa_per_h",
                "where");
  out += line;
  for (std::size_t j = 0; j < r.joints.size(); ++j) {
    const auto& c = r.joints[j];
    const auto& T = r.thresholds.joints[j];
    auto row = [&](const char* state, const MagnitudeSummary& s, std::string threshold, const ThresholdBasis* basis) {
      if (s.samples == 0) return;
      // Rates far below any a log could show are only the tail's arithmetic: a bound suffices.
      std::string rate = "-";
      if (basis && std::isfinite(basis->per_hour)) rate = basis->per_hour < 1e-6 ? "<1e-6" : core::significant(basis->per_hour, 3);
      std::snprintf(line, sizeof line, "%-6s %-5zu %-8s %10llu %10s %10s %10s %10s %10s %10s %10s %10s  %s\n",
                    sig.c_str(), j + 1, state, static_cast<unsigned long long>(s.samples), core::significant(s.seconds, 6).c_str(),
                    core::significant(s.rms, 6).c_str(), core::significant(s.p99, 6).c_str(), core::significant(s.p999, 6).c_str(), core::significant(s.max, 6).c_str(),
                    core::significant(s.t_max, 6).c_str(), threshold.c_str(), rate.c_str(), s.where_max.c_str());
      out += line;
    };
    row("moving", c.moving, core::significant(T.moving, 6), &c.moving_basis);
    row("slow", c.slow, T.slow ? core::significant(*T.slow, 6) : "-", T.slow ? &c.slow_basis : nullptr);
    row("rest", c.rest, T.rest && !T.rest_absolute ? core::significant(*T.rest, 6) : "-", T.rest && !T.rest_absolute ? &c.rest_basis : nullptr);
    row("rest_abs", c.rest_absolute, T.rest && T.rest_absolute ? core::significant(*T.rest, 6) : "-",
        T.rest && T.rest_absolute ? &c.rest_basis : nullptr);
  }
  // The tails behind the thresholds: what a reader needs to judge the extrapolation.
  for (std::size_t j = 0; j < r.joints.size(); ++j) {
    const auto& c = r.joints[j];
    auto tail_line = [&](const char* state, const ThresholdBasis& b) {
      if (!b.tail.ok) {
        if (!b.tail.why.empty() && r.rule == ThresholdRule::rate)
          out += "# joint " + std::to_string(j + 1) + " " + state + " tail: " + b.tail.why + "; max + margin\n";
        return;
      }
      const ParetoTail& p = b.tail.tail;
      out += "# joint " + std::to_string(j + 1) + " " + state + " tail: " + std::to_string(p.peaks) + " peaks over " +
             core::significant(p.u0, 4) + " Nm in " + core::significant(b.tail.seconds / 3600, 3) + " h (" + core::significant(p.rate, 3) +
             " per h), sigma " + core::significant(p.sigma, 3) + " Nm, " +
             (p.xi == 0 ? "exponential" : "xi " + core::significant(p.xi, 3)) +
             (std::isnan(b.tail.shape) || p.xi == b.tail.shape ? "" : " (fitted shape xi " + core::significant(b.tail.shape, 3) + ")") +
             "; threshold from " +
             (b.from_tail ? "the tail" : "the largest peak + margin") + "\n";
    };
    // What the threshold rests on, and the rarest rate those data vouch for.
    auto data_line = [&](const char* state, const ThresholdBasis& b) {
      if (!(b.tail.seconds > 0)) return;
      const double vouched = b.tail.supported_per_hour;
      out += "# joint " + std::to_string(j + 1) + " " + state + " data: " + core::significant(b.tail.seconds, 4) + " s, " +
             std::to_string(b.tail.peaks) + " independent peaks, " + std::to_string(b.tail.outliers.size()) +
             " left out; they vouch for rates down to " + core::significant(vouched, 3) + " per h";
      if (r.rule == ThresholdRule::rate && vouched > r.false_alarms_per_hour)
        out += ", not the " + core::significant(r.false_alarms_per_hour, 3) + " asked (" +
               core::significant(vouched / r.false_alarms_per_hour, 3) + " times rarer): the threshold stands for " +
               core::significant(b.vouched_per_hour, 3);
      out += "\n";
    };
    if (r.thresholds.joints[j].rest && !r.thresholds.joints[j].rest_absolute && !c.rest_drift_costs.empty()) {
      out += "# joint " + std::to_string(j + 1) + " rest baseline: follows drift at " + core::significant(c.rest_drift, 6) + " s (" +
             "drift time: threshold, smallest contact seen";
      for (std::size_t d = 0; d < c.rest_drift_costs.size() && d < r.rest_drift_candidates.size(); ++d)
        out += (d ? "; " : ": ") + core::significant(r.rest_drift_candidates[d], 6) + " s: " + core::significant(c.rest_drift_costs[d].first, 3) +
               ", " + core::significant(c.rest_drift_costs[d].second, 3) + " Nm";
      out += ")\n";
    }
    tail_line("moving", c.moving_basis);
    if (r.thresholds.joints[j].slow) tail_line("slow", c.slow_basis);
    if (r.thresholds.joints[j].rest) tail_line("rest", c.rest_basis);
    data_line("moving", c.moving_basis);
    if (r.thresholds.joints[j].slow) data_line("slow", c.slow_basis);
    if (r.thresholds.joints[j].rest) data_line("rest", c.rest_basis);
  }
  for (std::size_t j = 0; j < r.joints.size(); ++j) {
    const auto& c = r.joints[j];
    const auto& T = r.thresholds.joints[j];
    if (T.envelope)
      out += "# joint " + std::to_string(j + 1) + " envelope: " + core::significant(T.envelope->a, 6) + " + " + core::significant(T.envelope->b, 6) +
             " |dq| Nm (mean over the moving rows " + core::significant(c.envelope_mean, 6) + " Nm, constant " + core::significant(T.moving, 6) + " Nm)\n";
  }
  for (std::size_t j = 0; j < r.friction_band_static.size(); ++j)
    if (r.friction_band_static[j] > 0)
      out += "# joint " + std::to_string(j + 1) + " friction band: " + core::significant(r.thresholds.friction_band, 3) +
             " sd of the friction model's steady state, " + core::significant(r.friction_band_static[j], 3) +
             " Nm near standstill: moving rows count beyond it\n";
  // The statement is what the data can back: a rate extrapolated beyond them is the thresholds'
  // aim, not a promise, and is said to be one.
  const double expected = r.expected_false_alarms_per_hour();
  const double stated = r.vouched_false_alarms_per_hour();
  if (std::isfinite(stated) && std::isfinite(expected) && stated > expected * (1 + 1e-9))
    out += "# " + sig + " false alarms stated: " + core::significant(stated, 3) +
           " per hour of logs like these (every joint and state at the rarest rate its data vouch for); the thresholds aim at " +
           core::significant(expected, 3) + " per hour, " + core::significant(stated / expected, 3) +
           " times rarer than these data can confirm: more collision-free data state less\n";
  else if (std::isfinite(stated))
    out += "# " + sig + " false alarms stated: " + core::significant(stated, 3) +
           " per hour of logs like these (every joint and state at its rate and share of the time; the data vouch for it)\n";
  out += format_out_of_sample(r);
  for (const auto& note : r.notes) out += "# note: " + note + "\n";
  for (const auto& warning : r.warnings) out += "# warning: " + warning + "\n";
  return out;
}

}  // namespace momentum::calibrate

namespace momentum::calibrate {

std::string format_threshold_changes(const Thresholds* old, const Thresholds& updated) {
  const std::string sig(signal_name(updated.signal));
  if (!old) return "# " + sig + ": the profile had no thresholds for " + sig + "\n";
  if (old->joints.size() != updated.joints.size())
    return "# " + sig + ": the profile had thresholds for " + std::to_string(old->joints.size()) + " joints\n";
  std::string out;
  for (std::size_t j = 0; j < updated.joints.size(); ++j) {
    const auto& a = old->joints[j];
    const auto& b = updated.joints[j];
    auto line = [&](const char* state, std::optional<double> before, std::optional<double> after) {
      if (!before && !after) return;
      out += "# change " + sig + std::to_string(j + 1) + " " + state + " " + (before ? core::significant(*before, 6) : "-") + " -> " +
             (after ? core::significant(*after, 6) : "-") + " Nm";
      if (before && after) out += " " + core::signed_fixed(100 * (*after - *before) / *before, 1) + "%";
      out += "\n";
    };
    line("moving", a.moving, b.moving);
    line("slow", a.slow, b.slow);
    line("rest", a.rest, b.rest);
  }
  return out;
}

std::vector<std::string> threshold_rises(const Thresholds& old, const Thresholds& updated, double factor) {
  std::vector<std::string> out;
  if (old.joints.size() != updated.joints.size()) return out;
  const std::string sig(signal_name(updated.signal));
  for (std::size_t j = 0; j < updated.joints.size(); ++j) {
    auto check = [&](const char* state, std::optional<double> before, std::optional<double> after) {
      if (!before || !after || !(*before > 0) || !(*after > factor * *before)) return;
      out.push_back(sig + std::to_string(j + 1) + " " + state + " " + core::significant(*before, 6) + " -> " + core::significant(*after, 6) + " Nm, " +
                    core::significant(*after / *before, 3) + " times");
    };
    check("moving", old.joints[j].moving, updated.joints[j].moving);
    check("slow", old.joints[j].slow, updated.joints[j].slow);
    check("rest", old.joints[j].rest, updated.joints[j].rest);
  }
  return out;
}

}  // namespace momentum::calibrate
