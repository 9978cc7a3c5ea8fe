// Scene files (YAML, SI units): parsing with validation, and building the World
// and its script from them. The format is documented in docs/scene-format.md.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/hand.h"
#include "scene/script.h"
#include "scene/yaml_strict.h"
#include "core/world.h"
#include "tracking/tracker_config.h"

namespace gs::tracking {
struct DTrackFrame;
}

namespace gs::app {

struct SceneBody {
  BodySpec spec;           ///< everything but the mesh, which is imported at build time
  std::string mesh_file;   ///< resolved path when the shape is a mesh
  double mesh_scale = 1.0;
  bool has_drive = false;
  SceneError bandwidth_at;  ///< where kernel_bandwidth_m was given (checked against the spacing at build)
  SceneError at;            ///< the body's (or fingertip's) mapping
  SceneError position_at;   ///< its position_m (the mapping when not given; a fingertip's: its finger's joints)
  SceneError shape_at;      ///< its shape (a mesh's: the file key)
};

struct SceneFinger {
  std::string name;
  FingerModel model;
  Vec4 joints = Vec4::Zero();
  double motor_stiffness = 1.0, motor_damping = 0.0, joint_damping = 0.0;
  SceneBody tip;
};

struct SceneKeyframe {
  double time = 0.0;
  bool has_hand = false;
  Vec3 hand_position = Vec3::Zero();
  std::map<std::string, Vec4> joints;           ///< per finger
  std::map<std::string, Vec3> tip_targets;      ///< per finger, hand frame (inverse kinematics)
  std::map<std::string, Pose> body_targets;     ///< per body
  std::map<std::string, SceneError> tip_target_at;  ///< where each fingertip target was given
};

/// The scene's optional `camera:` section (docs/render.md); what is not given comes
/// from the default framing of the hand and the objects.
struct SceneCamera {
  bool has_position = false, has_target = false;
  Vec3 position = Vec3::Zero(), target = Vec3::Zero();  ///< m, world
  Vec3 up = Vec3::UnitZ();
  double fov_deg = 35.0;  ///< vertical
};

/// One segment of a tracked hand (`hand: {model: tracked}`, scene/scene_hand.cpp).
struct SceneHandSegment {
  std::string body;
  int finger = -1;  ///< gl finger (0 thumb .. 4 little); -1: the palm
  tracking::ESegment segment = tracking::ESegment::Palm;
  Pose offset;      ///< body pose in the tracked frame (the palm's in the back of the hand's)
};

/// A whole hand that follows ART Fingertracking: its segment bodies are in Scene::bodies.
struct SceneTrackedHand {
  bool enabled = false;
  bool right = true;
  bool self_contact = false;  ///< segments of different fingers, and fingers and palm, may touch
  std::vector<SceneHandSegment> segments;
  SceneError at;              ///< the hand section
  /// `sizes: tracker`: the phalanges take their sizes from the tracker's first usable
  /// datagram (SizeHandFromFrame) before the scene is built; until then the default sizes
  bool sizes_from_tracker = false;
  bool sized = false;         ///< the tracker's sizes were applied
  bool palm_size_given = false;  ///< the scene gave the palm's size_m (the tracker does not resize it)
  SceneError sizes_at;        ///< where `sizes: tracker` was given
  HandModel model;            ///< the sizes the segments have now
  Pose start;                 ///< the hand's start pose (position_m, rotation_deg)
  Vec3 start_flexion = Vec3::Zero();
};

struct Scene {
  std::string file, name, description;
  SceneError timestep_at;  ///< where timestep_s was given
  WorldParams params;
  double duration = 1.0;
  std::vector<SceneBody> bodies;
  Pose hand_pose;
  std::vector<SceneFinger> fingers;
  SceneTrackedHand tracked_hand;
  struct Pair {
    std::string a, b;
    double mu;
  };
  std::vector<Pair> friction_pairs;
  std::vector<SceneKeyframe> script;
  bool has_tracker = false;          ///< a `tracker:` section (docs/tracking.md)
  tracking::TrackerConfig tracker;
  bool has_camera = false;           ///< a `camera:` section (docs/render.md)
  SceneCamera camera;
};

/// Parses and validates a scene; false with every error found.
bool LoadScene(const std::string& path, Scene* out, std::vector<SceneError>* errors);
bool LoadSceneFromString(const std::string& text, const std::string& virtual_path, Scene* out,
                         std::vector<SceneError>* errors);

/// A scene made ready to step.
struct BuiltScene {
  std::string name;
  double duration = 1.0;
  World world;
  ScriptPlayer script;
  int tracked_body = -1;  ///< the first free body that is not a fingertip (reported in summaries)
  bool has_tracker = false;
  tracking::TrackerConfig tracker;  ///< with the fingertips' body indices resolved
  bool has_camera = false;
  SceneCamera camera;
  /// a `sizes: tracker` hand built before the tracker sized it: a note that its
  /// sizes are the default ones (FILE:LINE:COL: note: ...), for the command to print
  std::string sizes_note;
};

/// The `camera:` section (session/frame_recorder.cpp).
void ReadCameraSection(const YAML::Node& node, const std::string& file, Scene* s, std::vector<SceneError>* errors);

/// A body's `deformation:` key (scene_file.cpp): leaves *d as it is when absent.
void ReadDeformation(MapReader& parent, DeformationParams* d);

/// `hand: {model: tracked, ...}` (scene/scene_hand.cpp): appends the segment bodies.
void ReadTrackedHand(const YAML::Node& node, const std::string& file, Scene* s, std::vector<SceneError>* errors);
/// The tracker targets of the tracked hand's segments (after the tracker section).
void AddTrackedHandTargets(Scene* s, std::vector<SceneError>* errors);
/// `sizes: tracker`: sizes the phalanx capsules of the scene's tracked hand (length:
/// the phalanx's, radius: the finger's fingertip radius, tracker units times units_m)
/// from one parsed datagram, at the start pose. The datagram must carry the
/// configured hand (id and side), tracked, with every finger the scene has, each
/// passing the tracker's checks (MapFrame/JudgeFrame) and the scene's capsule limits
/// (lengths 5 mm to 12 cm, radius 2 mm to 3 cm); else false with why not.
bool SizeHandFromFrame(const tracking::DTrackFrame& frame, Scene* s, std::string* why);
/// Puts the scene's tracked hand at another start pose and start flexions (the
/// segment bodies with it), before the scene is built.
void PlaceTrackedHand(Scene* s, const Pose& start, const Vec3& flexion);
/// The tracked hand's fingers (core Finger, one per finger, carrying its phalanx
/// bodies) and the palm carrying the hand, once the bodies are in the world.
void AddTrackedFingers(const Scene& scene, World& w);
/// The pairs of hand segments that may not touch (World::SetCanTouch), once the world is built.
void ExcludeHandPairs(const Scene& scene, World& w);

/// The `tracker:` section (scene/scene_tracker.cpp); reads after the bodies.
void ReadTrackerSection(const YAML::Node& node, const std::string& file, Scene* s, std::vector<SceneError>* errors);
/// Resolves the tracked fingertips' body indices in a built world.
bool ResolveTracker(World& w, tracking::TrackerConfig* c, std::string* error);

/// Imports meshes, samples every surface, builds trees, fingers and the script, and
/// checks what the file alone cannot show (scene/scene_checks.h, docs/scene-format.md
/// "Checks when the scene is built"): false with every error found, each at the
/// file, line and column it comes from. Every command that loads a scene calls it.
bool BuildScene(const Scene& scene, BuiltScene* out, std::vector<SceneError>* errors);
/// The same, errors formatted one per line.
bool BuildScene(const Scene& scene, BuiltScene* out, std::string* error);
/// LoadScene + BuildScene, errors formatted one per line.
bool LoadAndBuildScene(const std::string& path, BuiltScene* out, std::string* error);

}  // namespace gs::app
