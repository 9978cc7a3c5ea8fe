// graspsim: real-time grasping of quasi-rigid point-based objects with exact
// Coulomb friction. See README.md.
#include <cstdio>

#include "app/commands.h"
#include "session/console.h"

int main(int argc, char** argv) {
  // progress and summaries line by line, also through a pipe or into a log file
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  // Ctrl-C and SIGTERM: every command stops at its next step, writes what it has, exits 130
  gs::app::InstallStopSignals();
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
  // a command with a set amount of work that was stopped says so in its exit code;
  // live and record run until they are stopped, and that is their normal end
  const bool runs_until_stopped = app.got_subcommand("live") || app.got_subcommand("record");
  if (gs::app::StopRequested() && !runs_until_stopped && exit_code != gs::app::kExitUsage &&
      exit_code != gs::app::kExitBadInput)
    return gs::app::kExitInterrupted;
  return exit_code;
}
