// A scene with a tracker section, made ready to follow DTrack input: the world,
// the parser, the mapping to fingertip targets and the target follower. Shared
// by replay (samples at their recorded times in simulated time), live (samples
// as they arrive, through the mailbox) and the tracking benchmark.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "scene/scene_file.h"
#include "session/worker_pool.h"
#include "tracking/dtrack_parser.h"
#include "tracking/synthetic_hand.h"
#include "tracking/target_follower.h"

namespace gs::app {

/// Where a `sizes: tracker` hand takes its sizes (docs/scene-format.md): the next
/// datagram of the session into *data, false when there is none (or on Ctrl-C);
/// `c` is the scene's tracker section.
using SizingFeed = std::function<bool(const tracking::TrackerConfig& c, std::string* data)>;

/// The synthetic hand's first datagram (tracking::SyntheticHandFor the scene's
/// tracker), for the commands that drive a scene with it.
SizingFeed SyntheticSizing();

/// `sizes: tracker`: sizes the scene's hand from the first datagram of `feed` that
/// can (SizeHandFromFrame), *note saying which and the sizes; false when none can,
/// *error naming the scene's line and what was wrong with the datagrams.
bool SizeTrackedHand(Scene* s, const SizingFeed& feed, std::string* note, std::string* error);

/// What the datagrams given to TrackedSim::Ingest carried for the scene: the
/// judgement live makes of every datagram it receives (tracking::JudgeFrame).
struct DatagramTally {
  uint64_t datagrams = 0;
  uint64_t good = 0;        ///< every target the scene needs, tracked
  uint64_t not_dtrack = 0;  ///< no DTrack line at all
  uint64_t missing = 0;     ///< DTrack without something the scene needs
  uint64_t other_side = 0;  ///< of those, with the scene's hand of the other side (tracking::CarriesOtherSide)
  int missing_code = -1;    ///< what the last of them lacked first (tracking::MissingLabel)
};

/// "good datagrams (carrying hand 0 (right), tracked): 570 of 581; 0 not DTrack, 11 without
/// finger 2 of hand 0": the tally in words, as replay and live print it (`needs`: what a
/// good datagram carries; `lacked`: what the missing ones lacked).
std::string TallyText(const DatagramTally& t, const std::string& needs, const std::string& lacked);

/// "" when some datagram drove the scene (or none came); else why none could: what they
/// lacked, and for a hand of the other side, the scene's `side` to change.
std::string NothingDrivenText(const DatagramTally& t, const tracking::TrackerConfig& c);

class TrackedSim {
 public:
  /// Loads and builds the scene; it must have a tracker section. A hand with
  /// `sizes: tracker` is sized from `sizing` first (refused without one); `adjust`,
  /// when given, changes the scene before it is built.
  bool Load(const std::string& path, std::string* error, const SizingFeed& sizing = nullptr,
            const std::function<void(Scene*)>& adjust = nullptr);

  /// How a `sizes: tracker` hand was sized (SizeTrackedHand), or "".
  const std::string& sizing_note() const { return sizing_note_; }

  World& world() { return scene_->world; }
  const World& world() const { return scene_->world; }
  const BuiltScene& scene() const { return *scene_; }
  const tracking::TrackerConfig& config() const { return scene_->tracker; }
  tracking::TargetFollower& follower() { return follower_; }
  const tracking::TargetFollower& follower() const { return follower_; }
  const tracking::DTrackParser& parser() const { return parser_; }

  /// Parses one datagram, maps it to fingertip targets and tallies what it carried.
  void Ingest(const char* data, size_t size, bool truncated, tracking::TargetSample* out);
  const DatagramTally& tally() const { return tally_; }

  /// Pushes a sample (applied from the current simulated time).
  void Push(const tracking::TargetSample& s) { follower_.Push(s, world().time); }

  /// Couplings toward the targets at the end of the step, then one step.
  void Step();

  /// The fingertips' states for a HUD, like "3/3 tracking" or "2/3 tracking;
  /// middle lost" (no allocation: writes into buf).
  void HudText(char* buf, size_t size) const;

  /// The scene's tracked body (BuiltScene::tracked_body) as an object for the
  /// synthetic hand to grasp: its shape (a mesh: the box bounding its points) and its
  /// points' bounding box in the room, where it will rest when it starts up to 5 mm
  /// above a level plane; false when the scene has none.
  bool GraspObject(tracking::GraspObject* out) const;

  /// Steps on `threads` threads from now on, the caller's included (1: on the
  /// caller's alone): a WorkerPool (session/worker_pool.h) started by the calling
  /// thread, with its scheduling. The results are the same either way.
  void UseThreads(int threads);

 private:
  std::unique_ptr<WorkerPool> pool_;  // before scene_: the world goes first
  std::unique_ptr<BuiltScene> scene_;
  std::string sizing_note_;
  tracking::DTrackParser parser_;
  tracking::DTrackFrame frame_;
  DatagramTally tally_;
  tracking::TargetFollower follower_;
};

/// Loads a tracked scene to be driven by the synthetic hand, into *sim and *hand: the
/// hand its tracker follows (tracking::SyntheticHandFor), aimed at the scene's tracked
/// body. A whole hand whose first pose is not the scene's start pose (a scene written
/// for another grasp: more than 5 mm or 5 degrees off, or other start flexions) starts
/// at that first pose instead, as if the scene had given it, so that the hand does not
/// sweep through the room to it; *moved then says so ("" otherwise).
bool LoadForSyntheticHand(const std::string& path, TrackedSim* sim, tracking::SyntheticHand* hand, std::string* moved,
                          std::string* error);

/// A tracked scene driven in simulated time by the synthetic hand its tracker
/// follows (tracking::SyntheticHandFor: a whole hand's power grasp, with its side,
/// aimed at the scene's tracked body),
/// the hand's datagrams at 100 Hz, a `sizes: tracker` hand sized by its first
/// (`bench step --scene`, `validate whole-hand`).
class SyntheticDrive {
 public:
  bool Load(const std::string& path, std::string* error);
  TrackedSim& sim() { return sim_; }
  World& world() { return sim_.world(); }
  /// the hand (set `pinch`, `hold_s` and `duration_s` before the first step)
  tracking::SyntheticHand& hand() { return hand_; }
  /// LoadForSyntheticHand's note when the hand starts elsewhere than the scene says, or ""
  const std::string& moved() const { return moved_; }
  /// the next datagram when its time has come, then one step
  void Step();
  /// steps until the world's time reaches t
  void RunTo(double t);

 private:
  TrackedSim sim_;
  tracking::SyntheticHand hand_;
  std::string moved_;
  double next_sample_ = 0.0;
  uint32_t frame_ = 1;
};

}  // namespace gs::app
