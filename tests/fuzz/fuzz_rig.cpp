// libFuzzer harness: the rig file loader (lib/lf/io/rig_file.h). Any input is
// a finalized rig or a std::runtime_error; nothing else may escape.
#include <cstdint>
#include <stdexcept>
#include <string>

#include "lf/io/rig_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > (1 << 13)) return 0;  // rig files of a few cameras: enough to reach every branch
  try {
    const lf::Rig rig = lf::rig_from_json(std::string(reinterpret_cast<const char*>(data), size));
    (void)lf::rig_to_json(rig);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
