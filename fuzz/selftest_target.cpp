// A deliberately wrong fuzz target for the driver's own test (fuzz/CMakeLists.txt): it refuses
// most inputs with relief::Error, as the real targets do, but throws std::runtime_error for an
// input that mentions the volcano stage, which the replay driver must report as a failure.
#include <cstdint>
#include <stdexcept>
#include <string>

#include "relief/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    if (text.find("\"volcano\"") != std::string::npos) throw std::runtime_error("not a relief::Error");
    throw relief::Error("", "refused");
  } catch (const relief::Error&) {
  }
  return 0;
}
