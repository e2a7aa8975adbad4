// Text-preserving edits of a profile: a tool that updates one section of a profile (mo-calibrate's
// "thresholds", mo-friction-fit's "friction") rewrites only the text of the members that changed, so
// the profile's comments, key order and formatting survive and a nightly update is a one-section
// diff. Schema: man 5 momentum-profile.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace momentum::model {

// Returns `text` (a JSON document, // and /* */ comments allowed, as load_profile reads it)
// edited so that it parses to `updated`. The edit is structural, member by member:
//   - a member whose value is unchanged keeps its text byte for byte, comments included;
//   - a changed member whose old and new values are both objects, or both arrays of the same
//     length, is edited recursively (except one written on one line whose shape changes: see
//     below);
//   - a container written on one line that gains or loses members or elements is replaced
//     whole, on one line when it still fits;
//   - a changed array whose old elements are the first elements of the new one (the
//     "provenance" list, appended to) gets the new elements appended after the old ones;
//   - any other changed value is replaced by format_profile_value of the new one, indented
//     as the old one was (on one line when the old one was and the new one fits);
//   - new members are appended at the end of their object, in the new value's key order,
//     indented like their siblings;
//   - an object that loses a member is rewritten whole (its comments are lost).
// A UTF-8 byte order mark at the start is kept. Throws nlohmann::json::parse_error when `text` is
// not JSON with comments.
std::string edit_profile_text(const std::string& text, const nlohmann::json& updated);

// Formats `value` as the profile's own hand-written style: 2-space indent, one member or element
// per line, except that a value nesting at most two levels (an array of numbers, an object of
// scalars, a list of such objects) stays on one line when it fits in 100 columns from `column`. `indent` is the indentation of the line the value starts on;
// the value's inner lines are indented by it plus 2 spaces. No trailing newline.
std::string format_profile_value(const nlohmann::json& value, const std::string& indent = "",
                                 std::size_t column = 0);

}  // namespace momentum::model
