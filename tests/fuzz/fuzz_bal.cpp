// libFuzzer harness: the BAL problem reader (calib/bundle.h). Any input is a
// problem whose arrays match its counts, or a std::runtime_error.
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>

#include "calib/bundle.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > (1 << 16)) return 0;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const lf::calib::BundleProblem p = lf::calib::read_bal(in, "<fuzz>");
    if (p.cameras.size() != 9 * static_cast<size_t>(p.num_cameras) ||
        p.points.size() != 3 * static_cast<size_t>(p.num_points))
      std::abort();
  } catch (const std::runtime_error&) {
  }
  return 0;
}
