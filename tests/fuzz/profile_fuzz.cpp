// libFuzzer target: the robot profile (man 5 momentum-profile) as its text, read the way every
// tool reads it (model::load_profile on a file), then the sections other stages read from it
// ("friction", "thresholds") and the text-preserving edit that mo-calibrate and mo-lugre-fit
// write back with. Any input either loads or throws momentum::Error (never another exception,
// never a crash, a leak or undefined behaviour), and a profile that loads:
//   - has finite gravity, finite k_i and rotor_inertia >= 0 for each joint, payloads sorted
//     by name and an active payload in range;
//   - selects each of its payloads by name, "none", and refuses a name it does not have;
//   - edited with one section replaced and a provenance entry appended
//     (model::edit_profile_text), gives text that parses to exactly the edited document, and
//     the unchanged document gives the text back byte for byte.
#include <fcntl.h>
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "momentum/core/error.hpp"
#include "momentum/detect/thresholds.hpp"
#include "momentum/friction/friction.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/model/profile_text.hpp"

namespace {

void check(bool ok) {
  if (!ok) __builtin_trap();
}

void write_file(const std::string& path, std::string_view bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  check(fd >= 0);
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    check(n > 0);
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  ::close(fd);
}

void check_sections(const nlohmann::json& document) {
  using namespace momentum;
  if (const auto it = document.find("friction"); it != document.end()) {
    try {
      std::vector<std::string> warnings;
      const friction::FrictionModel model = friction::friction_from_json(*it, &warnings);
      std::string why;
      check(model.IsValid(&why));
    } catch (const Error&) {
    }
  }
  for (detect::Signal signal : {detect::Signal::mu, detect::Signal::r}) {
    try {
      if (auto thresholds = detect::thresholds_from_profile(document, signal, "fuzz.json")) {
        std::string why;
        check(thresholds->IsValid(&why));
        // Stored back, the entry reads back the same.
        nlohmann::json copy = document;
        detect::store_thresholds(copy, *thresholds);
        auto again = detect::thresholds_from_profile(copy, signal, "fuzz.json");
        check(again.has_value());
        check(detect::thresholds_to_json(*again) == detect::thresholds_to_json(*thresholds));
      }
    } catch (const Error&) {
    }
  }
}

void check_edit(const momentum::model::Profile& profile) {
  using momentum::model::edit_profile_text;
  check(edit_profile_text(profile.text, profile.document) == profile.text);
  nlohmann::json updated = profile.document;
  updated["thresholds"] = {{"mu", {{"rest", {1.5, 2.5}}, {"margin", 0.25}}}};
  if (!updated.contains("provenance") || !updated["provenance"].is_array())
    updated["provenance"] = nlohmann::json::array();
  updated["provenance"].push_back({{"tool", "fuzz"}, {"details", {{"rows", 3}}}});
  const std::string text = edit_profile_text(profile.text, updated);
  const nlohmann::json reread = nlohmann::json::parse(text, nullptr, true, /*ignore_comments=*/true);
  check(reread == updated);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace momentum;
  static const bool quiet = [] {
    set_warning_sink([](std::string_view) {});
    return true;
  }();
  (void)quiet;
  static const std::string path = "/tmp/momentum-fuzz-" + std::to_string(::getpid()) + "-profile.json";
  write_file(path, std::string_view(reinterpret_cast<const char*>(data), size));
  model::Profile profile;
  try {
    profile = model::load_profile(path);
  } catch (const Error&) {
    return 0;
  }
  check(profile.gravity.allFinite());
  for (const model::JointDrive& drive : profile.joints) {
    check(std::isfinite(drive.k_i));
    check(std::isfinite(drive.rotor_inertia) && drive.rotor_inertia >= 0.0);
  }
  for (std::size_t k = 1; k < profile.payloads.size(); ++k)
    check(profile.payloads[k - 1].name < profile.payloads[k].name);
  check(profile.active_payload >= -1 && profile.active_payload < static_cast<int>(profile.payloads.size()));
  for (std::size_t k = 0; k < profile.payloads.size(); ++k) {
    model::select_payload(profile, profile.payloads[k].name);
    check(profile.active_payload == static_cast<int>(k));
  }
  model::select_payload(profile, "none");
  check(profile.payload() == nullptr);
  try {
    model::select_payload(profile, std::string("no such payload \x01"));
    check(false);
  } catch (const Error&) {
  }
  check_sections(profile.document);
  check_edit(profile);
  return 0;
}
