// libFuzzer target: URDF text to the chain (model::build_model_from_urdf_text). The input is a
// first line "ROOT TIP" naming the chain, then the URDF. Any input either builds a model or
// throws momentum::Error (never crashes, never recurses without end on a cycle, never runs out
// of memory); a model that builds has one joint per degree of freedom and consistent sizes.
#include <cstddef>
#include <cstdint>
#include <string>

#include "momentum/core/error.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const std::size_t newline = input.find('\n');
  if (newline == std::string::npos) return 0;
  const std::string names = input.substr(0, newline);
  const std::size_t space = names.find(' ');
  if (space == std::string::npos) return 0;
  momentum::model::Profile profile;
  profile.root = names.substr(0, space);
  profile.tip = names.substr(space + 1);
  momentum::set_warning_sink([](std::string_view) {});
  try {
    const momentum::model::Model model = momentum::model::build_model_from_urdf_text(profile, input.substr(newline + 1));
    if (model.nq <= 0 || model.joints.size() != static_cast<std::size_t>(model.nq) ||
        model.bodies.size() != static_cast<std::size_t>(model.nq) || model.k_i.size() != model.nq)
      __builtin_trap();
  } catch (const momentum::Error&) {
  }
  return 0;
}
