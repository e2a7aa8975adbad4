#include "momentum/calibrate/tail.hpp"

#include <algorithm>

#include "momentum/core/error.hpp"

namespace momentum::calibrate {

namespace {

bool heap_order(const TailPeak& a, const TailPeak& b) { return a.m > b.m; }  // min-heap on m

// Survival of the generalised Pareto distribution at y >= 0.
double pareto_survival(double y, double sigma, double xi) {
  if (y <= 0) return 1;
  if (std::fabs(xi) < 1e-9) return std::exp(-y / sigma);
  const double base = 1 + xi * y / sigma;
  if (base <= 0) return 0;  // beyond the end point of a bounded tail
  return std::pow(base, -1 / xi);
}

struct Moments {
  double sigma, xi;
};

// Probability-weighted moments of exceedances y (ascending), Hosking and Wallis (1987), with the
// shape clamped to [xi_min, xi_max] and the scale then matched to the mean.
Moments pareto_moments(const std::vector<double>& y, const TailFitOptions& options) {
  const double n = static_cast<double>(y.size());
  double a0 = 0, a1 = 0;
  for (std::size_t j = 0; j < y.size(); ++j) {
    a0 += y[j];
    a1 += (n - 1 - static_cast<double>(j)) / (n - 1) * y[j];
  }
  a0 /= n;
  a1 /= n;
  Moments m{0, 0};
  const double d = a0 - 2 * a1;
  if (d > 0 && a0 > 0) {
    m.xi = -(a0 / d - 2);  // Hosking's k = -xi
    m.sigma = 2 * a0 * a1 / d;
  }
  if (!(m.sigma > 0) || !(m.xi >= options.xi_min && m.xi <= options.xi_max)) {
    m.xi = std::clamp(std::isfinite(m.xi) ? m.xi : 0.0, options.xi_min, options.xi_max);
    m.sigma = a0 * (1 - m.xi);  // the mean of the distribution is sigma / (1 - xi)
  }
  return m;
}

// The exponential tail (xi = 0) with the mean excess as scale.
Moments exponential_moments(const std::vector<double>& y) {
  double mean = 0;
  for (double v : y) mean += v;
  return Moments{mean / static_cast<double>(y.size()), 0};
}

}  // namespace

TailSampler::TailSampler(double window, std::size_t keep) : window_(window), keep_(keep) {
  if (!(window > 0 && std::isfinite(window)) || keep < 8) throw Error("tail sampler: need window > 0 and keep >= 8");
}

void TailSampler::push(const TailPeak& peak) {
  if (kept_.size() < keep_) {
    kept_.push_back(peak);
    std::push_heap(kept_.begin(), kept_.end(), heap_order);
  } else if (peak.m > kept_.front().m) {
    std::pop_heap(kept_.begin(), kept_.end(), heap_order);
    kept_.back() = peak;
    std::push_heap(kept_.begin(), kept_.end(), heap_order);
  }
}

void TailSampler::close() {
  if (!has_candidate_) return;
  has_candidate_ = false;
  descending_ = true;
  ++peaks_;
  if (could_keep(candidate_.m)) push(candidate_);
}

void TailSampler::begin_stream() {
  close();
  descending_ = false;
  previous_m_ = 0;
  since_peak_ = 0;
}

std::vector<TailPeak> TailSampler::largest() const {
  std::vector<TailPeak> out = kept_;
  if (has_candidate_ && could_keep(candidate_.m)) {
    out.push_back(candidate_);
    if (out.size() > keep_) {
      std::sort(out.begin(), out.end(), heap_order);
      out.pop_back();
    }
  }
  std::sort(out.begin(), out.end(), [](const TailPeak& a, const TailPeak& b) { return a.m > b.m; });
  return out;
}

void TailSampler::merge(const TailSampler& other) {
  for (const auto& p : other.largest()) push(p);
  peaks_ += other.peaks_ + (other.has_candidate_ ? 1 : 0);
  seconds_ += other.seconds_;
}

double ParetoTail::level(double per_hour) const {
  if (!(per_hour > 0) || !(rate > 0)) return INFINITY;
  const double ratio = rate / per_hour;
  if (ratio <= 1) return u0;  // the data's own peaks are rarer than that: no extrapolation down
  if (std::fabs(xi) < 1e-9) return u0 + sigma * std::log(ratio);
  return u0 + sigma / xi * (std::pow(ratio, xi) - 1);
}

double ParetoTail::rate_over(double u) const { return rate * pareto_survival(u - u0, sigma, xi); }

double ParetoTail::supported_rate(double uncertainty) const {
  if (!(rate > 0) || peaks <= 0 || !(uncertainty > 1)) return NAN;
  const double spread = std::log(uncertainty);
  const double reach = std::sqrt(std::max(0.0, peaks * spread * spread - 1));
  return rate * std::exp(-reach);
}

bool TailFitOptions::IsValid(std::string* why) const {
  if (!(xi_min <= xi_max && xi_min > -1 && xi_max < 1)) return invalid(why, "tail shape bounds must satisfy -1 < min <= max < 1");
  if (!(outlier_probability > 0 && outlier_probability < 1)) return invalid(why, "outlier probability must be in (0, 1)");
  if (!(corroborated_probability > 0 && corroborated_probability < 1))
    return invalid(why, "corroborated outlier probability must be in (0, 1)");
  if (max_outliers < 0) return invalid(why, "max outliers must be >= 0");
  if (min_peaks < 2) return invalid(why, "a tail fit needs at least 2 peaks over its base level");
  if (min_shape_peaks < min_peaks) return invalid(why, "the shape needs at least as many peaks as the fit");
  if (!(rate_uncertainty > 1 && std::isfinite(rate_uncertainty))) return invalid(why, "rate uncertainty factor must be > 1");
  return true;
}

TailFit fit_tail(const std::vector<TailPeak>& largest, std::uint64_t total_peaks, double seconds,
                 const TailFitOptions& options, const std::function<bool(const TailPeak&)>& corroborated) {
  std::string why;
  if (!options.IsValid(&why)) throw Error(why);
  TailFit fit;
  fit.seconds = seconds;
  fit.peaks = std::max<std::uint64_t>(total_peaks, largest.size());
  if (seconds > 0) fit.supported_per_hour = 3600 / seconds;
  std::vector<TailPeak> peaks = largest;  // largest first
  std::uint64_t total = std::max<std::uint64_t>(total_peaks, peaks.size());
  // Exceedances used, within what was kept: for the exponential tail the square root of all
  // peaks, the usual balance of bias and variance in the exponential domain; more would reach
  // down into the body, and minutes of motion mix quiet phases, whose many small peaks would set
  // the scale, with busy ones, whose few large peaks are the tail that false alarms come from.
  // A fitted shape follows the body further: the top fifth.
  auto exceedances = [&](std::size_t available, std::uint64_t all) {
    const auto root = static_cast<std::uint64_t>(std::llround(std::sqrt(static_cast<double>(all))));
    const auto wanted =
        std::max<std::uint64_t>(static_cast<std::uint64_t>(options.min_peaks), options.fitted_shape ? all / 5 : root);
    return static_cast<std::size_t>(std::min<std::uint64_t>(available - 1, wanted));
  };
  auto fit_below = [&](std::size_t first, ParetoTail* tail, double* shape = nullptr) {
    // The tail of peaks[first..]: base level the (k+1)-th of them.
    const std::size_t available = peaks.size() - first;
    if (available < static_cast<std::size_t>(options.min_peaks) + 1) return false;
    const std::size_t k = exceedances(available, total - first);
    const double u0 = peaks[first + k].m;
    std::vector<double> y;
    for (std::size_t i = first + k; i-- > first;) y.push_back(peaks[i].m - u0);  // ascending
    // The shape is not estimable from a handful of peaks.
    const bool estimable = static_cast<int>(k) >= options.min_shape_peaks;
    const Moments fitted = estimable && (shape || options.fitted_shape) ? pareto_moments(y, options) : Moments{0, 0};
    if (shape) *shape = estimable ? fitted.xi : NAN;
    const Moments m = options.fitted_shape && estimable ? fitted : exponential_moments(y);
    if (!(m.sigma > 0)) return false;
    *tail = ParetoTail{u0, m.sigma, m.xi, static_cast<double>(k) / (seconds / 3600), static_cast<int>(k)};
    return true;
  };
  if (!(seconds > 0) || !fit_below(0, &fit.tail)) {
    fit.why = std::to_string(total) + " independent peaks in " + std::to_string(seconds) +
              " s, a tail fit needs " + std::to_string(options.min_peaks + 1);
    fit.largest_kept = peaks.empty() ? 0 : peaks.front().m;
    return fit;
  }
  // Outliers (generalised ESD): the i-th largest peak judged against the tail of the peaks
  // below it, for every i up to the cap; the outliers are the peaks down to the deepest extreme
  // one. Testing from the top down and stopping at the first ordinary peak would let a second
  // glitch, which widens the tail the first is judged by, mask both.
  std::size_t removed = 0;
  const std::size_t cap = std::min<std::size_t>(static_cast<std::size_t>(options.max_outliers), total / 10);
  for (std::size_t i = 1; i <= cap; ++i) {
    ParetoTail below;
    if (!fit_below(i, &below)) break;
    // Judged with the tail's predictive distribution, not its point estimate: a scale estimated
    // as the mean of k exponential excesses leaves a further excess Lomax distributed,
    // P(Y > y) = (1 + y / (k sigma))^-k, i.e. a generalised Pareto tail of shape 1/k. From a
    // handful of peaks, the plug-in exp(-y / sigma) calls ordinary peaks of a few scales
    // impossible. Never lighter than that: a bounded fit (xi < 0) may end below peaks that
    // recur (the same reversal every cycle), and would call each of them impossible.
    const double shape = std::max(below.xi, 1.0 / below.peaks);
    const double survival = pareto_survival(peaks[i - 1].m - below.u0, below.sigma, shape);
    const double any = -std::expm1(static_cast<double>(below.peaks) * std::log1p(-std::min(survival, 1.0)));
    const bool seen_elsewhere = corroborated && corroborated(peaks[i - 1]);
    if (any < (seen_elsewhere ? options.corroborated_probability : options.outlier_probability)) removed = i;
  }
  fit.outliers.assign(peaks.begin(), peaks.begin() + static_cast<std::ptrdiff_t>(removed));
  for (const TailPeak& o : fit.outliers) fit.corroborated.push_back(corroborated && corroborated(o));
  peaks.erase(peaks.begin(), peaks.begin() + static_cast<std::ptrdiff_t>(removed));
  total -= removed;
  fit.largest_kept = peaks.front().m;
  fit.ok = fit_below(0, &fit.tail, &fit.shape);
  if (!fit.ok) fit.why = "too few peaks once the outliers are removed";
  else fit.supported_per_hour = fit.tail.supported_rate(options.rate_uncertainty);
  return fit;
}

}  // namespace momentum::calibrate
