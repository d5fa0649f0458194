// `ieslam synth`: a synthetic RGB-D dataset with exact ground truth.
#include <algorithm>
#include <iostream>
#include <vector>

#include "apps/app_util.h"
#include "apps/commands.h"
#include "apps/interrupt.h"
#include "core/error.h"
#include "frontend/simulation/synthetic_dataset.h"

namespace ieslam {

int SynthCommand(const CommandArgs& args) {
  const std::vector<FlagSpec> specs = {
      {"output", "DIR", "dataset directory to write (required)"},
      {"frames", "N", "number of frames at 30 Hz (default 300)"},
      {"sensor", "S",
       "rgbd (640x480 registered colour + depth, TUM layout) or pair (1024x768 "
       "camera + 176x144 range imager, pair layout) (default rgbd)"},
      {"seed", "S", "scene seed; the sensor noise is seeded with S + 1 (default 1)"},
      {"readout", "SECONDS",
       "rgbd: a rolling shutter reading its rows in this time, first to last (default 0: a "
       "global shutter); calib.yaml carries it"},
      {"depth-correction", "A,B,C",
       "the range imager reads each depth times 1 + A x + B y + C (x^2 + y^2) at its pixel's "
       "normalised coordinates (a depth tilt and bowl, default 0,0,0); calib.yaml carries it"},
      {"threads", "N", "rendering threads, 0 = all cores; never changes the output (default 0)"}};
  const Flags flags(args, specs);
  if (flags.help()) {
    std::cout << FormatHelp("synth", "--output DIR [flags]",
                            "Renders a textured room along a closed hand-held-like trajectory and\n"
                            "writes a dataset `ieslam run --dataset DIR` reads, with ground truth.",
                            specs);
    return 0;
  }
  const std::string output = flags.Require("output");
  SyntheticDatasetOptions options;
  options.frames = flags.GetInt("frames", options.frames, 2, 1000000);
  options.sensor = ParseSyntheticSensor(flags.GetString("sensor", "rgbd"));
  const int seed = flags.GetInt("seed", 1, 0, 2000000000);
  options.scene.seed = static_cast<uint32_t>(seed);
  options.noise_seed = static_cast<uint32_t>(seed) + 1;
  options.threads = flags.GetInt("threads", 0, 0, 256);
  options.readout_s = flags.GetDouble("readout", 0.0, -0.2, 0.2);
  const std::vector<double> correction =
      flags.GetDoubleList("depth-correction", {0.0, 0.0, 0.0}, 3, -0.5, 0.5);
  std::copy(correction.begin(), correction.end(), options.depth_correction.begin());
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  PrepareOutputDirectory(output);
  const StopOnInterrupt interrupt;  // Ctrl-C: a shorter dataset, still complete
  const int frames = WriteSyntheticDataset(output, options, interrupt.Poll());
  std::cout << "synth: wrote " << frames << " " << ToString(options.sensor)
            << " frames with ground truth to " << output << "\n";
  if (frames < options.frames) {
    std::cerr << "synth: interrupted after " << frames << " of " << options.frames
              << " frames; the dataset holds those\n";
    return interrupt.exit_code();
  }
  return 0;
}

}  // namespace ieslam
