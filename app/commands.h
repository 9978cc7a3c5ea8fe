// Each graspsim subcommand registers itself on the CLI through one of these.
// The callback runs the command and stores its exit code in *exit_code.
#pragma once

#include <CLI/CLI.hpp>

#include "scene/exit_code.h"

namespace gs::tracking {
struct UdpOptions;
}

namespace gs::app {

struct RenderOptions;

void AddRunCommand(CLI::App& app, int* exit_code);
void AddBenchCommand(CLI::App& app, int* exit_code);
void AddValidateCommand(CLI::App& app, int* exit_code);
void AddSceneCommand(CLI::App& app, int* exit_code);
void AddSolveCommand(CLI::App& app, int* exit_code);
void AddRecordCommand(CLI::App& app, int* exit_code);
void AddSendCommand(CLI::App& app, int* exit_code);
void AddReplayCommand(CLI::App& app, int* exit_code);
void AddLiveCommand(CLI::App& app, int* exit_code);
void AddStressCommand(CLI::App& app, int* exit_code);
void AddPlotCommand(CLI::App& app, int* exit_code);
void AddBridgeCommand(CLI::App& app, int* exit_code);

/// --port (required), --multicast, --allow, --controller (record, bridge).
void AddUdpReceiveOptions(CLI::App* cmd, tracking::UdpOptions* udp);

/// --frames, --video, --size, --fps, --force-scale, --arrows, --no-hud (run, replay, live).
void AddRenderOptions(CLI::App* cmd, RenderOptions* opt);

}  // namespace gs::app
