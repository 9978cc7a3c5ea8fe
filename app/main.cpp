// graspsim: real-time grasping of quasi-rigid point-based objects with exact
// Coulomb friction. See README.md.
#include <cstdio>

#include "app/cli_help.h"
#include "app/commands.h"
#include "session/console.h"

int main(int argc, char** argv) {
  // progress and summaries line by line, also through a pipe or into a log file
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  // Ctrl-C and SIGTERM: every command stops at its next step, writes what it has, exits 130
  gs::app::InstallStopSignals();
  CLI::App app{"graspsim: real-time virtual grasping of deformable objects with exact Coulomb friction", "graspsim"};
  app.formatter(gs::app::MakeHelpFormatter());  // before the commands: they inherit it
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
  gs::app::AddBridgeCommand(app, &exit_code);
  for (CLI::App* cmd : app.get_subcommands({})) cmd->group("Commands");
  gs::app::SetHelpFooter(
      &app,
      {{"graspsim run config/paper_box_grasp.yaml --out out/ --video grasp.mp4",
        "the paper's box grasp: its timing tables, the output files in out/ and an MP4 video"},
       {"graspsim scene check config/*.yaml", "check scene files as run would load them"},
       {"graspsim replay assets/demo_session.lcmlog --out out/", "replay a recorded tracker session"},
       {"graspsim COMMAND --help", "each command's options, examples and exit codes"}},
      {{gs::app::kExitOk, "success"},
       {gs::app::kExitFailure, "a failed check: a validation case, a solve at its iteration cap, a run in which a "
                               "body passed through another"},
       {gs::app::kExitUsage, "bad command line"},
       {gs::app::kExitBadInput, "bad input file: scene, mesh, FCLIB file or session log"},
       {gs::app::kExitInterrupted, "interrupted (Ctrl-C, SIGTERM) after writing what was computed; live and record end with 0, "
                                    "a stop being their normal end"}});
  app.footer(app.get_footer() + "\n\nThe scene format, output files and benchmarks: README.md and docs/.");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // bench nosuch, scene, graspsim nosuch: say which commands there are
    const std::string unknown = e.get_exit_code() == 0 ? std::string() : gs::app::UnknownCommandMessage(app);
    if (!unknown.empty()) {
      std::fprintf(stderr, "%s\n", unknown.c_str());
      return gs::app::kExitUsage;
    }
    const int rc = app.exit(e);
    return rc == 0 ? 0 : gs::app::kExitUsage;
  }
  // a command with a set amount of work that was stopped says so in its exit code;
  // live, record and bridge run until they are stopped, and that is their normal end
  const bool runs_until_stopped = app.got_subcommand("live") || app.got_subcommand("record") ||
                                  app.got_subcommand("bridge");
  if (gs::app::StopRequested() && !runs_until_stopped && exit_code != gs::app::kExitUsage &&
      exit_code != gs::app::kExitBadInput)
    return gs::app::kExitInterrupted;
  return exit_code;
}
