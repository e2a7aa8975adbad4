#include "momentum/friction_fit/subset.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "momentum/core/error.hpp"

namespace momentum::friction_fit {

bool SubsetOptions::IsValid(std::string* why) const {
  if (windows < 1) return invalid(why, "search subset: windows must be >= 1");
  if (max_samples > 0 && max_samples < 8 * static_cast<std::size_t>(windows))
    return invalid(why, "search subset: at least 8 samples per window needed");
  if (!std::isfinite(warmup)) return invalid(why, "search subset: warm-up must be finite");
  if (!std::isfinite(min_window)) return invalid(why, "search subset: window length must be finite");
  return true;
}

namespace {

// Stratum of every sample (-1: not counted).
std::vector<int> strata_of(const JointSeries& d) {
  const std::size_t n = d.size();
  std::vector<int> stratum(n, -1);
  std::vector<double> speed, accel(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    if (k > 0 && d.restart[k] == 0) accel[k] = std::abs(d.dq[k] - d.dq[k - 1]) / (d.t[k] - d.t[k - 1]);
    if (d.scored[k]) speed.push_back(std::abs(d.dq[k]));
  }
  if (speed.empty()) return stratum;
  auto quantile = [](std::vector<double> v, double q) {
    auto mid = v.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), mid, v.end());
    return *mid;
  };
  const double q1 = quantile(speed, 0.25), q2 = quantile(speed, 0.5), q3 = quantile(speed, 0.75);
  std::vector<double> counted_accel;
  for (std::size_t k = 0; k < n; ++k)
    if (d.scored[k]) counted_accel.push_back(accel[k]);
  const double accel_median = quantile(counted_accel, 0.5);
  // A reversal: the velocity passes from beyond +h to beyond -h or back (hysteresis against
  // noise around zero), h a tenth of the median counted speed.
  const double h = 0.1 * q2;
  int direction = 0;
  double last_reversal = -1e300;
  for (std::size_t k = 0; k < n; ++k) {
    if (d.restart[k] >= 2) direction = 0, last_reversal = -1e300;
    const int now = d.dq[k] > h ? 1 : (d.dq[k] < -h ? -1 : 0);
    if (now != 0) {
      if (direction != 0 && now != direction) last_reversal = d.t[k];
      direction = now;
    }
    if (!d.scored[k]) continue;
    if (d.t[k] - last_reversal <= 0.25) {
      stratum[k] = kSubsetStrata - 1;
      continue;
    }
    const double s = std::abs(d.dq[k]);
    const int level = s < q1 ? 0 : s < q2 ? 1 : s < q3 ? 2 : 3;
    stratum[k] = level * 4 + (d.dq[k] < 0 ? 2 : 0) + (accel[k] > accel_median ? 1 : 0);
  }
  return stratum;
}

}  // namespace

JointSeries search_subset(const JointSeries& data, const observer::Gains& gains,
                          const SubsetOptions& options, std::vector<std::size_t>* segment_start,
                          SubsetSummary* summary, std::vector<std::size_t>* origin) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  if (!gains.IsValid(&why)) throw std::invalid_argument("search subset: observer gains: " + why);
  SubsetSummary local;
  SubsetSummary& s = summary ? *summary : local;
  s = SubsetSummary{};
  s.counted_total = data.scored_count();
  if (segment_start) segment_start->clear();
  if (origin) origin->clear();
  const std::size_t n = data.size();
  if (options.max_samples == 0 || s.counted_total <= options.max_samples) {
    s.segments = 1;
    s.samples = n;
    s.counted = s.counted_total;
    if (segment_start) segment_start->push_back(0);
    if (origin)
      for (std::size_t k = 0; k < n; ++k) origin->push_back(k);
    return data;
  }

  const std::vector<int> stratum = strata_of(data);
  s.strata_total.assign(kSubsetStrata, 0);
  for (int c : stratum)
    if (c >= 0) ++s.strata_total[static_cast<std::size_t>(c)];

  // Windows on a grid of `length` samples, each with its counted samples per stratum.
  const double dt = data.median_dt();
  const double min_window = options.min_window >= 0 ? options.min_window : (gains.k2 > 0 ? 2.0 / gains.k2 : 0.0);
  const std::size_t shortest = dt > 0 ? static_cast<std::size_t>(std::ceil(min_window / dt)) : 0;
  const std::size_t length =
      std::max<std::size_t>({8, options.max_samples / static_cast<std::size_t>(options.windows), shortest});
  const std::size_t count = (n + length - 1) / length;
  std::vector<std::array<std::uint32_t, kSubsetStrata>> histogram(count);
  for (auto& h : histogram) h.fill(0);
  for (std::size_t k = 0; k < n; ++k)
    if (stratum[k] >= 0) ++histogram[k / length][static_cast<std::size_t>(stratum[k])];

  // Equal shares of the budget (water-filling: a stratum that has less gives all it has).
  std::vector<double> target(kSubsetStrata, 0.0);
  {
    double budget = static_cast<double>(options.max_samples);
    std::vector<std::size_t> open;
    for (std::size_t c = 0; c < kSubsetStrata; ++c)
      if (s.strata_total[c] > 0) open.push_back(c);
    while (!open.empty()) {
      const double share = budget / static_cast<double>(open.size());
      std::vector<std::size_t> still;
      for (std::size_t c : open) {
        if (static_cast<double>(s.strata_total[c]) <= share) {
          target[c] = static_cast<double>(s.strata_total[c]);
          budget -= target[c];
        } else {
          still.push_back(c);
        }
      }
      if (still.size() == open.size()) {
        for (std::size_t c : still) target[c] = share;
        break;
      }
      open = std::move(still);
    }
  }

  std::vector<double> remaining = target;
  std::vector<bool> chosen(count, false);
  std::size_t counted = 0;
  while (counted < options.max_samples) {
    double best_gain = 0;
    std::size_t best = count;
    for (std::size_t w = 0; w < count; ++w) {
      if (chosen[w]) continue;
      double gain = 0;
      for (std::size_t c = 0; c < kSubsetStrata; ++c)
        if (target[c] > 0) gain += std::min(static_cast<double>(histogram[w][c]), remaining[c]) / target[c];
      if (gain > best_gain) best_gain = gain, best = w;
    }
    if (best == count) break;  // no window adds anything still wanted
    chosen[best] = true;
    for (std::size_t c = 0; c < kSubsetStrata; ++c) {
      remaining[c] = std::max(0.0, remaining[c] - histogram[best][c]);
      counted += histogram[best][c];
    }
  }

  // Warm-up before each run of chosen windows.
  double warmup = options.warmup > 0 ? options.warmup : 5.0 / gains.k1;
  const std::size_t warm = std::max<std::size_t>(3, dt > 0 ? static_cast<std::size_t>(std::ceil(warmup / dt)) : 3);
  JointSeries out;
  out.joint = data.joint;
  out.source = data.source;
  s.strata_chosen.assign(kSubsetStrata, 0);
  for (std::size_t w = 0; w < count;) {
    if (!chosen[w]) {
      ++w;
      continue;
    }
    std::size_t end_window = w;
    while (end_window < count && chosen[end_window]) ++end_window;
    const std::size_t first = w * length, last = std::min(n, end_window * length);
    const std::size_t begin = first > warm ? first - warm : 0;
    JointSeries piece;
    piece.joint = data.joint;
    piece.source = data.source;
    for (std::size_t k = begin; k < last; ++k) {
      piece.t.push_back(data.t[k]);
      piece.dq.push_back(data.dq[k]);
      piece.r.push_back(data.r[k]);
      piece.restart.push_back(k == begin ? 2 : data.restart[k]);
      const bool counts = k >= first && data.scored[k];
      piece.scored.push_back(counts ? 1 : 0);
      if (counts && stratum[k] >= 0) ++s.strata_chosen[static_cast<std::size_t>(stratum[k])];
      if (origin) origin->push_back(k);
    }
    if (segment_start) segment_start->push_back(out.size());
    append_series(out, piece);
    ++s.segments;
    w = end_window;
  }
  out.restart.front() = 2;
  out.positions.reset();
  out.source = data.source;
  s.used = true;
  s.samples = out.size();
  s.counted = out.scored_count();
  return out;
}

}  // namespace momentum::friction_fit
