// The paper's arm (share/momentum/robots/paper-arm) and the Panda (tests/data) for the
// simulator's tests.
#pragma once

#include <string>

#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/sim/run.hpp"
#include "momentum/core/error.hpp"

namespace momentum::sim::testing {

inline std::string paper_arm_profile() {
  return std::string(MOMENTUM_SOURCE_DIR) + "/share/momentum/robots/paper-arm/paper-arm.json";
}

struct Arm {
  model::Profile profile;
  model::Model model;
  SimulationSection section;
};

inline Arm load_arm(const std::string& path) {
  // The profile layer may not know the "simulation" key yet; its warning is noise here.
  auto previous = set_warning_sink([](std::string_view) {});
  Arm arm;
  arm.profile = model::load_profile(path);
  arm.model = model::build_model(arm.profile);
  arm.section = read_simulation_section(arm.profile, arm.model);
  set_warning_sink(previous);
  return arm;
}

inline Arm paper_arm() { return load_arm(paper_arm_profile()); }
inline Arm panda() { return load_arm(std::string(MOMENTUM_TEST_DATA) + "/panda.json"); }

}  // namespace momentum::sim::testing
