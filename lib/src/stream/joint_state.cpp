#include "momentum/stream/joint_state.hpp"

#include <bit>
#include <cstdio>
#include <cstring>
#include <utility>

namespace momentum::stream::ros2 {

namespace {

// A CDR stream after its encapsulation header. XCDR1 aligns a primitive of n bytes to a
// multiple of n from the start of the data (the byte after the 4-byte header).
class CdrInput {
 public:
  CdrInput(std::string_view data, bool little) : s_(data), swap_(little != (std::endian::native == std::endian::little)) {}

  const char* failure = nullptr;

  template <typename T>
  bool read(T& value) {
    if (!align(sizeof(T))) return false;
    if (s_.size() - at_ < sizeof(T)) return fail("a field runs past the end of the message");
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, s_.data() + at_, sizeof(T));
    if (swap_)
      for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    std::memcpy(&value, bytes, sizeof(T));
    at_ += sizeof(T);
    return true;
  }

  // A CDR string: uint32 length counting the terminating NUL, then the bytes and the NUL.
  bool read_string(std::string& out) {
    std::uint32_t length = 0;
    if (!read(length)) return false;
    if (length == 0) return fail("a string of length 0 (CDR strings hold their NUL)");
    if (s_.size() - at_ < length) return fail("a string runs past the end of the message");
    if (s_[at_ + length - 1] != '\0') return fail("a string without its terminating NUL");
    out.assign(s_.data() + at_, length - 1);
    at_ += length;
    return true;
  }

  // A sequence's element count, checked against the bytes left (each element takes at least
  // `min_size` bytes), so that a corrupt count cannot make the caller allocate.
  bool read_count(std::uint32_t& count, std::size_t min_size) {
    if (!read(count)) return false;
    if (count > (s_.size() - at_) / min_size) return fail("a sequence count larger than the message could hold");
    return true;
  }

  bool read_doubles(std::vector<double>& out) {
    std::uint32_t count = 0;
    if (!read_count(count, sizeof(double))) return false;
    out.resize(count);
    for (double& v : out)
      if (!read(v)) return false;
    return true;
  }

 private:
  bool align(std::size_t n) {
    const std::size_t padded = (at_ + n - 1) / n * n;
    if (padded > s_.size()) return fail("a field runs past the end of the message");
    at_ = padded;
    return true;
  }
  bool fail(const char* why) {
    failure = why;
    return false;
  }
  std::string_view s_;
  std::size_t at_ = 0;
  bool swap_;
};

}  // namespace

std::string decode_joint_state(std::string_view bytes, JointState& out) {
  if (bytes.size() < 4) return "message of " + std::to_string(bytes.size()) + " bytes, shorter than its CDR header";
  const auto b0 = static_cast<unsigned char>(bytes[0]), b1 = static_cast<unsigned char>(bytes[1]);
  if (b0 != 0 || b1 > 1) {
    char id[8];
    std::snprintf(id, sizeof id, "%02x%02x", b0, b1);
    return std::string("CDR encapsulation 0x") + id + " is not plain XCDR1 (00 00 or 00 01)";
  }
  CdrInput in(bytes.substr(4), b1 == 1);
  std::uint32_t names = 0;
  bool ok = in.read(out.stamp_sec) && in.read(out.stamp_nanosec) && in.read_string(out.frame_id) &&
            in.read_count(names, 5);  // a string: 4 bytes of length and its NUL at least
  if (ok) {
    out.name.resize(names);
    for (std::string& name : out.name)
      if (!(ok = in.read_string(name))) break;
  }
  ok = ok && in.read_doubles(out.position) && in.read_doubles(out.velocity) && in.read_doubles(out.effort);
  if (!ok) return in.failure ? in.failure : "bad message";
  return {};
}

}  // namespace momentum::stream::ros2
