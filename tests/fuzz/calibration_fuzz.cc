// Fuzzes the calibration reader (YAML through cv::FileStorage). Any input must give a Rig
// or a ConfigError: no crash, no sanitizer report, no other exception (an escaping
// cv::Exception would end the command with "internal error" instead of exit code 2). A rig
// it accepts must pass Rig::Check and survive being written and read back unchanged.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/calibration.h"
#include "core/error.h"

namespace {

void Require(bool condition) {
  if (!condition) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string yaml(reinterpret_cast<const char*>(data), size);
  ieslam::Rig rig;
  try {
    rig = ieslam::ParseCalibration(yaml, "calib.yaml");
  } catch (const ieslam::ConfigError& e) {
    Require(std::string(e.what()).rfind("calib.yaml", 0) == 0);  // names the file
    return 0;
  }
  std::string why;
  Require(rig.Check(&why));
  const ieslam::Rig back = ieslam::ParseCalibration(ieslam::FormatCalibration(rig), "written");
  Require(back.name == rig.name && back.registered == rig.registered &&
          back.pixel_sigma == rig.pixel_sigma && back.colour.fx == rig.colour.fx &&
          back.colour.width == rig.colour.width &&
          back.range.depth_scale == rig.range.depth_scale &&
          back.range.invalid_values == rig.range.invalid_values &&
          back.range.depth_correction == rig.range.depth_correction &&
          back.T_colour_range.isApprox(rig.T_colour_range, 1e-12));
  return 0;
}
