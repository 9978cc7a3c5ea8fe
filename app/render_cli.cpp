// The rendering options of run, replay and live (docs/render.md).
#include "app/cli_help.h"
#include "app/commands.h"
#include "session/frame_recorder.h"

namespace gs::app {

void AddRenderOptions(CLI::App* cmd, RenderOptions* opt) {
  cmd->add_option("--frames", opt->frames, "write PNG frames as DIR/frame_NNNNNN.png (docs/render.md)")
      ->type_name("DIR");
  cmd->add_option("--video", opt->video, "write an H.264 MP4 video through ffmpeg")->type_name("FILE.mp4");
  cmd->add_option("--size", opt->size, "frame size in pixels, width x height (even sides for --video)")
      ->type_name("WxH")
      ->capture_default_str();
  cmd->add_option("--fps", opt->fps, "frames per simulated second")
      ->type_name("N")
      ->capture_default_str()
      ->check(IntInRange(1, 240, "a number of frames per second"));
  cmd->add_option("--force-scale", opt->force_scale,
                  "force arrow length in m per N (default: from the object's weight)")
      ->type_name("M/N")
      ->check(Positive("length in m per N"));
  cmd->add_option("--arrows", opt->arrows, "force arrows: pair (one per touching body pair), contact (one per "
                                           "contact) or none")
      ->type_name("pair|contact|none")
      ->capture_default_str()
      ->check(OneOf({"pair", "contact", "none"}, "an arrow style"));
  cmd->add_flag("--no-hud", opt->no_hud, "no heads-up display in the frames");
}

}  // namespace gs::app
