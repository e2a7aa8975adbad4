#include "momentum/eval/classes.hpp"

#include <cmath>

#include "momentum/eval/score.hpp"

namespace momentum::eval {

LinkTemperature learn_link_temperature(const eval::Truth& truth, const std::vector<Detection>& detections,
                                       double written) {
  LinkTemperature out;
  out.temperature = written;
  // Per contact: ln p of each candidate as written, and the true one's index.
  std::vector<std::pair<std::vector<double>, std::size_t>> cases;
  for (const auto& o : score(truth, detections, {}).outcomes) {
    if (o.detection < 0) continue;
    const Detection& d = detections[static_cast<std::size_t>(o.detection)];
    std::vector<double> logs;
    std::size_t truth_index = d.link_probabilities.size();
    for (std::size_t i = 0; i < d.link_probabilities.size(); ++i) {
      logs.push_back(std::log(std::max(d.link_probabilities[i].second, 1e-300)));
      if (d.link_probabilities[i].first == o.contact.link) truth_index = i;
    }
    if (truth_index < logs.size()) cases.emplace_back(std::move(logs), truth_index);
  }
  out.events = static_cast<int>(cases.size());
  if (cases.empty()) return out;
  // Mean -ln p(true) at inverse temperature beta relative to the written one.
  auto loss = [&](double beta) {
    double sum = 0;
    for (const auto& [logs, k] : cases) {
      double top = -INFINITY;
      for (double l : logs) top = std::max(top, beta * l);
      double z = 0;
      for (double l : logs) z += std::exp(beta * l - top);
      sum -= beta * logs[k] - top - std::log(z);
    }
    return sum / static_cast<double>(cases.size());
  };
  // Golden section on ln beta (the loss is convex in beta, so unimodal on its logarithm).
  double lo = std::log(written / 1e5), hi = std::log(written / 1.0);
  if (!(lo < hi)) lo = hi;
  const double golden = (std::sqrt(5.0) - 1) / 2;
  for (int i = 0; i < 200 && hi - lo > 1e-9; ++i) {
    const double a = hi - golden * (hi - lo), b = lo + golden * (hi - lo);
    if (loss(std::exp(a)) < loss(std::exp(b))) hi = b;
    else lo = a;
  }
  const double beta = std::exp(0.5 * (lo + hi));
  out.temperature = written / beta;
  out.log_loss_written = loss(1.0);
  out.log_loss = loss(beta);
  return out;
}

}  // namespace momentum::eval
