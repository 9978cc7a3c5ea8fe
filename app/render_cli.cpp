// The rendering options of run, replay and live (docs/render.md).
#include "app/commands.h"
#include "session/frame_recorder.h"

namespace gs::app {

void AddRenderOptions(CLI::App* cmd, RenderOptions* opt) {
  cmd->add_option("--frames", opt->frames, "write frames as DIR/frame_NNNNNN.png (docs/render.md)");
  cmd->add_option("--video", opt->video, "write an MP4 video through ffmpeg (H.264)");
  cmd->add_option("--size", opt->size, "frame size WxH (even sides for --video)")->capture_default_str();
  cmd->add_option("--fps", opt->fps, "frames per simulated second")->capture_default_str()->check(CLI::Range(1, 240));
  cmd->add_option("--force-scale", opt->force_scale, "force arrow length (m per N; default from the object's weight)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--arrows", opt->arrows, "force arrows: pair (one per touching body pair), contact, none")
      ->capture_default_str()
      ->check(CLI::IsMember({"pair", "contact", "none"}));
  cmd->add_flag("--no-hud", opt->no_hud, "no heads-up display in the frames");
}

}  // namespace gs::app
