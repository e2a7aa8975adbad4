#include "momentum/model/profile_text.hpp"

#include <algorithm>
#include <cstddef>
#include <stdexcept>
#include <string_view>
#include <vector>

namespace momentum::model {

namespace {

constexpr std::size_t kWidth = 100;  // the profile's line width

// Where one JSON value lies in the text. Objects keep their members' keys and values in text
// order; arrays their elements.
struct Node {
  std::size_t begin = 0;  // first character of the value
  std::size_t end = 0;    // one past its last character
  char kind = 's';        // 'o' object, 'a' array, 's' scalar (string, number, literal)
  std::vector<std::string> keys;        // objects: decoded member names
  std::vector<std::size_t> key_begins;  // objects: the opening quote of each member's name
  std::vector<Node> children;           // object members' values, or array elements
};

// A recursive-descent scanner that only finds spans; nlohmann::json has already validated the
// text (load_profile), and parse_json re-checks it, so errors here only guard against misuse.
class Scanner {
 public:
  explicit Scanner(const std::string& text) : text_(text) {}

  Node document() {
    // A UTF-8 byte order mark, as some editors save a file: load_profile's parser skips it too,
    // and the edit keeps it in front of the document.
    if (text_.compare(0, 3, "\xEF\xBB\xBF") == 0) pos_ = 3;
    skip_blank();
    Node root = value();
    skip_blank();
    if (pos_ != text_.size()) bad("text after the document");
    return root;
  }

 private:
  [[noreturn]] void bad(const char* what) const {
    throw std::runtime_error(std::string("profile text: ") + what);
  }

  void skip_blank() {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
        ++pos_;
      } else if (c == '/' && pos_ + 1 < text_.size() && text_[pos_ + 1] == '/') {
        pos_ = text_.find('\n', pos_);
        if (pos_ == std::string::npos) pos_ = text_.size();
      } else if (c == '/' && pos_ + 1 < text_.size() && text_[pos_ + 1] == '*') {
        const std::size_t close = text_.find("*/", pos_ + 2);
        if (close == std::string::npos) bad("unterminated comment");
        pos_ = close + 2;
      } else {
        return;
      }
    }
  }

  std::size_t string_end(std::size_t at) const {
    std::size_t k = at + 1;
    while (k < text_.size() && text_[k] != '"') k += text_[k] == '\\' ? 2 : 1;
    if (k >= text_.size()) bad("unterminated string");
    return k + 1;
  }

  Node value() {
    if (pos_ >= text_.size()) bad("missing value");
    Node node;
    node.begin = pos_;
    const char c = text_[pos_];
    if (c == '{' || c == '[') {
      node.kind = c == '{' ? 'o' : 'a';
      const char close = c == '{' ? '}' : ']';
      ++pos_;
      skip_blank();
      if (pos_ < text_.size() && text_[pos_] == close) {
        node.end = ++pos_;
        return node;
      }
      while (true) {
        skip_blank();
        if (node.kind == 'o') {
          if (pos_ >= text_.size() || text_[pos_] != '"') bad("expected a member name");
          const std::size_t key_end = string_end(pos_);
          node.key_begins.push_back(pos_);
          node.keys.push_back(nlohmann::json::parse(text_.substr(pos_, key_end - pos_)).get<std::string>());
          pos_ = key_end;
          skip_blank();
          if (pos_ >= text_.size() || text_[pos_] != ':') bad("expected ':'");
          ++pos_;
          skip_blank();
        }
        node.children.push_back(value());
        skip_blank();
        if (pos_ >= text_.size()) bad("unterminated object or array");
        if (text_[pos_] == ',') {
          ++pos_;
          continue;
        }
        if (text_[pos_] != close) bad("expected ',' or the closing bracket");
        node.end = ++pos_;
        return node;
      }
    }
    if (c == '"') {
      pos_ = string_end(pos_);
    } else {
      while (pos_ < text_.size() && std::string_view(",]}/ \t\r\n").find(text_[pos_]) == std::string_view::npos)
        ++pos_;
    }
    node.end = pos_;
    if (node.end == node.begin) bad("empty value");
    return node;
  }

  const std::string& text_;
  std::size_t pos_ = 0;
};

nlohmann::json parse_json(const std::string& text) {
  return nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/true, /*ignore_comments=*/true);
}

struct Replacement {
  std::size_t begin, end;
  std::string text;
};

// The whitespace at the start of the line holding `pos`, and the column of `pos`.
std::string line_indent(const std::string& text, std::size_t pos, std::size_t* column = nullptr) {
  const std::size_t line = text.rfind('\n', pos == 0 ? 0 : pos - 1);
  const std::size_t start = (line == std::string::npos || pos == 0) ? 0 : line + 1;
  std::size_t k = start;
  while (k < pos && (text[k] == ' ' || text[k] == '\t')) ++k;
  if (column) *column = pos - start;
  return text.substr(start, k - start);
}

bool is_scalar(const nlohmann::json& v) { return !v.is_object() && !v.is_array(); }

// How deeply containers nest in `value`: 0 for a scalar, 1 for a flat array or object.
int nesting(const nlohmann::json& value) {
  if (is_scalar(value)) return 0;
  int deepest = 0;
  for (const auto& item : value) deepest = std::max(deepest, nesting(item));
  return deepest + 1;
}

std::string one_line(const nlohmann::json& value) {
  if (is_scalar(value)) return value.dump();
  std::string out(1, value.is_object() ? '{' : '[');
  bool first = true;
  for (auto it = value.begin(); it != value.end(); ++it) {
    if (!first) out += ", ";
    first = false;
    if (value.is_object()) out += nlohmann::json(it.key()).dump() + ": ";
    out += one_line(*it);
  }
  out += value.is_object() ? '}' : ']';
  return out;
}

// The position where text after the value ending at `end` may be inserted on a new line: after
// a comment that ends the value's line, else right after the value.
std::size_t after_line_comment(const std::string& text, std::size_t end) {
  std::size_t k = end;
  while (k < text.size() && (text[k] == ' ' || text[k] == '\t')) ++k;
  if (text.compare(k, 2, "//") == 0) {
    const std::size_t eol = text.find('\n', k);
    return eol == std::string::npos ? text.size() : eol;
  }
  return end;
}

bool spans_lines(const std::string& text, const Node& node) {
  return std::find(text.begin() + static_cast<std::ptrdiff_t>(node.begin),
                   text.begin() + static_cast<std::ptrdiff_t>(node.end), '\n') !=
         text.begin() + static_cast<std::ptrdiff_t>(node.end);
}

// Appends `items` (pre-formatted: "\"key\": value" or an element) after the last child.
void append_items(const std::string& text, const Node& node, const std::vector<std::string>& items,
                  std::vector<Replacement>& edits) {
  const Node& last = node.children.back();
  if (spans_lines(text, node)) {
    const std::size_t first_child = node.kind == 'o' ? node.key_begins.back() : last.begin;
    const std::string indent = line_indent(text, first_child);
    std::string lines;
    for (std::size_t k = 0; k < items.size(); ++k) lines += (k ? ",\n" : "\n") + indent + items[k];
    // The comma goes right after the value, the new lines after a comment ending its line.
    const std::size_t at = after_line_comment(text, last.end);
    if (at == last.end) {
      edits.push_back({at, at, "," + lines});
    } else {
      edits.push_back({last.end, last.end, ","});
      edits.push_back({at, at, lines});
    }
  } else {
    std::string inserted;
    for (const auto& item : items) inserted += ", " + item;
    edits.push_back({last.end, last.end, inserted});
  }
}

std::string formatted_at(const std::string& text, const Node& node, const nlohmann::json& value) {
  std::size_t column = 0;
  const std::string indent = line_indent(text, node.begin, &column);
  return format_profile_value(value, indent, column);
}

// True when `a` and `b` differ at most in scalar values: same container types, same keys, same
// array lengths.
bool same_shape(const nlohmann::json& a, const nlohmann::json& b) {
  if (is_scalar(a) || is_scalar(b)) return is_scalar(a) && is_scalar(b);
  if (a.type() != b.type() || a.size() != b.size()) return false;
  if (a.is_object()) {
    for (auto it = a.begin(); it != a.end(); ++it) {
      const auto other = b.find(it.key());
      if (other == b.end() || !same_shape(*it, *other)) return false;
    }
    return true;
  }
  for (std::size_t k = 0; k < a.size(); ++k)
    if (!same_shape(a[k], b[k])) return false;
  return true;
}

void edit(const std::string& text, const Node& node, const nlohmann::json& old_value,
          const nlohmann::json& new_value, std::vector<Replacement>& edits) {
  if (old_value == new_value) return;
  // A container written on one line is edited in place only for new values of its scalars;
  // anything else rewrites it whole, on one line when it still fits, else spread out.
  if (node.kind != 's' && !spans_lines(text, node) && !same_shape(old_value, new_value)) {
    edits.push_back({node.begin, node.end, formatted_at(text, node, new_value)});
    return;
  }
  if (node.kind == 'o' && new_value.is_object() && old_value.is_object() && !node.children.empty()) {
    const bool loses_a_member = std::any_of(node.keys.begin(), node.keys.end(),
                                            [&](const std::string& k) { return !new_value.contains(k); });
    // Duplicate names in the text (the last one wins in nlohmann) are not edited in place.
    std::vector<std::string> sorted = node.keys;
    std::sort(sorted.begin(), sorted.end());
    const bool duplicates = std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end();
    if (!loses_a_member && !duplicates) {
      for (std::size_t k = 0; k < node.children.size(); ++k)
        edit(text, node.children[k], old_value.at(node.keys[k]), new_value.at(node.keys[k]), edits);
      std::vector<std::string> added;
      const std::size_t column = node.key_begins.back() - (text.rfind('\n', node.key_begins.back()) + 1);
      const std::string indent = line_indent(text, node.key_begins.back());
      for (const auto& item : new_value.items()) {
        if (old_value.contains(item.key())) continue;
        const std::string name = nlohmann::json(item.key()).dump() + ": ";
        added.push_back(name + format_profile_value(item.value(), indent, column + name.size()));
      }
      if (!added.empty()) append_items(text, node, added, edits);
      return;
    }
  }
  if (node.kind == 'a' && new_value.is_array() && old_value.is_array() && new_value.size() == old_value.size()) {
    for (std::size_t k = 0; k < node.children.size(); ++k) edit(text, node.children[k], old_value[k], new_value[k], edits);
    return;
  }
  if (node.kind == 'a' && new_value.is_array() && old_value.is_array() && !node.children.empty() &&
      new_value.size() > old_value.size() &&
      std::equal(old_value.begin(), old_value.end(), new_value.begin())) {
    std::size_t column = 0;
    const std::string indent = line_indent(text, node.children.back().begin, &column);
    std::vector<std::string> added;
    for (std::size_t k = old_value.size(); k < new_value.size(); ++k)
      added.push_back(format_profile_value(new_value[k], indent, spans_lines(text, node) ? indent.size() : column));
    append_items(text, node, added, edits);
    return;
  }
  edits.push_back({node.begin, node.end, formatted_at(text, node, new_value)});
}

}  // namespace

std::string format_profile_value(const nlohmann::json& value, const std::string& indent, std::size_t column) {
  if (is_scalar(value)) return value.dump();
  if (value.empty()) return value.is_object() ? "{}" : "[]";
  // Up to a list of small objects ("joints": [{"k_i": 11}, ...]) on one line when it fits.
  if (nesting(value) <= 2) {
    const std::string line = one_line(value);
    if (column + line.size() <= kWidth) return line;
  }
  const std::string inner = indent + "  ";
  std::string out(1, value.is_object() ? '{' : '[');
  bool first = true;
  for (auto it = value.begin(); it != value.end(); ++it) {
    out += first ? "\n" : ",\n";
    first = false;
    out += inner;
    std::string name;
    if (value.is_object()) name = nlohmann::json(it.key()).dump() + ": ";
    out += name + format_profile_value(*it, inner, inner.size() + name.size());
  }
  out += "\n" + indent + (value.is_object() ? '}' : ']');
  return out;
}

std::string edit_profile_text(const std::string& text, const nlohmann::json& updated) {
  // A UTF-8 byte order mark (an editor's) is no JSON to the scanner: kept, and the rest edited.
  static constexpr std::string_view kByteOrderMark = "\xEF\xBB\xBF";
  if (text.starts_with(kByteOrderMark))
    return std::string(kByteOrderMark) + edit_profile_text(text.substr(kByteOrderMark.size()), updated);
  const nlohmann::json original = parse_json(text);
  const Node root = Scanner(text).document();
  std::vector<Replacement> edits;
  edit(text, root, original, updated, edits);
  // Apply from the end so earlier positions stay valid; insertions at one position keep their order.
  std::stable_sort(edits.begin(), edits.end(),
                   [](const Replacement& a, const Replacement& b) { return a.begin > b.begin; });
  std::string out = text;
  for (const auto& e : edits) out.replace(e.begin, e.end - e.begin, e.text);
  return out;
}

}  // namespace momentum::model
