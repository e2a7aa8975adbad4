#pragma once
// Small text helpers every stage shares: trimming, splitting lists and words, showing untrusted
// bytes in messages, and the UTF-8 byte order mark some editors put at the start of a file.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace momentum::core {

// `text` without leading and trailing blanks: spaces, tabs, and CR/LF (a line of a file
// written on Windows).
std::string_view trim(std::string_view text);

// Splits "a,b,c" at `separator` into its parts (not trimmed); an empty text gives no parts,
// "a,,b" gives an empty middle part.
std::vector<std::string> split(std::string_view text, char separator = ',');

// The words of a text one after the other, allocating nothing: the one splitter for the
// parsers that run on every line of a capture (candump, ASC; millions of lines, where split's
// vector of strings per line would cost more than the parse). A word is a run of characters
// other than space and tab. A Words is a cursor: copy it to come back to where it was.
class Words {
 public:
  explicit Words(std::string_view text) : rest_(text) {}
  // The next word (a view into the text), or an empty view when no word is left.
  std::string_view next() {
    std::size_t k = 0;
    while (k < rest_.size() && blank(rest_[k])) ++k;
    const std::size_t start = k;
    while (k < rest_.size() && !blank(rest_[k])) ++k;
    const std::string_view word = rest_.substr(start, k - start);
    rest_.remove_prefix(k);
    return word;
  }
  // The text after the last word returned.
  std::string_view rest() const { return rest_; }

 private:
  static bool blank(char c) { return c == ' ' || c == '\t'; }
  std::string_view rest_;
};

// Untrusted bytes as a message may show them: printable ASCII and valid UTF-8 as they are,
// anything else (NUL, control characters, bytes that are not UTF-8, DEL) as \xNN, a backslash
// as \\. At most `max_bytes` of the input are shown, then "...".
std::string printable(std::string_view bytes, std::size_t max_bytes = 40);

// The UTF-8 byte order mark (EF BB BF).
inline constexpr std::string_view kByteOrderMark = "\xEF\xBB\xBF";
// `text` without a leading byte order mark.
inline std::string_view strip_byte_order_mark(std::string_view text) {
  return text.substr(0, 3) == kByteOrderMark ? text.substr(3) : text;
}

}  // namespace momentum::core
