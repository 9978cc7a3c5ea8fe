// Each graspsim subcommand registers itself on the CLI through one of these.
// The callback runs the command and stores its exit code in *exit_code.
#pragma once

#include <CLI/CLI.hpp>

namespace gs::app {

/// Exit codes shared by every subcommand.
enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,     ///< the command ran and something failed (a validation case, a bench target)
  kExitUsage = 2,       ///< bad command line
  kExitBadInput = 3,    ///< a scene, mesh, log or problem file was refused
  kExitInterrupted = 130,
};

void AddRunCommand(CLI::App& app, int* exit_code);
void AddBenchCommand(CLI::App& app, int* exit_code);
void AddValidateCommand(CLI::App& app, int* exit_code);
void AddSceneCommand(CLI::App& app, int* exit_code);
void AddSolveCommand(CLI::App& app, int* exit_code);
// tracking (issue 4)
void AddRecordCommand(CLI::App& app, int* exit_code);
void AddSendCommand(CLI::App& app, int* exit_code);
void AddReplayCommand(CLI::App& app, int* exit_code);
void AddLiveCommand(CLI::App& app, int* exit_code);
// stress and scaling (issue 6)
void AddStressCommand(CLI::App& app, int* exit_code);

}  // namespace gs::app
