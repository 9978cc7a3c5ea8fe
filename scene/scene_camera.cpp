// The scene's `camera:` section (read with the rest of the scene; used by the renderer).
#include "scene/scene_file.h"
#include "scene/yaml_strict.h"

namespace gs::app {

void ReadCameraSection(const YAML::Node& node, const std::string& file, Scene* s, std::vector<SceneError>* errors) {
  MapReader m(node, file, "camera", errors);
  if (!m.ok()) return;
  s->has_camera = true;
  SceneCamera& c = s->camera;
  c.has_position = m.Vector3("position_m", &c.position, -1e3, 1e3, false);
  c.has_target = m.Vector3("target_m", &c.target, -1e3, 1e3, false);
  const bool has_up = m.Vector3("up", &c.up, -1e3, 1e3, false);
  m.Number("fov_deg", &c.fov_deg, 1.0, 170.0, false);
  if (has_up && !(c.up.norm() > 1e-9)) m.Error(m.Raw("up"), "'up' must not be the zero vector");
  if (c.has_position && c.has_target && (c.position - c.target).norm() < 1e-9)
    m.Error(m.Raw("target_m"), "'target_m' must differ from 'position_m'");
  else if (c.has_position && c.has_target && c.up.norm() > 1e-9 &&
           (c.target - c.position).normalized().cross(c.up.normalized()).norm() < 1e-6)
    m.Error(m.Raw("up"), "'up' must not point along the view direction (from position_m to target_m)");
  m.Finish();
}

}  // namespace gs::app
