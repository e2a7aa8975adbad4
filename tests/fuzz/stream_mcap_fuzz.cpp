// libFuzzer target: the MCAP reader (a ROS 2 bag through stream::Reader on a file, mo-log(5)
// MCAP): the container (records, chunks and their compressions, CRCs, the summary read from the
// file's end) and the CDR JointState decoding. An input that does not start with 0x89 gets the
// MCAP magic put in front, so that mutations are spent on the records, not on falling back to
// CSV; the properties checked are those of stream_fuzz.hpp (every bad part reported and counted
// or fatal in strict mode alike; what was read writes and reads back the same).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "momentum/stream/mcap.hpp"
#include "stream_fuzz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using momentum::stream::mcap::kMagic;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  if (bytes.substr(0, 1) == std::string_view(kMagic, 1)) {
    stream_fuzz::run_one(bytes);
    return 0;
  }
  std::string input(kMagic, sizeof kMagic);
  input.append(bytes);
  stream_fuzz::run_one(input);
  return 0;
}
