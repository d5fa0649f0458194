// Calibration files: a Rig (colour camera, range imager, extrinsics) in YAML.
//
// The format (cv::FileStorage YAML; `#` comments allowed; the `%YAML:1.0` first line
// OpenCV wants is optional in files we read; one document, top-level keys in column 1, see
// core/yaml_text.h). Every key is required unless noted:
//
//   name: tum_fr1
//   registered: 1            # 1: depth registered to colour (range intrinsics copied
//                            #    from colour, extrinsics identity); 0: two cameras
//   pixel_sigma: 1.0         # keypoint position standard deviation, pixels
//   colour:
//     width: 640
//     height: 480
//     fx: 517.3
//     fy: 516.5
//     cx: 318.6
//     cy: 255.3
//     distortion: [k1, k2, p1, p2, k3]    # OpenCV order
//     readout_s: 0.025       # optional: rolling shutter, first to last row (Rig::colour_readout_s)
//   range:
//     width, height, fx, fy, cx, cy, distortion   # may be omitted when registered: 1
//                                                 # (if given they must equal colour's)
//     depth_scale: 0.0002    # metres per raw 16-bit unit
//     depth_kind: z          # z (Kinect) or radial (distance along the ray, time of flight)
//     invalid_values: [0]    # raw values meaning "no measurement" (may be [])
//     min_range_m: 0.3
//     max_range_m: 10.0
//     noise: {a: 0.0002, b: 0.0, c: 0.0016}   # sigma(d) = a + b d + c d^2 metres
//   T_colour_range: [16 values]   # 4x4 row-major, p_colour = T * p_range; may be
//                                 # omitted when registered: 1 (then must be identity)
//
// Unknown keys are rejected, so that a misspelt optional key cannot pass unnoticed.
#pragma once

#include <string>

#include "core/camera.h"

namespace ieslam {

// Reads and validates (Rig::Check) a calibration file. Throws ConfigError naming the file
// and the key for a missing file, a YAML syntax error, a missing or unknown key, a value of
// the wrong type, NaN/inf, a value outside its physical range (focal length, principal
// point, a distortion that does not map the image one-to-one, depth scale, noise; each
// bound is argued in calibration.cc), or a rig that fails Rig::Check. The extrinsic rotation is
// projected onto the nearest rotation (files carry a few decimals).
Rig ReadCalibration(const std::string& path);

// The same from a YAML string; `source` names it in error messages.
Rig ParseCalibration(const std::string& yaml, const std::string& source);

// The YAML text of a rig (17 significant digits, so Parse(Format(rig)) == rig).
// CHECKs that the rig passes Rig::Check: writing a bad rig is a programmer error.
std::string FormatCalibration(const Rig& rig);

// Writes FormatCalibration(rig) atomically. Throws DataError when the file cannot be written.
void WriteCalibration(const std::string& path, const Rig& rig);

// `<DataDirectory()>/calib/<name>.yaml` (core/data_directory.h): the calibration files shipped
// in data/calib/ ("tum_fr1", "tum_fr2", "tum_fr3", "7scenes", "sr3000_dragonfly2"). Throws
// ConfigError naming the places searched when no data directory is found.
std::string DefaultCalibrationPath(const std::string& name);

}  // namespace ieslam
