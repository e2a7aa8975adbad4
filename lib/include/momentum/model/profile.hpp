// The robot profile: one JSON file per robot (comments allowed) that every tool reads with -p.
// This layer only knows the keys the model needs (urdf, root, tip, gravity, joints); the other
// stages read and write their own sections ("observer", "friction", "thresholds", "payloads",
// "provenance") in Profile::document, and save the whole document back atomically.
// Schema: man 5 momentum-profile.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace momentum::model {

// Drive parameters of one chain joint, in chain order (joint 1 nearest the root).
struct JointDrive {
  // Torque constant at the joint, gear ratio included: tau_m = k_i * i. Nm/A (N/A for a
  // prismatic joint). Any finite value; 1 means "the current column already holds torque".
  double k_i = 1.0;
  // Reflected rotor inertia, added to the mass matrix diagonal. kg m^2 (kg for prismatic), >= 0.
  double rotor_inertia = 0.0;
};

// A body the arm carries, as a robot controller's payload setting holds it. Combined into the
// inertia of the body its link belongs to by build_model (parallel-axis theorem).
struct Payload {
  std::string name;                                   // key in the profile's "payloads"
  double mass = 0.0;                                  // kg, >= 0
  Eigen::Vector3d com = Eigen::Vector3d::Zero();      // centre of mass in `link`'s frame, m
  // Rotational inertia about the centre of mass, axes of `link`'s frame, kg m^2. Zero for a
  // point mass, else physical (see is_physical_inertia); zero when mass is 0.
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  std::string link;                                   // URDF link it is fixed to; empty: the tip
};

// A parsed profile. `document` is the whole JSON as read (comments dropped); the typed fields
// below are the model's view of it and are not written back by save_profile_atomically.
struct Profile {
  std::filesystem::path path;  // the file it was read from (empty when built in memory)
  // The file's text as read, comments included (empty when built in memory): save_profile_as
  // edits it so that an update changes only the members it updates.
  std::string text;
  nlohmann::json document;     // whole document; other stages own their sections
  std::filesystem::path urdf;  // URDF file, resolved against the profile's folder
  std::string root;            // chain root link (fixed to the world)
  std::string tip;             // chain tip link
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};  // in the root link's frame, m/s^2
  // One entry per moving joint of the chain, or empty when the profile has no "joints" key
  // (then every joint gets the JointDrive defaults). The count is checked by build_model, which
  // is the first place the chain is known.
  std::vector<JointDrive> joints;
  // The profile's "payloads", sorted by name, and the one the dynamics include:
  // an index into `payloads`, or -1 for none. Starts as the document's "active_payload";
  // select_payload changes it (a tool's --payload).
  std::vector<Payload> payloads;
  int active_payload = -1;

  // The payload the dynamics include, or nullptr.
  const Payload* payload() const {
    return active_payload < 0 ? nullptr : &payloads[static_cast<std::size_t>(active_payload)];
  }
};

// Top-level keys this layer knows; anything else is reported through momentum::warn.
const std::vector<std::string>& known_profile_keys();

// Reads and parses a profile file. JSON with // and /* */ comments (a UTF-8 byte order mark is
// skipped). Throws momentum::Error naming the file (and the line for syntax errors, numbers out
// of double's range and misspelt keys) when the file cannot be read, is not JSON, nests arrays
// and objects more than 64 deep, lacks urdf/root/tip, or a known key has the wrong type or
// value (gravity not 3 finite numbers, joints not an array of objects, k_i not finite,
// rotor_inertia negative, a payload with a negative or non-finite mass, a com not 3 numbers, an
// inertia not 6 numbers or not physical, a payload named "none", "active_payload" naming no
// payload). An unknown key (top level, in a "joints" entry or a payload) that is a near miss of
// a known one (the same but for case, '_' or '-'; one edit from a known key of 4 or more
// characters, two from one of 8 or more: "joint", "Joints", "ki") is an error naming the key
// it resembles, since its section would silently keep its defaults; any other unknown key is
// reported once through momentum::warn.
Profile load_profile(const std::filesystem::path& path);

// Same as load_profile for a document already in memory; `path` is used to resolve the URDF
// and in error messages (it need not exist).
Profile profile_from_document(nlohmann::json document, const std::filesystem::path& path);

// Makes the payload called `name` the active one: "none" for no payload, "" to keep the
// profile's "active_payload". Throws momentum::Error naming the profile file when no payload
// has that name (the message lists the names it has).
void select_payload(Profile& profile, const std::string& name);

// Writes `document` (format_profile_value's style, trailing newline) with core::replace_file:
// to the file `path` names after following symlinks, through a temporary file renamed over it,
// so readers see either the old or the new profile, never a torn one; the mode is kept. Throws
// momentum::Error naming the file on any I/O failure, for a target that is not a regular file
// (a device) and for a read-only profile (the temporary file is removed).
void save_profile_atomically(const nlohmann::json& document, const std::filesystem::path& path);

// Same as save_profile_atomically for a profile's text, written as given.
void save_profile_text_atomically(const std::string& text, const std::filesystem::path& path);

// How a profile in `folder` names the URDF file `urdf` (absolute, or relative to the current
// directory): relative to `folder` when the URDF is in it or below it (the two travel together,
// as a robot's folder), else absolute, so that the profile keeps working when copied alone.
std::filesystem::path urdf_reference(const std::filesystem::path& urdf, const std::filesystem::path& folder);

// Appends {"tool", "version" (momentum version), "time" (UTC, ISO-8601, seconds, 'Z'),
// "details"} to document["provenance"], creating the list when absent. Throws momentum::Error
// when "provenance" exists and is not an array.
void append_provenance(nlohmann::json& document, const std::string& tool,
                       const nlohmann::json& details);

// Saves `document`, an edited copy of `source.document`, at `destination`, atomically. The text
// written is `source.text` edited by edit_profile_text: members that did not change keep their
// text, comments and order (a profile built in memory is formatted whole). When the destination
// is in another folder than `source.path`, a relative "urdf" is rewritten with urdf_reference
// so that the new profile names the same URDF file: relative when the URDF is in the
// destination's folder or below, else absolute. Throws like save_profile_atomically.
void save_profile_as(nlohmann::json document, const Profile& source, const std::filesystem::path& destination);

// Where a tool's updated profile goes: `destination` "-" is standard output (the whole document,
// indented by 2), "" the source profile itself, anything else a file written by save_profile_as.
// Returns what was written to, for reports ("stdout" or the path). Throws like
// save_profile_as, and what writing standard output throws (core::BrokenPipe).
std::string write_updated_profile(const nlohmann::json& document, const Profile& source, const std::string& destination);

}  // namespace momentum::model
