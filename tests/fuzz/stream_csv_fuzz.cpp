// libFuzzer target: the CSV stream reader (stream::Reader on a file). The input is the file as
// it is, so the format detection from the first byte is fuzzed as well; the properties checked
// are those of stream_fuzz.hpp.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "stream_fuzz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  stream_fuzz::run_one(std::string_view(reinterpret_cast<const char*>(data), size));
  return 0;
}
