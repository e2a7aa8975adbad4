#include "momentum/model/profile.hpp"


#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>

#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile_text.hpp"
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

// The line of the first `"key"` that a colon follows (a member name), or 0 when `text` is empty
// or does not hold it.
std::uint64_t line_of_key(const std::string& text, const std::string& key) {
  const std::string quoted = nlohmann::json(key).dump();
  for (std::size_t at = text.find(quoted); at != std::string::npos; at = text.find(quoted, at + 1)) {
    std::size_t k = at + quoted.size();
    while (k < text.size() && std::isspace(static_cast<unsigned char>(text[k]))) ++k;
    if (k < text.size() && text[k] == ':') return line_of_byte(text, at + 1);
  }
  return 0;
}

// A key as its writer may have meant it: lower case, without '_', '-' and spaces.
std::string key_skeleton(const std::string& key) {
  std::string out;
  for (const char c : key)
    if (c != '_' && c != '-' && c != ' ') out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// Optimal string alignment distance (edits, and swaps of neighbours) between `a` and `b`.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[a.size()][b.size()];
}

// Throws when the unknown key `key` of `where` is a near miss of a key this layer knows (the
// same but for case, '_' or '-'; or one edit away from a known key of 4 or more characters, two
// from one of 8 or more): a misspelt "joints" would otherwise leave every drive at its defaults
// with only a warning. Otherwise warns that it is ignored.
void unknown_key(const std::string& key, const std::vector<std::string>& known, const std::string& where,
                 const std::filesystem::path& path, const std::string& text) {
  const std::string skeleton = key_skeleton(key);
  for (const auto& k : known) {
    const std::string target = key_skeleton(k);
    const std::size_t shorter = std::min(skeleton.size(), target.size());
    const std::size_t distance = edit_distance(skeleton, target);
    const bool near = distance == 0 || (distance == 1 && shorter >= 4) || (distance == 2 && shorter >= 8);
    if (near)
      fail(path, "unknown key " + in_quotes(key) + where + ": did you mean " + in_quotes(k) +
                     "? (a misspelt key leaves its section at the defaults)",
           line_of_key(text, key));
  }
  warn(located(path.string(), 0, "unknown key " + in_quotes(key) + where + " ignored"));
}

// How deeply arrays and objects may nest in a profile: ours nest 6 levels at most, and a
// document nested thousands deep would cost seconds and the stack of every recursive walk.
constexpr int kMaxDepth = 64;

// Throws, naming the line, when `text` nests arrays and objects deeper than kMaxDepth (strings
// and // or /* */ comments are skipped as the parser skips them).
void check_depth(const std::string& text, const std::filesystem::path& path) {
  int depth = 0;
  for (std::size_t k = 0; k < text.size(); ++k) {
    const char c = text[k];
    if (c == '"') {
      for (++k; k < text.size() && text[k] != '"'; ++k)
        if (text[k] == '\\') ++k;
    } else if (c == '/' && k + 1 < text.size() && text[k + 1] == '/') {
      k = text.find('\n', k);
      if (k == std::string::npos) return;
    } else if (c == '/' && k + 1 < text.size() && text[k + 1] == '*') {
      k = text.find("*/", k + 2);
      if (k == std::string::npos) return;
      ++k;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxDepth)
        fail(path, "arrays and objects nest deeper than " + std::to_string(kMaxDepth) + " levels", line_of_byte(text, k + 1));
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
}

// One entry of "payloads". Inertia: 6 numbers in the URDF's order ixx, ixy, ixz, iyy, iyz, izz.
Payload parse_payload(const std::string& name, const nlohmann::json& entry,
                      const std::filesystem::path& path, const std::string& text) {
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
      unknown_key(key, {"mass", "com", "inertia", "link", "description"}, " in " + where, path, text);
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

namespace {
Profile profile_from_text(nlohmann::json document, const std::filesystem::path& path, const std::string& text);
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
  // nlohmann's lexer takes a NUL byte for the end of input and would load the document in
  // front of it, dropping whatever follows without a word (and the text-preserving edit that
  // writes back sees text after the document).
  if (const auto nul = text.find('\0'); nul != std::string::npos)
    fail(path, "NUL byte in profile text (not a text file?)", line_of_byte(text, nul + 1));
  check_depth(text, path);
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/true,
                                     /*ignore_comments=*/true);
  } catch (const nlohmann::json::parse_error& e) {
    fail(path, "invalid json: " + parse_error_text(e), line_of_byte(text, e.byte));
  } catch (const nlohmann::json::exception& e) {
    // A number beyond double's range ("1e999"): the library names the number, not its place.
    std::string what = e.what();
    std::uint64_t line = 0;
    if (const auto open = what.find('\''), close = what.rfind('\''); open != std::string::npos && close > open) {
      const std::string number = what.substr(open + 1, close - open - 1);
      if (const auto at = text.find(number); at != std::string::npos) line = line_of_byte(text, at + 1);
      what = "number out of range: " + number;
    }
    fail(path, "invalid json: " + what, line);
  }
  return profile_from_text(std::move(document), path, text);
}

Profile profile_from_document(nlohmann::json document, const std::filesystem::path& path) {
  return profile_from_text(std::move(document), path, "");
}

namespace {

// profile_from_document, with the file's text to find the lines of keys in (empty: none).
Profile profile_from_text(nlohmann::json document, const std::filesystem::path& path, const std::string& text) {
  if (!document.is_object()) {
    fail(path, std::string("a profile must be a json object, not ") + type_name(document));
  }
  Profile profile;
  profile.path = path;
  const auto& known = known_profile_keys();
  for (const auto& item : document.items()) {
    if (std::find(known.begin(), known.end(), item.key()) == known.end()) unknown_key(item.key(), known, "", path, text);
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
          unknown_key(item.key(), {"k_i", "rotor_inertia", "name"}, " in " + where, path, text);
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
      profile.payloads.push_back(parse_payload(item.key(), item.value(), path, text));
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
  profile.text = text;
  return profile;
}

}  // namespace

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
  // Under the profile's lock (kept when this run holds it since its read).
  core::ReplaceOptions options;
  options.lock = true;
  core::replace_file(path, text, options);
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

std::string write_updated_profile(const nlohmann::json& document, const Profile& source, const std::string& destination) {
  const std::string target = destination.empty() ? source.path.string() : destination;
  if (target == "-") {
    core::write_document("-", document.dump(2) + "\n");
    return "stdout";
  }
  save_profile_as(document, source, target);
  return target;
}

}  // namespace momentum::model
