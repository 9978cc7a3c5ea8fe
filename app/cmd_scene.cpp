// `graspsim scene check FILE...`: validates scene files without running them: the
// file itself (LoadScene), then everything `run`, `replay` and `live` check when they
// build it (BuildScene: meshes, sampling, bandwidths, time step, overlaps, reachable
// fingertip targets, the tracker's bodies), so that it refuses exactly what they refuse.
#include <cstdio>
#include <memory>

#include "app/commands.h"
#include "scene/scene_file.h"

namespace gs::app {

void AddSceneCommand(CLI::App& app, int* exit_code) {
  CLI::App* scene = app.add_subcommand("scene", "Scene file tools");
  scene->require_subcommand(1);
  auto files = std::make_shared<std::vector<std::string>>();
  CLI::App* check = scene->add_subcommand("check", "Validate scene files: every error with file:line:column");
  check->add_option("files", *files, "scene files (YAML)")->required();
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
                  f.c_str(), s.name.c_str(), s.bodies.size(), s.fingers.size(), points, cps, s.duration, s.params.dt,
                  s.script.size());
    }
    *exit_code = all ? kExitOk : kExitBadInput;
  });
}

}  // namespace gs::app
