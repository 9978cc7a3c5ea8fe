#include "session/tracked_sim.h"

#include <cstdio>
#include <limits>

#include "tracking/hand_mapping.h"
#include "tracking/synthetic_hand.h"

namespace gs::app {

namespace {

std::string Joined(const std::vector<SceneError>& errors) {
  std::string all;
  for (const SceneError& e : errors) all += (all.empty() ? "" : "\n") + e.Format();
  return all;
}

// "thumb 31.7, 33.9, 45 mm, radius 9.5 mm; index ..."
std::string SizesText(const HandModel& m) {
  static const char* const kNames[kHandMaxFingers] = {"thumb", "index", "middle", "ring", "little"};
  std::string out;
  char buf[128];
  for (int f = 0; f < m.fingers; ++f) {
    const HandFingerModel& g = m.finger[f];
    std::snprintf(buf, sizeof buf, "%s%s %.1f, %.1f, %.1f mm, radius %.1f mm", f ? "; " : "", kNames[f],
                  1e3 * g.length[0], 1e3 * g.length[1], 1e3 * g.length[2], 1e3 * g.radius);
    out += buf;
  }
  return out;
}

}  // namespace

SizingFeed SyntheticSizing() {
  return [given = false](const tracking::TrackerConfig& c, std::string* data) mutable {
    if (given) return false;
    given = true;
    *data = tracking::SyntheticHandFor(c).Datagram(0.0, 0);
    return true;
  };
}

bool SizeTrackedHand(Scene* s, const SizingFeed& feed, std::string* note, std::string* error) {
  tracking::DTrackParser parser;
  tracking::DTrackFrame frame;
  std::string data, why, first, last;
  int64_t n = 0;
  while (feed(s->tracker, &data)) {
    ++n;
    parser.Parse(data.data(), data.size(), &frame);
    if (SizeHandFromFrame(frame, s, &why)) {
      *note = "the hand sized from datagram " + std::to_string(n) + " (sizes: tracker" +
              (n > 1 ? "; the " + std::to_string(n - 1) + " before it could not: " + first : "") +
              "): " + SizesText(s->tracked_hand.model);
      return true;
    }
    if (first.empty()) first = why;
    last = why;
  }
  SceneError e = s->tracked_hand.sizes_at;
  if (n == 0)
    e.message = "'sizes: tracker': no datagram to size the hand from";
  else
    e.message = "'sizes: tracker': none of the " + std::to_string(n) + " datagrams can size the hand: the first: " +
                first + (last != first ? "; the last: " + last : "");
  *error = e.Format();
  return false;
}

bool TrackedSim::Load(const std::string& path, std::string* error, const SizingFeed& sizing,
                      const std::function<void(Scene*)>& adjust) {
  Scene scene;
  std::vector<SceneError> errors;
  if (!LoadScene(path, &scene, &errors)) {
    *error = Joined(errors);
    return false;
  }
  const std::string no_tracker =
      path + ": the scene has no 'tracker:' section (see docs/tracking.md and config/tracked_hand.yaml)";
  sizing_note_.clear();
  if (scene.tracked_hand.sizes_from_tracker) {
    if (!scene.has_tracker) {
      *error = no_tracker;
      return false;
    }
    if (!sizing) {
      SceneError e = scene.tracked_hand.sizes_at;
      e.message = "'sizes: tracker' needs the tracker's datagrams before the scene is built, which this command "
                  "does not read; give the sizes per finger ('sizes: {thumb: {lengths_m: [...], radius_m: ...}, "
                  "...}', docs/scene-format.md)";
      *error = e.Format();
      return false;
    }
    if (!SizeTrackedHand(&scene, sizing, &sizing_note_, error)) return false;
  }
  if (adjust) adjust(&scene);
  // the scene's own checks come first, as every command that builds it gives them
  scene_ = std::make_unique<BuiltScene>();
  if (!BuildScene(scene, scene_.get(), error)) return false;
  if (!scene_->has_tracker) {
    *error = no_tracker;
    return false;
  }
  follower_.Init(scene_->tracker, scene_->world);
  return true;
}

void TrackedSim::Ingest(const char* data, size_t size, bool truncated, tracking::TargetSample* out) {
  int errors = 0;
  if (truncated) {
    parser_.CountOversized(size);
    frame_.Clear();
    errors = 1;
  } else {
    errors = parser_.Parse(data, size, &frame_);
  }
  MapFrame(frame_, scene_->tracker, out);
  out->parse_errors = errors;
  ++tally_.datagrams;
  int code = -1;
  switch (tracking::JudgeFrame(frame_, errors, scene_->tracker, *out, &code)) {
    case tracking::ECarries::Good: ++tally_.good; break;
    case tracking::ECarries::NotDTrack: ++tally_.not_dtrack; break;
    case tracking::ECarries::Missing:
      ++tally_.missing;
      tally_.missing_code = code;
      if (tracking::CarriesOtherSide(frame_, scene_->tracker)) ++tally_.other_side;
      break;
  }
}

std::string TallyText(const DatagramTally& t, const std::string& needs, const std::string& lacked) {
  char buf[512];
  std::snprintf(buf, sizeof buf, "good datagrams (carrying %s, tracked): %llu of %llu; %llu not DTrack, %llu without %s",
                needs.c_str(), static_cast<unsigned long long>(t.good), static_cast<unsigned long long>(t.datagrams),
                static_cast<unsigned long long>(t.not_dtrack), static_cast<unsigned long long>(t.missing),
                lacked.c_str());
  std::string s = buf;
  if (t.other_side)
    s += " (" + std::to_string(t.other_side) + " with the hand of the other side)";
  return s;
}

std::string NothingDrivenText(const DatagramTally& t, const tracking::TrackerConfig& c) {
  if (t.good > 0 || t.datagrams == 0) return "";
  std::string s = "none of the " + std::to_string(t.datagrams) + " datagrams carries " +
                  tracking::MissingLabel(c, -1) + " with every target tracked, so the scene was never driven";
  if (t.other_side > 0) {
    const bool right = c.hand_side == 1;
    s += "; " + std::to_string(t.other_side) + " carry hand " + std::to_string(c.hand_id) + " as a " +
         (right ? "left" : "right") + " hand, where the scene's hand has `side: " + (right ? "right" : "left") +
         "` (set `side: " + (right ? "left" : "right") + "` to drive it with this input)";
  } else if (t.missing > 0) {
    s += "; they lack " + tracking::MissingLabel(c, t.missing_code);
  } else {
    s += "; none is DTrack";
  }
  return s;
}

void TrackedSim::UseThreads(int threads) {
  world().UseRunner(nullptr);
  pool_.reset();
  if (threads < 2) return;
  pool_ = std::make_unique<WorkerPool>(threads);
  world().UseRunner(pool_.get());
}

void TrackedSim::HudText(char* buf, size_t size) const {
  if (size == 0) return;
  const int n = follower_.size();
  int tracking = 0;
  for (int i = 0; i < n; ++i) tracking += follower_.state(i) == tracking::ETipState::Tracking;
  int len = std::snprintf(buf, size, "%d/%d tracking", tracking, n);
  const auto& tips = scene_->tracker.fingertips;
  bool first = true;
  for (int i = 0; i < n && len >= 0 && static_cast<size_t>(len) < size; ++i) {
    if (follower_.state(i) == tracking::ETipState::Tracking) continue;
    len += std::snprintf(buf + len, size - static_cast<size_t>(len), "%s %s %s", first ? ";" : ",",
                         i < static_cast<int>(tips.size()) ? tips[i].name.c_str() : "?",
                         tracking::TipStateName(follower_.state(i)));
    first = false;
  }
}

bool TrackedSim::GraspObject(tracking::GraspObject* out) const {
  const int i = scene_->tracked_body;
  if (i < 0) return false;
  const Body& b = world().bodies[static_cast<size_t>(i)];
  const std::vector<Vec3>& points = b.geometry.cloud.positions;
  if (points.empty()) return false;
  Vec3 low = Vec3::Constant(std::numeric_limits<double>::infinity()), high = -low;
  Vec3 body_low = low, body_high = high;
  for (const Vec3& p : points) {
    const Vec3 room = b.pose.Apply(p);
    low = low.cwiseMin(room);
    high = high.cwiseMax(room);
    body_low = body_low.cwiseMin(p);
    body_high = body_high.cwiseMax(p);
  }
  out->shape = b.geometry.shape;
  out->pose = b.pose;
  if (out->shape.type == EShape::Mesh) {
    out->shape.type = EShape::Box;
    out->shape.half_extents = 0.5 * (body_high - body_low);
    out->pose.t = b.pose.Apply(0.5 * (body_low + body_high));
  }
  // an object placed just above a level table (within 5 mm) will rest on it when
  // the hand arrives: grasped there
  for (const Body& t : world().bodies) {
    if (!t.geometry.is_plane || t.motion == EMotion::Free || t.pose.R.col(2).z() < 0.999) continue;
    const double drop = low.z() - t.pose.t.z();
    if (drop <= 0.0 || drop > 5e-3) continue;
    low.z() -= drop;
    high.z() -= drop;
    out->pose.t.z() -= drop;
    break;
  }
  out->low = low;
  out->high = high;
  return true;
}

void TrackedSim::Step() {
  World& w = world();
  if (!scene_->script.empty()) scene_->script.Apply(w, w.time + w.params.dt);
  follower_.Apply(w, w.time + w.params.dt);
  w.Step();
}

namespace {

// the scene's start pose is the synthetic hand's first one (within 5 mm and 5 degrees,
// the start flexions within 0.01 rad of the open hand's)
bool StartsWhereTheHandDoes(const World& w, const Pose& first) {
  const double angle = Eigen::AngleAxisd(w.hand.pose.R.transpose() * first.R).angle();
  if ((w.hand.pose.t - first.t).norm() > 5e-3 || angle > 5.0 * M_PI / 180.0) return false;
  for (const Finger& f : w.hand.fingers)
    for (int j = 0; j < 3; ++j)
      if (std::abs(f.q[j + 1] - tracking::SyntheticOpenFlexion()[j]) > 0.01) return false;
  return true;
}

}  // namespace

bool LoadForSyntheticHand(const std::string& path, TrackedSim* sim, tracking::SyntheticHand* hand, std::string* moved,
                          std::string* error) {
  moved->clear();
  if (!sim->Load(path, error, SyntheticSizing())) return false;
  tracking::GraspObject object;
  *hand = sim->GraspObject(&object) ? tracking::SyntheticHandFor(sim->config(), object)
                                    : tracking::SyntheticHandFor(sim->config());
  const World& w = sim->world();
  if (!hand->whole_hand || w.hand.fingers.empty()) return true;
  Pose first;
  TrackedFinger fingers[kHandMaxFingers];
  hand->WholeHandPose(0.0, &first, fingers);
  if (StartsWhereTheHandDoes(w, first)) return true;
  const auto start_there = [&](Scene* s) {
    PlaceTrackedHand(s, first, tracking::SyntheticOpenFlexion());
  };
  if (!sim->Load(path, error, SyntheticSizing(), start_there)) return false;
  const Vec3 deg = (180.0 / M_PI) * first.R.eulerAngles(2, 1, 0);
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "the synthetic hand starts at position_m [%.4f, %.4f, %.4f], rotation_deg [%.1f, %.1f, %.1f], "
                "start_flexion_rad [0, 0.35, 0.15], not at the scene's hand pose",
                first.t.x(), first.t.y(), first.t.z(), deg.z(), deg.y(), deg.x());
  *moved = buf;
  return true;
}

bool SyntheticDrive::Load(const std::string& path, std::string* error) {
  return LoadForSyntheticHand(path, &sim_, &hand_, &moved_, error);
}

void SyntheticDrive::Step() {
  World& w = sim_.world();
  if (w.time >= next_sample_ - 0.5 * w.params.dt) {
    const std::string d = hand_.Datagram(next_sample_, frame_++);
    tracking::TargetSample sample;
    sim_.Ingest(d.data(), d.size(), false, &sample);
    sim_.Push(sample);
    next_sample_ += 0.01;
  }
  sim_.Step();
}

void SyntheticDrive::RunTo(double t) {
  World& w = sim_.world();
  while (w.time < t - 0.5 * w.params.dt) Step();
}

}  // namespace gs::app
