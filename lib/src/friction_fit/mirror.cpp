#include "momentum/friction_fit/mirror.hpp"

#include <algorithm>
#include <cmath>

#include "momentum/core/error.hpp"

namespace momentum::friction_fit {

namespace {

// A whole log reduced to what the check needs: t and, per joint, q, dq, tau_m.
struct Log {
  std::vector<double> t;
  std::vector<std::vector<double>> q, dq, tau;
};

Log read_log(stream::Reader& in, const std::vector<int>& joints, const std::vector<double>& k_i) {
  const std::size_t tc = in.require("t");
  std::vector<std::size_t> qc, dqc, tauc;
  std::vector<double> factor;
  for (int j : joints) {
    const std::string n = std::to_string(j);
    qc.push_back(in.require("q" + n));
    dqc.push_back(in.require("dq" + n));
    if (auto c = in.find("tau_m" + n)) {
      tauc.push_back(*c);
      factor.push_back(1.0);
    } else if (auto ci = in.find("i" + n)) {
      if (static_cast<std::size_t>(j) > k_i.size())
        throw Error(in.name() + ": no tau_m" + n + " column and no torque constant for joint " + n);
      tauc.push_back(*ci);
      factor.push_back(k_i[static_cast<std::size_t>(j) - 1]);
    } else {
      throw Error(in.name() + ": missing column 'tau_m" + n + "' (or 'i" + n + "')");
    }
  }
  Log log;
  log.q.resize(joints.size());
  log.dq.resize(joints.size());
  log.tau.resize(joints.size());
  while (const double* row = in.next()) {
    bool ok = std::isfinite(row[tc]) && (log.t.empty() || row[tc] > log.t.back());
    for (std::size_t i = 0; ok && i < joints.size(); ++i)
      ok = std::isfinite(row[qc[i]]) && std::isfinite(row[dqc[i]]) && std::isfinite(row[tauc[i]]);
    if (!ok) continue;
    log.t.push_back(row[tc]);
    for (std::size_t i = 0; i < joints.size(); ++i) {
      log.q[i].push_back(row[qc[i]]);
      log.dq[i].push_back(row[dqc[i]]);
      log.tau[i].push_back(factor[i] * row[tauc[i]]);
    }
  }
  if (log.t.size() < 2) throw Error(in.name() + ": fewer than two usable rows");
  return log;
}

}  // namespace

MirrorReference mirror_reference(stream::Reader& forward, stream::Reader& mirror,
                                 const std::vector<int>& joints, const std::vector<double>& k_i) {
  const Log f = read_log(forward, joints, k_i);
  const Log m = read_log(mirror, joints, k_i);
  const double duration = f.t.back() - f.t.front();
  const double mirror_duration = m.t.back() - m.t.front();
  if (std::abs(duration - mirror_duration) > 0.01 * duration)
    throw Error(mirror.name() + ": lasts " + std::to_string(mirror_duration) + " s, the forward log " +
                std::to_string(duration) + " s; a mirror must last as long");
  MirrorReference ref;
  ref.joints = joints;
  ref.dq.resize(joints.size());
  ref.dq_mirror.resize(joints.size());
  ref.friction.resize(joints.size());
  for (std::size_t k = 0; k < f.t.size(); ++k) {
    const double tm = m.t.front() + (duration - (f.t[k] - f.t.front()));
    if (tm < m.t.front() || tm > m.t.back()) {
      ++ref.skipped;
      continue;
    }
    // Linear interpolation in the mirror log.
    auto hi = std::lower_bound(m.t.begin(), m.t.end(), tm);
    std::size_t b = static_cast<std::size_t>(hi - m.t.begin());
    if (b == 0) b = 1;
    const std::size_t a = b - 1;
    const double w = (tm - m.t[a]) / (m.t[b] - m.t[a]);
    auto at = [&](const std::vector<double>& v) { return v[a] + w * (v[b] - v[a]); };
    ref.t.push_back(f.t[k]);
    for (std::size_t i = 0; i < joints.size(); ++i) {
      ref.max_position_mismatch = std::max(ref.max_position_mismatch, std::abs(f.q[i][k] - at(m.q[i])));
      ref.max_velocity_mismatch = std::max(ref.max_velocity_mismatch, std::abs(f.dq[i][k] + at(m.dq[i])));
      ref.dq[i].push_back(f.dq[i][k]);
      ref.dq_mirror[i].push_back(-at(m.dq[i]));
      ref.friction[i].push_back(0.5 * (f.tau[i][k] - at(m.tau[i])));
    }
  }
  return ref;
}

MirrorCheck compare_mirror(const MirrorReference& reference, std::size_t index, friction::Kind kind,
                           const friction::Parameters<double>& parameters,
                           const friction::Options& options, double skip, double min_speed,
                           double guard) {
  MirrorCheck check;
  if (index >= reference.joints.size() || reference.t.empty()) return check;
  const auto& t = reference.t;
  // Times of the slow samples, in order, for the guard window around each.
  std::vector<double> slow;
  if (min_speed > 0)
    for (std::size_t k = 0; k < t.size(); ++k)
      if (std::abs(reference.dq[index][k]) < min_speed || std::abs(reference.dq_mirror[index][k]) < min_speed)
        slow.push_back(t[k]);
  auto near_slow = [&](double time) {
    const auto it = std::lower_bound(slow.begin(), slow.end(), time - guard);
    return it != slow.end() && *it <= time + guard;
  };
  friction::JointFriction<double> model(kind, parameters, options);
  double sum = 0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    const double dt = k ? t[k] - t[k - 1] : 0.0;
    const double tau = model.step(reference.dq[index][k], dt);
    if (t[k] < t.front() + skip) continue;
    if (near_slow(t[k])) {
      ++check.excluded;
      continue;
    }
    const double e = tau - reference.friction[index][k];
    sum += e * e;
    check.max_abs = std::max(check.max_abs, std::abs(e));
    ++check.samples;
  }
  check.rms = check.samples ? std::sqrt(sum / static_cast<double>(check.samples)) : 0.0;
  return check;
}

}  // namespace momentum::friction_fit
