// The exit codes every graspsim command shares (README "Using it"). They live
// beside the scene loader because every library that runs a command's work
// (session, validate, bench) depends on it, and refusing an input file is where
// most of them start.
#pragma once

namespace gs::app {

enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,     ///< the command ran and something failed (a validation case, a bench target)
  kExitUsage = 2,       ///< bad command line
  kExitBadInput = 3,    ///< a scene, mesh, log or problem file was refused
  kExitMissingTool = 4, ///< an outside program graspsim calls to draw figures (gnuplot) is missing or failed
  kExitInterrupted = 130,
};

}  // namespace gs::app
