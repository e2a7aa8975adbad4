#include "momentum/eval/truth.hpp"

#include <algorithm>

#include "momentum/core/error.hpp"
#include "momentum/core/text.hpp"
#include "momentum/stream/format.hpp"
#include "momentum/stream/reader.hpp"

namespace momentum::eval {

Truth read_truth(const std::string& path) {
  auto reader = stream::Reader::open(path);
  Truth truth;
  for (const auto& comment : reader->leading_comments()) {
    const std::string_view text = core::trim(comment);
    constexpr std::string_view key = "duration:";
    if (text.substr(0, key.size()) == key) {
      const auto value = stream::parse_double(core::trim(text.substr(key.size())));
      if (value && *value > 0) truth.duration = *value;
    }
  }
  const std::size_t c_onset = reader->require("t_onset"), c_end = reader->require("t_end"),
                    c_link = reader->require("link");
  const auto c_clamp = reader->find("clamp"), c_force = reader->find("f_peak");
  const auto c_px = reader->find("px"), c_py = reader->find("py"), c_pz = reader->find("pz");
  std::vector<std::size_t> c_torques;
  for (int j = 1; reader->find("tau_peak" + std::to_string(j)); ++j)
    c_torques.push_back(*reader->find("tau_peak" + std::to_string(j)));
  while (const double* row = reader->next()) {
    TruthContact c;
    c.t_onset = row[c_onset];
    c.t_end = row[c_end];
    const double link = row[c_link];
    if (!(c.t_end >= c.t_onset))
      throw Error(reader->where() + ": contact ends (" + std::to_string(c.t_end) + ") before its onset");
    if (!(link >= 1 && link == std::floor(link) && link <= 1e6))
      throw Error(reader->where() + ": link must be a positive whole number");
    c.link = static_cast<int>(link);
    if (c_clamp) c.clamp = row[*c_clamp] != 0;
    if (c_force) c.peak_force = row[*c_force];
    if (c_px && c_py && c_pz) c.point = {row[*c_px], row[*c_py], row[*c_pz]};
    for (std::size_t k = 0; k < c_torques.size(); ++k)
      c.peak_torque = k == 0 ? std::abs(row[c_torques[k]]) : std::max(c.peak_torque, std::abs(row[c_torques[k]]));
    truth.contacts.push_back(c);
  }
  std::stable_sort(truth.contacts.begin(), truth.contacts.end(),
                   [](const TruthContact& a, const TruthContact& b) { return a.t_onset < b.t_onset; });
  return truth;
}

}  // namespace momentum::eval
