#include "apps/commands.h"

namespace ieslam {

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {
      {"run", "dataset -> features -> keyframe selection -> EIF (-> bundle adjustment)",
       RunCommand},
      {"refine", "bundle-adjust an earlier run's keyframes again (batch refinement)",
       RefineCommand},
      {"localize", "place each frame of a dataset in a saved map (ieslam run's OUT/map)",
       LocalizeCommand},
      {"evaluate", "TUM-compatible ATE / RPE of a trajectory against ground truth",
       EvaluateCommand},
      {"simulate", "the paper's simulation: Table I and filter consistency", SimulateCommand},
      {"synth", "write a synthetic RGB-D dataset with exact ground truth", SynthCommand},
      {"register", "register frame i to i+K across a dataset against ground truth",
       RegisterCommand},
      {"options", "every option with its default and help, as a --config file", OptionsCommand},
  };
  return commands;
}

}  // namespace ieslam
