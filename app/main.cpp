// graspsim: real-time grasping of quasi-rigid point-based objects with exact
// Coulomb friction. See README.md.
#include <cstdio>

#include "app/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"graspsim: real-time virtual grasping of deformable objects with exact Coulomb friction"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "graspsim 0.1.0");
  int exit_code = gs::app::kExitOk;
  // one line per subcommand (see app/commands.h)
  gs::app::AddBenchCommand(app, &exit_code);
  gs::app::AddValidateCommand(app, &exit_code);
  gs::app::AddRunCommand(app, &exit_code);
  gs::app::AddSceneCommand(app, &exit_code);
  gs::app::AddSolveCommand(app, &exit_code);
  gs::app::AddRecordCommand(app, &exit_code);
  gs::app::AddSendCommand(app, &exit_code);
  gs::app::AddReplayCommand(app, &exit_code);
  gs::app::AddLiveCommand(app, &exit_code);
  gs::app::AddStressCommand(app, &exit_code);
  gs::app::AddPlotCommand(app, &exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : gs::app::kExitUsage;
  }
  return exit_code;
}
