#include "momentum/model/profile.hpp"


#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>

#include "momentum/core/file.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile_text.hpp"
#include "momentum/stream/error.hpp"
#include "momentum/version.hpp"

namespace momentum::model {

namespace {

std::string in_quotes(const std::string& text) { return "\"" + text + "\""; }

[[noreturn]] void fail(const std::filesystem::path& path, const std::string& message,
                       std::uint64_t line = 0) {
  throw Error(located(path.string(), line, message));
}

const char* type_name(const nlohmann::json& value) { return value.type_name(); }

std::string required_string(const nlohmann::json& document, const char* key,
                            const std::filesystem::path& path) {
  const auto it = document.find(key);
  if (it == document.end()) fail(path, std::string("missing required key ") + in_quotes(key));
  if (!it->is_string()) {
    fail(path, in_quotes(key) + " must be a string, not " + type_name(*it));
  }
  std::string value = it->get<std::string>();
  if (value.empty()) fail(path, in_quotes(key) + " is empty");
  return value;
}

double finite_number(const nlohmann::json& value, const std::string& what,
                     const std::filesystem::path& path) {
  if (!value.is_number()) fail(path, what + " must be a number, not " + type_name(value));
  const double x = value.get<double>();
  if (!std::isfinite(x)) fail(path, what + " must be finite");
  return x;
}

// nlohmann's parse_error::what() reads "[json.exception.parse_error.101] parse error at line
// 3, column 5: syntax error while parsing ..."; keep the part after the location.
std::string parse_error_text(const nlohmann::json::parse_error& e) {
  std::string text = e.what();
  const auto colon = text.find(": ", text.find("parse error"));
  if (colon != std::string::npos) text = text.substr(colon + 2);
  if (!text.empty() && text.back() == '.') text.pop_back();
  return text;
}

std::uint64_t line_of_byte(const std::string& text, std::size_t byte) {
  byte = std::min(byte, text.size());
  // nlohmann's byte position is one past the offending character.
  const std::size_t end = byte > 0 ? byte - 1 : 0;
  return 1 + static_cast<std::uint64_t>(
                 std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(end), '\n'));
}

// One entry of "payloads". Inertia: 6 numbers in the URDF's order ixx, ixy, ixz, iyy, iyz, izz.
Payload parse_payload(const std::string& name, const nlohmann::json& entry,
                      const std::filesystem::path& path) {
  const std::string where = "\"payloads\"." + name;
  if (name == "none") fail(path, where + ": \"none\" is reserved for no payload");
  if (name.empty()) fail(path, "\"payloads\" has a payload with an empty name");
  if (!entry.is_object()) fail(path, where + " must be an object, not " + type_name(entry));
  Payload payload;
  payload.name = name;
  bool have_mass = false;
  for (const auto& item : entry.items()) {
    const std::string key = item.key();
    const nlohmann::json& value = item.value();
    if (key == "mass") {
      payload.mass = finite_number(value, where + ".mass", path);
      if (payload.mass < 0.0) fail(path, where + ".mass must be >= 0 (kg)");
      have_mass = true;
    } else if (key == "com") {
      if (!value.is_array() || value.size() != 3) {
        fail(path, where + ".com must be an array of 3 numbers (m, in the link's frame)");
      }
      for (std::size_t k = 0; k < 3; ++k) {
        payload.com[static_cast<Eigen::Index>(k)] =
            finite_number(value[k], where + ".com[" + std::to_string(k) + "]", path);
      }
    } else if (key == "inertia") {
      if (!value.is_array() || value.size() != 6) {
        fail(path, where + ".inertia must be an array of 6 numbers: ixx, ixy, ixz, iyy, iyz, izz "
                           "(kg m^2, about the com)");
      }
      double v[6];
      for (std::size_t k = 0; k < 6; ++k) {
        v[k] = finite_number(value[k], where + ".inertia[" + std::to_string(k) + "]", path);
      }
      payload.inertia << v[0], v[1], v[2], v[1], v[3], v[4], v[2], v[4], v[5];
    } else if (key == "link") {
      if (!value.is_string() || value.get<std::string>().empty()) {
        fail(path, where + ".link must be a link name");
      }
      payload.link = value.get<std::string>();
    } else if (key != "description") {
      warn(located(path.string(), 0, "unknown key " + in_quotes(key) + " in " + where + " ignored"));
    }
  }
  if (!have_mass) fail(path, where + ": missing \"mass\" (kg)");
  if (!payload.inertia.isZero(0.0)) {
    if (payload.mass == 0.0) fail(path, where + ": zero mass with a nonzero inertia");
    std::string why;
    if (!is_physical_inertia(payload.inertia, &why)) {
      fail(path, where + ".inertia is not physical: " + why);
    }
  }
  return payload;
}

std::string payload_names(const Profile& profile) {
  std::string names;
  for (const Payload& p : profile.payloads) names += (names.empty() ? "" : ", ") + p.name;
  return names.empty() ? "none defined" : "known: " + names;
}

}  // namespace

const std::vector<std::string>& known_profile_keys() {
  static const std::vector<std::string> keys = {
      "urdf",     "root",       "tip",      "gravity",    "joints",
      "observer", "friction",   "thresholds", "provenance", "payloads",
      "dynamics", "simulation", "name",     "description", "active_payload",
      "inertial_corrections"};
  return keys;
}

Profile load_profile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot open profile: ") + std::strerror(errno));
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) fail(path, "cannot read profile");
  const std::string text = buffer.str();
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/true,
                                     /*ignore_comments=*/true);
  } catch (const nlohmann::json::parse_error& e) {
    fail(path, "invalid json: " + parse_error_text(e), line_of_byte(text, e.byte));
  }
  Profile profile = profile_from_document(std::move(document), path);
  profile.text = text;
  return profile;
}

Profile profile_from_document(nlohmann::json document, const std::filesystem::path& path) {
  if (!document.is_object()) {
    fail(path, std::string("a profile must be a json object, not ") + type_name(document));
  }
  Profile profile;
  profile.path = path;
  const auto& known = known_profile_keys();
  for (const auto& item : document.items()) {
    if (std::find(known.begin(), known.end(), item.key()) == known.end()) {
      warn(located(path.string(), 0, "unknown key " + in_quotes(item.key()) + " ignored"));
    }
  }
  const std::filesystem::path urdf = required_string(document, "urdf", path);
  profile.urdf = urdf.is_absolute() ? urdf : path.parent_path() / urdf;
  profile.root = required_string(document, "root", path);
  profile.tip = required_string(document, "tip", path);

  if (const auto it = document.find("gravity"); it != document.end()) {
    if (!it->is_array() || it->size() != 3) {
      fail(path, "\"gravity\" must be an array of 3 numbers (m/s^2, root frame)");
    }
    for (int k = 0; k < 3; ++k) {
      profile.gravity[k] = finite_number((*it)[static_cast<std::size_t>(k)],
                                         "\"gravity\"[" + std::to_string(k) + "]", path);
    }
  }

  if (const auto it = document.find("joints"); it != document.end()) {
    if (!it->is_array()) fail(path, "\"joints\" must be an array of objects, one per joint");
    std::size_t index = 0;
    for (const auto& entry : *it) {
      ++index;
      const std::string where = "\"joints\"[" + std::to_string(index - 1) + "]";
      if (!entry.is_object()) fail(path, where + " must be an object, not " + type_name(entry));
      JointDrive drive;
      for (const auto& item : entry.items()) {
        if (item.key() == "k_i") {
          drive.k_i = finite_number(item.value(), where + ".k_i", path);
        } else if (item.key() == "rotor_inertia") {
          drive.rotor_inertia = finite_number(item.value(), where + ".rotor_inertia", path);
          if (drive.rotor_inertia < 0.0) fail(path, where + ".rotor_inertia must be >= 0");
        } else if (item.key() != "name") {
          warn(located(path.string(), 0, "unknown key " + in_quotes(item.key()) + " in " + where +
                                             " ignored"));
        }
      }
      profile.joints.push_back(drive);
    }
  }
  if (const auto it = document.find("payloads"); it != document.end()) {
    if (!it->is_object()) {
      fail(path, "\"payloads\" must be an object of named payloads, not " +
                     std::string(type_name(*it)));
    }
    for (const auto& item : it->items()) {
      profile.payloads.push_back(parse_payload(item.key(), item.value(), path));
    }
  }
  if (const auto it = document.find("active_payload"); it != document.end()) {
    if (!it->is_string()) {
      fail(path, "\"active_payload\" must be a payload name or \"none\", not " +
                     std::string(type_name(*it)));
    }
    const std::string name = it->get<std::string>();
    if (name != "none") {
      select_payload(profile, name);
      if (profile.active_payload < 0) fail(path, "\"active_payload\" is empty");
    }
  }
  profile.document = std::move(document);
  return profile;
}

void select_payload(Profile& profile, const std::string& name) {
  if (name.empty()) return;
  if (name == "none") {
    profile.active_payload = -1;
    return;
  }
  for (std::size_t k = 0; k < profile.payloads.size(); ++k) {
    if (profile.payloads[k].name == name) {
      profile.active_payload = static_cast<int>(k);
      return;
    }
  }
  fail(profile.path, "no payload " + in_quotes(name) + " in \"payloads\" (" +
                         payload_names(profile) + ")");
}

void save_profile_atomically(const nlohmann::json& document, const std::filesystem::path& path) {
  save_profile_text_atomically(format_profile_value(document) + "\n", path);
}

void save_profile_text_atomically(const std::string& text, const std::filesystem::path& path) {
  // Where the bytes go and how they replace the file is core's (symlinks followed, only a
  // regular file replaced, mode kept, read-only refused, atomic rename, no temporary left).
  core::replace_file(path, text);
}

void append_provenance(nlohmann::json& document, const std::string& tool,
                       const nlohmann::json& details) {
  auto& list = document["provenance"];
  if (list.is_null()) list = nlohmann::json::array();
  if (!list.is_array()) {
    throw Error("profile: \"provenance\" must be an array, not " + std::string(list.type_name()));
  }
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  ::gmtime_r(&now, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &utc);
  list.push_back({{"tool", tool}, {"version", kVersion}, {"time", stamp}, {"details", details}});
}

std::filesystem::path urdf_reference(const std::filesystem::path& urdf, const std::filesystem::path& folder) {
  namespace fs = std::filesystem;
  const fs::path target = fs::absolute(urdf).lexically_normal();
  const fs::path relative = target.lexically_relative(fs::absolute(folder).lexically_normal());
  if (relative.empty() || *relative.begin() == "..") return target;
  return relative;
}

void save_profile_as(nlohmann::json document, const Profile& source, const std::filesystem::path& destination) {
  namespace fs = std::filesystem;
  const fs::path from = fs::absolute(source.path).parent_path();
  const fs::path to = fs::absolute(destination).parent_path();
  if (from != to && document.contains("urdf") && document["urdf"].is_string() &&
      !fs::path(document["urdf"].get<std::string>()).is_absolute())
    document["urdf"] = urdf_reference(source.urdf, to).generic_string();
  if (source.text.empty()) {
    save_profile_atomically(document, destination);
  } else {
    save_profile_text_atomically(edit_profile_text(source.text, document), destination);
  }
}

}  // namespace momentum::model
