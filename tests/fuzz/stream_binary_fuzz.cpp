// libFuzzer target: the binary stream reader (stream::Reader on a file, mo-log(5)). An input
// that does not start with the format's magic gets the magic and version 1 put in front, so
// that mutations are spent on the header counts, names, comment records and row records, not
// on falling back to CSV; the properties checked are those of stream_fuzz.hpp.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#include "momentum/stream/format.hpp"
#include "stream_fuzz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using momentum::stream::kBinaryMagic;
  using momentum::stream::kBinaryVersion;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  if (bytes.substr(0, 1) == std::string_view(kBinaryMagic, 1)) {
    stream_fuzz::run_one(bytes);
    return 0;
  }
  std::string input(kBinaryMagic, sizeof kBinaryMagic);
  char version[4];
  std::memcpy(version, &kBinaryVersion, 4);
  input.append(version, 4);
  input.append(bytes);
  stream_fuzz::run_one(input);
  return 0;
}
