// `graspsim scene check FILE...`: validates scene files without running them: the
// file itself (LoadScene), then everything `run`, `replay` and `live` check when they
// build it (BuildScene: meshes, sampling, bandwidths, time step, overlaps, reachable
// fingertip targets, the tracker's bodies), so that it refuses exactly what they refuse.
#include <cstdio>
#include <memory>

#include "app/cli_help.h"
#include "app/commands.h"
#include "scene/scene_file.h"

namespace gs::app {

void AddSceneCommand(CLI::App& app, int* exit_code) {
  CLI::App* scene = app.add_subcommand("scene", "Scene file tools: check scene files as run loads them");
  scene->require_subcommand(1);
  SetHelpFooter(scene,
                {{"graspsim scene check config/*.yaml", "check every scene that ships with graspsim"}},
                {{kExitOk, "every file is a scene that run accepts"},
                 {kExitUsage, "bad command line, or an unknown scene command (the list is printed)"},
                 {kExitBadInput, "a file was refused: each error as FILE:LINE:COLUMN: message"}});
  auto files = std::make_shared<std::vector<std::string>>();
  CLI::App* check = scene->add_subcommand(
      "check", "Validate scene files and build them as run does: every error with file:line:column");
  check->group("Commands");
  check->add_option("files", *files, "scene files (YAML, docs/scene-format.md)")->type_name("SCENE.yaml")->required();
  SetHelpFooter(check,
                {{"graspsim scene check config/*.yaml", "one ok line per scene: bodies, fingers, points, duration"},
                 {"graspsim scene check tests/data/scenes/deep_overlap.yaml",
                  "a refused scene: the line and column, and the value to use"}},
                {{kExitOk, "every file loads and builds"},
                 {kExitUsage, "bad command line (no file given)"},
                 {kExitBadInput, "a file was refused (the others are still checked): each error as "
                                 "FILE:LINE:COLUMN: message"}});
  check->callback([files, exit_code]() {
    bool all = true;
    for (const std::string& f : *files) {
      Scene s;
      std::vector<SceneError> errors;
      auto built = std::make_unique<BuiltScene>();
      if (!LoadScene(f, &s, &errors) || !BuildScene(s, built.get(), &errors)) {
        all = false;
        for (const SceneError& e : errors) std::fprintf(stderr, "%s\n", e.Format().c_str());
        continue;
      }
      if (!built->sizes_note.empty()) std::fprintf(stderr, "%s\n", built->sizes_note.c_str());
      int points = 0, cps = 0;
      for (const SceneBody& b : s.bodies) {
        points += b.spec.geometry.points;
        cps += b.spec.geometry.control_points;
      }
      for (const SceneFinger& fg : s.fingers) {
        points += fg.tip.spec.geometry.points;
        cps += fg.tip.spec.geometry.control_points;
      }
      std::printf("%s: ok: scene '%s', %zu bodies, %zu fingers, %d points, %d control points, %.3f s in steps of %g s, "
                  "%zu script keyframes\n",
                  f.c_str(), s.name.c_str(), s.bodies.size(), built->world.hand.fingers.size(), points, cps, s.duration,
                  s.params.dt,
                  s.script.size());
    }
    *exit_code = all ? kExitOk : kExitBadInput;
  });
}

}  // namespace gs::app
