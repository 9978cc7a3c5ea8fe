// The whole tracked hand: the scene's `hand: {model: tracked}` (segment bodies,
// contact exclusions, targets), the mapping of gl blocks to segment targets, bad
// gl input, and the power grasp of config/whole_hand_power_grasp.yaml driven by
// the synthetic whole hand.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <thread>

#include "core/hand.h"
#include "core/virtual_coupling.h"
#include "scene/scene_file.h"
#include "session/tracked_sim.h"
#include "tracking/dtrack_parser.h"
#include "tracking/hand_mapping.h"
#include "tracking/session_log.h"
#include "tracking/synthetic_hand.h"
#include "test_util.h"

namespace gs::tracking {
namespace {

const std::string kScene = std::string(GRASPSIM_SOURCE_DIR) + "/config/whole_hand_power_grasp.yaml";

std::string SceneText() {
  std::ifstream f(kScene);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

int BodyIndex(const World& w, const std::string& name) {
  for (size_t i = 0; i < w.bodies.size(); ++i)
    if (w.bodies[i].name == name) return static_cast<int>(i);
  ADD_FAILURE() << "no body " << name;
  return 0;
}

bool Build(const std::string& text, app::BuiltScene* b, std::string* error) {
  app::Scene scene;
  std::vector<app::SceneError> errors;
  if (!app::LoadSceneFromString(text, kScene, &scene, &errors)) {
    for (const auto& e : errors) *error += e.Format() + "\n";
    return false;
  }
  return app::BuildScene(scene, b, error);
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

TEST(WholeHand, SceneMakesOneBodyPerSegmentAndKeepsTheHandsSegmentsApart) {
  app::BuiltScene b;
  std::string error;
  ASSERT_TRUE(Build(SceneText(), &b, &error)) << error;
  const World& w = b.world;
  ASSERT_EQ(w.bodies.size(), 2u + 1u + 15u);  // table, box, palm, 5 x 3 phalanges
  EXPECT_EQ(b.world.bodies[b.tracked_body].name, "box");
  // the phalanges are capsules of the average hand's lengths and radii
  const HandModel m = AverageAdultHand(5, true);
  const Body& middle_inner = w.bodies[BodyIndex(w, "middle_inner")];
  EXPECT_EQ(middle_inner.geometry.shape.type, EShape::Capsule);
  EXPECT_DOUBLE_EQ(middle_inner.geometry.shape.half_length, 0.5 * m.finger[2].length[2]);
  EXPECT_DOUBLE_EQ(middle_inner.geometry.shape.radius, m.finger[2].radius);
  // one target per segment, on the gl finger of its name
  ASSERT_EQ(b.tracker.fingertips.size(), 16u);
  for (const FingertipMap& f : b.tracker.fingertips) {
    EXPECT_EQ(f.body_index, BodyIndex(w, f.body));
    if (f.body.rfind("ring_", 0) == 0) {
      EXPECT_EQ(f.finger, 3);
    }
  }
  EXPECT_EQ(b.tracker.hand_side, 1);
  const int io = BodyIndex(w, "index_outer"), im = BodyIndex(w, "index_middle"), mo = BodyIndex(w, "middle_outer");
  const int ii = BodyIndex(w, "index_inner"), palm = BodyIndex(w, "palm"), box = BodyIndex(w, "box");
  EXPECT_FALSE(w.CanTouch(io, im));
  EXPECT_FALSE(w.CanTouch(io, mo));  // no self contact
  EXPECT_FALSE(w.CanTouch(palm, mo));
  EXPECT_TRUE(w.CanTouch(io, box));
  EXPECT_TRUE(w.CanTouch(palm, box));

  app::BuiltScene self;
  const std::string self_text = Replace(SceneText(), "self_contact: false", "self_contact: true");
  ASSERT_TRUE(Build(self_text, &self, &error)) << error;
  const World& sw = self.world;
  EXPECT_FALSE(sw.CanTouch(io, im));    // one finger's segments never
  EXPECT_FALSE(sw.CanTouch(ii, palm));  // nor an inner phalanx and the palm, at the knuckle
  EXPECT_TRUE(sw.CanTouch(io, mo));
  EXPECT_TRUE(sw.CanTouch(palm, mo));
  // the thumb is rooted inside the palm box: none of its phalanges touches it
  for (const char* thumb : {"thumb_outer", "thumb_middle", "thumb_inner"})
    EXPECT_FALSE(sw.CanTouch(palm, BodyIndex(sw, thumb))) << thumb;
  EXPECT_TRUE(sw.CanTouch(BodyIndex(sw, "thumb_outer"), io));
  // fingers too thick for their knuckles' spacing (18 mm) start deep in each other:
  // refused, naming what places a hand's segments
  error.clear();
  app::BuiltScene thick;
  EXPECT_FALSE(Build(Replace(self_text, "  self_contact: true\n",
                             "  self_contact: true\n  sizes: {index: {lengths_m: [0.022, 0.027, 0.043], radius_m: 0.016}, "
                             "middle: {lengths_m: [0.024, 0.030, 0.047], radius_m: 0.016}}\n"),
                     &thick, &error));
  EXPECT_NE(error.find("bodies 'index_inner' and 'middle_inner' start overlapping"), std::string::npos) << error;
  EXPECT_NE(error.find("start_flexion_rad"), std::string::npos) << error;  // what to change in a hand
}

// the hand's skin as the scene says: its default deforms (Gaussian, 300 N/m), and
// `model: rigid` makes every segment rigid instead of being left at that default
TEST(WholeHand, TheHandsDeformationModelIsTheScenes) {
  const std::string skin = "  deformation:\n    model: gaussian\n    stiffness_N_m: 300\n    damping_N_s_m: 1\n"
                           "    influence_radius_m: 0.003\n";
  ASSERT_NE(SceneText().find(skin), std::string::npos);
  const std::pair<const char*, EDeformation> cases[] = {
      {"  deformation: {model: rigid}\n", EDeformation::Rigid},
      {"  deformation: {model: boussinesq, young_modulus_Pa: 2.0e5, poisson_ratio: 0.45}\n", EDeformation::Boussinesq},
      {"", EDeformation::Gaussian}};
  for (const auto& [text, model] : cases) {
    app::BuiltScene built;
    std::string error;
    ASSERT_TRUE(Build(Replace(SceneText(), skin, text), &built, &error)) << error;
    for (const char* name : {"palm", "thumb_outer", "index_inner", "little_middle"}) {
      const Body& b = built.world.bodies[BodyIndex(built.world, name)];
      EXPECT_EQ(b.deform.enabled(), model != EDeformation::Rigid) << text << name;
      EXPECT_EQ(b.deform.params().model, model) << text << name;
    }
  }
}

TEST(WholeHand, LeftHandIsTheRightOneMirrored) {
  app::BuiltScene right, left;
  std::string error;
  ASSERT_TRUE(Build(SceneText(), &right, &error)) << error;
  ASSERT_TRUE(Build(Replace(SceneText(), "side: right", "side: left"), &left, &error)) << error;
  EXPECT_EQ(left.tracker.hand_side, 0);
  // the hand frame is palm down at y = 0 in both: every segment mirrored in y
  for (const char* name : {"palm", "thumb_inner", "thumb_outer", "index_middle", "little_outer"}) {
    const Vec3 r = right.world.bodies[BodyIndex(right.world, name)].pose.t;
    const Vec3 l = left.world.bodies[BodyIndex(left.world, name)].pose.t;
    EXPECT_NEAR(l.x(), r.x(), 1e-12) << name;
    EXPECT_NEAR(l.y(), -r.y(), 1e-12) << name;
    EXPECT_NEAR(l.z(), r.z(), 1e-12) << name;
  }
  EXPECT_GT(std::abs(right.world.bodies[BodyIndex(right.world, "thumb_inner")].pose.t.y()), 0.02);
}

TEST(WholeHand, ThreeFingerHandHasThumbIndexAndMiddle) {
  app::BuiltScene b;
  std::string error;
  ASSERT_TRUE(Build(Replace(SceneText(), "fingers: 5 ", "fingers: 3 "), &b, &error)) << error;
  EXPECT_EQ(b.world.bodies.size(), 2u + 1u + 9u);
  for (const Body& body : b.world.bodies) EXPECT_EQ(body.name.find("ring"), std::string::npos);
  BodyIndex(b.world, "middle_outer");
}

TEST(WholeHand, BadHandSectionsAreRefusedWithTheirLine) {
  app::Scene scene;
  std::vector<app::SceneError> errors;
  EXPECT_FALSE(app::LoadSceneFromString(Replace(SceneText(), "fingers: 5 ", "fingers: 4 "), kScene, &scene, &errors));
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].message.find("'fingers' must be 5"), std::string::npos) << errors[0].Format();
  EXPECT_GT(errors[0].line, 0);
  errors.clear();
  app::Scene no_tracker;
  const std::string text = SceneText();
  EXPECT_FALSE(app::LoadSceneFromString(text.substr(0, text.find("tracker:")), kScene, &no_tracker, &errors));
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].message.find("needs a 'tracker:' section"), std::string::npos) << errors[0].Format();
  errors.clear();
  app::Scene bad_key;
  EXPECT_FALSE(app::LoadSceneFromString(Replace(text, "self_contact: false", "self_contacts: false"), kScene,
                                        &bad_key, &errors));
  ASSERT_FALSE(errors.empty());
  EXPECT_GT(errors[0].line, 0);
  // `sizes` is 'tracker' or a map of fingers: anything else at its value's line and column
  errors.clear();
  app::Scene bogus;
  const std::string with_bogus = Replace(text, "  self_contact: false\n", "  self_contact: false\n  sizes: bogus\n");
  EXPECT_FALSE(app::LoadSceneFromString(with_bogus, kScene, &bogus, &errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].line, 1 + std::count(with_bogus.begin(), with_bogus.begin() + with_bogus.find("sizes: bogus"), '\n'));
  EXPECT_EQ(errors[0].column, 10);
  EXPECT_NE(errors[0].message.find("'sizes' must be 'tracker'"), std::string::npos) << errors[0].Format();
}

// ---- `sizes: tracker`: the phalanges sized from the tracker's first usable datagram

std::string TrackerSizedText() {
  return Replace(SceneText(), "  self_contact: false\n", "  self_contact: false\n  sizes: tracker\n");
}

// the synthetic whole hand's datagram at t with its phalanx lengths and radii times `scale`
std::string SizedDatagram(double scale, int fingers = 5) {
  SyntheticHand h = SyntheticHand::WholeHand(fingers, 3.0);
  h.size_scale = scale;
  return h.Datagram(0.0, 1);
}

std::string LeftHanded(std::string d) { return Replace(d, "gl 1 [0 1.000 1 5]", "gl 1 [0 1.000 0 5]"); }

app::SizingFeed Feed(std::vector<std::string> datagrams) {
  return [datagrams, i = size_t(0)](const TrackerConfig&, std::string* out) mutable {
    if (i >= datagrams.size()) return false;
    *out = datagrams[i++];
    return true;
  };
}

bool LoadSized(app::TrackedSim* sim, const std::string& text, const app::SizingFeed& feed, std::string* error) {
  const std::string path =
      std::filesystem::temp_directory_path() / ("graspsim_sized_hand_" + std::to_string(getpid()) + ".yaml");
  std::ofstream(path) << text;
  const bool ok = sim->Load(path, error, feed);
  std::filesystem::remove(path);
  return ok;
}

// every phalanx capsule has the model's length and radius (to the datagram's 0.001 mm)
void ExpectPhalanges(const World& w, const HandModel& m, const char* label) {
  const char* names[5] = {"thumb", "index", "middle", "ring", "little"};
  const char* phalanges[3] = {"outer", "middle", "inner"};
  for (int f = 0; f < 5; ++f)
    for (int k = 0; k < 3; ++k) {
      const Body& b = w.bodies[BodyIndex(w, std::string(names[f]) + "_" + phalanges[k])];
      EXPECT_NEAR(b.geometry.shape.half_length, 0.5 * m.finger[f].length[k], 1e-6) << label << names[f] << k;
      EXPECT_NEAR(b.geometry.shape.radius, m.finger[f].radius, 1e-6) << label << names[f];
    }
}

HandModel Scaled(double scale) {
  HandModel m = AverageAdultHand(5, true);
  for (HandFingerModel& f : m.finger) {
    for (double& l : f.length) l *= scale;
    f.radius *= scale;
  }
  return m;
}

int ValidCount(const TargetSample& s);

TEST(WholeHand, TrackerSizesShapeThePhalangesFromTheSentLengthsAndRadii) {
  app::TrackedSim sized, mapped;
  std::string error;
  ASSERT_TRUE(LoadSized(&sized, TrackerSizedText(), Feed({SizedDatagram(1.2)}), &error)) << error;
  ExpectPhalanges(sized.world(), Scaled(1.2), "tracker ");
  EXPECT_NE(sized.sizing_note().find("datagram 1 "), std::string::npos) << sized.sizing_note();
  // the same datagrams leave a scene without `sizes: tracker` at its default sizes
  ASSERT_TRUE(LoadSized(&mapped, SceneText(), Feed({SizedDatagram(1.2)}), &error)) << error;
  ExpectPhalanges(mapped.world(), Scaled(1.0), "default ");
  EXPECT_TRUE(mapped.sizing_note().empty());
  // the capsules follow their tracked phalanges: a step on the sizing datagram's targets keeps them finite
  TargetSample s;
  const std::string d = SizedDatagram(1.2);
  sized.Ingest(d.data(), d.size(), false, &s);
  EXPECT_EQ(ValidCount(s), 16);
}

// the datagram with every finger block's fingertip `dx_mm` further along the hand's x
// (gl finger positions are in the back of the hand's frame): the whole tracked chain
// moves, so every knuckle lies dx_mm further along x in the hand frame
std::string ShiftFingers(const std::string& d, double dx_mm) {
  const size_t gl = d.find("gl 1 [");
  EXPECT_NE(gl, std::string::npos);
  std::string out = d;
  // brackets after the gl line's head: [id q lr n][hand position][hand rotation], then
  // three per finger: [position][rotation][radius, lengths, angles]
  size_t at = gl;
  for (int bracket = 0; bracket < 3 + 3 * 5; ++bracket) {
    at = out.find('[', at + 1);
    if (bracket < 3 || (bracket - 3) % 3 != 0) continue;
    const size_t end = out.find(' ', at);
    char x[32];
    std::snprintf(x, sizeof x, "%.3f", std::atof(out.substr(at + 1, end - at - 1).c_str()) + dx_mm);
    out = out.substr(0, at + 1) + x + out.substr(end);
  }
  return out;
}

TEST(WholeHand, TrackerSizesRootTheFingersAtTheTrackedKnuckles) {
  app::TrackedSim sized;
  std::string error;
  // the synthetic hand's knuckles are the average hand's; its fingers sent 6 mm
  // further along the hand's x put them 6 mm further forward
  ASSERT_TRUE(LoadSized(&sized, TrackerSizedText(), Feed({ShiftFingers(SizedDatagram(1.0), 6.0)}), &error)) << error;
  const HandModel avg = AverageAdultHand(5, true);
  const World& w = sized.world();
  ASSERT_EQ(w.hand.fingers.size(), 5u);
  for (int f = 0; f < 5; ++f) {
    const Vec3 expected = avg.finger[f].root.t + Vec3(0.006, 0.0, 0.0);
    EXPECT_NEAR((w.hand.fingers[f].model.base.t - expected).norm(), 0.0, 2e-6)
        << f << ": " << w.hand.fingers[f].model.base.t.transpose() << " vs " << expected.transpose();
    // the inner phalanx starts at that knuckle
    const Body& inner = w.bodies[w.hand.fingers[f].segment_body[0]];
    const Vec3 proximal = inner.pose.t - inner.geometry.shape.half_length * inner.pose.R.col(2);
    EXPECT_NEAR((proximal - (w.hand.pose * w.hand.fingers[f].model.base).t).norm(), 0.0, 1e-9) << f;
  }
  // a knuckle farther than 15 cm from the back of the hand cannot size it
  app::TrackedSim far;
  EXPECT_FALSE(LoadSized(&far, TrackerSizedText(), Feed({ShiftFingers(SizedDatagram(1.0), 200.0)}), &error));
  EXPECT_NE(error.find("knuckle lies"), std::string::npos) << error;
}

// the datagram with every finger block's fingertip y (across the hand) times `factor`
std::string SpreadFingers(const std::string& d, double factor) {
  std::string out = d;
  size_t at = out.find("gl 1 [");
  for (int bracket = 0; bracket < 3 + 3 * 5; ++bracket) {
    at = out.find('[', at + 1);
    if (bracket < 3 || (bracket - 3) % 3 != 0) continue;
    const size_t y_at = out.find(' ', at) + 1, y_end = out.find(' ', y_at);
    char y[32];
    std::snprintf(y, sizeof y, "%.3f", std::atof(out.substr(y_at, y_end - y_at).c_str()) * factor);
    out = out.substr(0, y_at) + y + out.substr(y_end);
  }
  return out;
}

TEST(WholeHand, TrackerSizesWidenThePalmWithTheKnuckles) {
  app::TrackedSim wide, given;
  std::string error;
  // the palm's size left to the hand (the shipped scene gives the default's)
  const std::string unsized = Replace(TrackerSizedText(), "palm: {size_m: [0.09, 0.085, 0.025], ", "palm: {");
  ASSERT_TRUE(LoadSized(&wide, unsized, Feed({SpreadFingers(SizedDatagram(1.0), 1.3)}), &error)) << error;
  const World& w = wide.world();
  const HandModel avg = AverageAdultHand(5, true);
  // the knuckles of the four fingers, as the tracker's chains put them, across the hand
  double lo = 1e9, hi = -1e9;
  for (int f = 1; f < 5; ++f) {
    lo = std::min(lo, w.hand.fingers[f].model.base.t.y());
    hi = std::max(hi, w.hand.fingers[f].model.base.t.y());
  }
  const double ratio = (hi - lo) / (avg.finger[4].root.t.y() - avg.finger[1].root.t.y());
  EXPECT_GT(ratio, 1.2);
  const Body& palm = w.bodies[BodyIndex(w, "palm")];
  EXPECT_NEAR(palm.geometry.shape.half_extents.y(), 0.5 * avg.palm_size.y() * ratio, 1e-12);
  EXPECT_NEAR(palm.geometry.shape.half_extents.x(), 0.5 * avg.palm_size.x(), 1e-12);
  // a palm the scene sizes keeps its size
  const std::string text = Replace(TrackerSizedText(), "palm: {size_m: [0.09, 0.085, 0.025]", "palm: {size_m: [0.09, 0.08, 0.025]");
  ASSERT_TRUE(LoadSized(&given, text, Feed({SpreadFingers(SizedDatagram(1.0), 1.3)}), &error)) << error;
  EXPECT_NEAR(given.world().bodies[BodyIndex(given.world(), "palm")].geometry.shape.half_extents.y(), 0.04, 1e-12);
}

TEST(WholeHand, TrackerSizesSkipDatagramsThatCannotSizeTheHand) {
  app::Scene base;
  std::vector<app::SceneError> errors;
  ASSERT_TRUE(app::LoadSceneFromString(TrackerSizedText(), kScene, &base, &errors));
  DTrackParser parser;
  DTrackFrame good;
  const std::string d = SizedDatagram(1.2);
  ASSERT_EQ(parser.Parse(d.data(), d.size(), &good), 0);
  struct Case {
    const char* what;
    std::function<void(Hand&)> spoil;
    const char* why;
  };
  const std::vector<Case> cases = {
      {"0 mm", [](Hand& h) { h.fingers[1].phalanx_length[1] = 0.0; }, "index (finger 1): a phalanx length is out of range"},
      {"1 m", [](Hand& h) { h.fingers[4].phalanx_length[2] = 1000.0; }, "little (finger 4): a phalanx length is out of range"},
      {"NaN", [](Hand& h) { h.fingers[2].tip_radius = std::nan(""); }, "middle (finger 2): the fingertip radius is out of range"},
      {"1 mm radius", [](Hand& h) { h.fingers[0].tip_radius = 1.0; },
       "thumb (finger 0): the fingertip radius is outside the scene's 2 to 30 mm"},
      {"3 fingers", [](Hand& h) { h.num_fingers = 3; }, "hand 0 has 3 fingers; the scene's hand has 5"},
      {"left", [](Hand& h) { h.right = false; }, "hand 0 is a left hand; the scene's is right"},
      {"untracked", [](Hand& h) { h.quality = -1.0; }, "hand 0 is not tracked"},
  };
  for (const Case& c : cases) {
    app::Scene s = base;
    DTrackFrame f = good;
    c.spoil(f.hands[0]);
    std::string why;
    EXPECT_FALSE(app::SizeHandFromFrame(f, &s, &why)) << c.what;
    EXPECT_NE(why.find(c.why), std::string::npos) << c.what << ": " << why;
    EXPECT_FALSE(s.tracked_hand.sized) << c.what;
    // the scene keeps its default sizes
    EXPECT_EQ(s.tracked_hand.model.finger[1].length[1], base.tracked_hand.model.finger[1].length[1]) << c.what;
  }
  // through the load: the bad ones are skipped, the first usable one sizes the hand
  app::TrackedSim sim;
  std::string error;
  ASSERT_TRUE(LoadSized(&sim, TrackerSizedText(),
                        Feed({SizedDatagram(1.2, 3), LeftHanded(SizedDatagram(1.2)), SizedDatagram(0.2),
                              SizedDatagram(1.2), SizedDatagram(1.0)}),
                        &error))
      << error;
  ExpectPhalanges(sim.world(), Scaled(1.2), "after skips ");
  EXPECT_NE(sim.sizing_note().find("datagram 4 (sizes: tracker; the 3 before it could not: hand 0 has 3 fingers"),
            std::string::npos)
      << sim.sizing_note();
}

TEST(WholeHand, TrackerSizesRefuseASessionWithoutAUsableDatagram) {
  const std::string text = TrackerSizedText();
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + text.find("sizes: tracker"), '\n'));
  const std::string at = "graspsim_sized_hand_" + std::to_string(getpid()) + ".yaml:" + std::to_string(line) + ":10: ";
  app::TrackedSim sim;
  std::string error;
  EXPECT_FALSE(LoadSized(&sim, text, Feed({SizedDatagram(1.2, 3), SizedDatagram(0.1)}), &error));
  EXPECT_NE(error.find(at), std::string::npos) << error;
  EXPECT_NE(error.find("none of the 2 datagrams can size the hand: the first: hand 0 has 3 fingers; the scene's hand "
                       "has 5; the last: hand 0, thumb (finger 0): a phalanx length is out of range"),
            std::string::npos)
      << error;
  EXPECT_FALSE(LoadSized(&sim, text, Feed({}), &error));
  EXPECT_NE(error.find("no datagram to size the hand from"), std::string::npos) << error;
  // a command with no datagrams before the build says so and names the alternative
  EXPECT_FALSE(LoadSized(&sim, text, nullptr, &error));
  EXPECT_NE(error.find("give the sizes per finger"), std::string::npos) << error;
}

void WriteSession(const std::string& path, const std::vector<std::string>& datagrams) {
  SessionWriter w;
  std::string error;
  ASSERT_TRUE(w.Open(path, &error)) << error;
  for (size_t i = 0; i < datagrams.size(); ++i) {
    Datagram d;
    d.data = datagrams[i].data();
    d.size = datagrams[i].size();
    d.monotonic_ns = 1000000000 + static_cast<int64_t>(i) * 10000000;
    d.utime = d.monotonic_ns / 1000;
    d.sequence = i;
    std::snprintf(d.source, sizeof(d.source), "test");
    ASSERT_TRUE(w.Write(d));
  }
  w.Close();
}

TEST(WholeHand, ReplaySizesTheHandFromTheSessionAndSceneCheckNotesTheDefault) {
  const std::string dir = test::TempDir("tracker_sizes");
  const std::string scene = dir + "/sized.yaml", good = dir + "/good.lcmlog", bad = dir + "/bad.lcmlog";
  std::ofstream(scene) << TrackerSizedText();
  WriteSession(good, {LeftHanded(SizedDatagram(1.2)), SizedDatagram(1.2), SizedDatagram(1.2)});
  WriteSession(bad, {SizedDatagram(1.2, 3), SizedDatagram(1.2, 3)});
  const test::Result r = test::Run(test::Binary() + " replay " + scene + " " + good + " --duration 0.003 --quiet");
  ASSERT_EQ(r.code, 0) << r.output;
  char index[96];
  const HandModel m = Scaled(1.2);
  std::snprintf(index, sizeof index, "index %.1f, %.1f, %.1f mm, radius %.1f mm", 1e3 * m.finger[1].length[0],
                1e3 * m.finger[1].length[1], 1e3 * m.finger[1].length[2], 1e3 * m.finger[1].radius);
  EXPECT_NE(r.output.find("replay: the hand sized from datagram 2 (sizes: tracker; the 1 before it could not: hand 0 "
                          "is a left hand"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find(index), std::string::npos) << index << "\n" << r.output;
  const test::Result refused = test::Run(test::Binary() + " replay " + scene + " " + bad + " --duration 0.003");
  EXPECT_EQ(refused.code, 3) << refused.output;
  EXPECT_NE(refused.output.find("sized.yaml:"), std::string::npos) << refused.output;
  EXPECT_NE(refused.output.find("none of the 2 datagrams can size the hand: the first: hand 0 has 3 fingers"),
            std::string::npos)
      << refused.output;
  // without a session the scene builds at the default sizes, and says so
  const test::Result check = test::Run(test::Binary() + " scene check " + scene);
  EXPECT_EQ(check.code, 0) << check.output;
  EXPECT_NE(check.output.find("note: 'sizes: tracker' with no tracker session here: the hand has the default sizes"),
            std::string::npos)
      << check.output;
}

// a parsed synthetic whole-hand datagram and the scene's tracker
struct Mapped {
  app::BuiltScene scene;
  SyntheticHand hand = SyntheticHand::WholeHand(5, 3.0);
  DTrackFrame frame;
  TargetSample sample;
  void Parse(double t) {
    DTrackParser parser;
    const std::string d = hand.Datagram(t, 1);
    ASSERT_EQ(parser.Parse(d.data(), d.size(), &frame), 0);
  }
  void Map() { MapFrame(frame, scene.tracker, &sample); }
  int Target(const std::string& body) const {
    for (size_t i = 0; i < scene.tracker.fingertips.size(); ++i)
      if (scene.tracker.fingertips[i].body == body) return static_cast<int>(i);
    ADD_FAILURE() << body;
    return 0;
  }
};

TEST(WholeHand, SegmentTargetsAreThePhalangesOfTheSentHand) {
  Mapped m;
  std::string error;
  ASSERT_TRUE(Build(SceneText(), &m.scene, &error)) << error;
  const double t = 1.5;  // closed on the box
  m.Parse(t);
  m.Map();
  ASSERT_EQ(m.sample.count, 16);
  Pose hand;
  TrackedFinger f[5];
  m.hand.WholeHandPose(t, &hand, f);
  const char* names[5] = {"thumb", "index", "middle", "ring", "little"};
  const char* phalanx[3] = {"outer", "middle", "inner"};
  for (int i = 0; i < 5; ++i) {
    const FingerChain c = ChainFromTip(f[i]);
    for (int k = 0; k < 3; ++k) {
      const int target = m.Target(std::string(names[i]) + "_" + phalanx[k]);
      ASSERT_TRUE(m.sample.valid[target]);
      const Pose want = PhalanxCapsulePose(c, static_cast<EPhalanx>(k));
      // the datagram rounds to 1 um and 1e-3 degrees
      EXPECT_LT((m.sample.pose[target].t - want.t).norm(), 1e-5) << names[i] << " " << phalanx[k];
      EXPECT_LT((m.sample.pose[target].R - want.R).norm(), 1e-4) << names[i] << " " << phalanx[k];
    }
  }
  const int palm = m.Target("palm");
  ASSERT_TRUE(m.sample.valid[palm]);
  EXPECT_LT((m.sample.pose[palm].t - hand.Apply(Vec3(0, 0, 0.0125))).norm(), 1e-5);
  // closed: the fingers' middle phalanges stand against the box's far face, the thumb's outer against the near one
  EXPECT_NEAR(m.sample.pose[m.Target("index_middle")].t.x(), 0.03 + 0.008 - 0.004, 1e-4);
  EXPECT_NEAR(m.sample.pose[m.Target("thumb_outer")].t.x(), -(0.03 + 0.0095 - 0.004), 1e-3);
}

TEST(WholeHand, SyntheticPinchPutsTheThumbAndIndexPadsIntoTwoFaces) {
  Mapped m;
  std::string error;
  ASSERT_TRUE(Build(SceneText(), &m.scene, &error)) << error;
  m.hand.pinch = true;
  m.Parse(1.3);  // closed, not lifted yet
  m.Map();
  // the outer phalanges stand 4 mm into the far (+x) and near (-x) faces of the box at the origin
  const Pose index = m.sample.pose[m.Target("index_outer")], thumb = m.sample.pose[m.Target("thumb_outer")];
  EXPECT_NEAR(index.t.x(), 0.03 + 0.008 - 0.004, 1e-4);
  EXPECT_NEAR(thumb.t.x(), -(0.03 + 0.0095 - 0.004), 1e-4);
  // upright (a capsule's axis is its z), and the pinch axis passes over the box's centre
  EXPECT_GT(std::abs(index.R.col(2).z()), 0.99);
  EXPECT_GT(std::abs(thumb.R.col(2).z()), 0.99);
  EXPECT_NEAR(index.t.y() + thumb.t.y(), 0.0, 1e-4);
  // the palm and the other fingers stay clear of the lid (z = 6 cm)
  EXPECT_GT(m.sample.pose[m.Target("palm")].t.z() - 0.0125, 0.06 + 0.004);
  for (const char* name : {"middle_outer", "middle_middle", "ring_outer", "little_outer"}) {
    const Vec3 c = m.sample.pose[m.Target(name)].t;
    const Vec3 nearest(std::clamp(c.x(), -0.03, 0.03), std::clamp(c.y(), -0.03, 0.03), std::clamp(c.z(), 0.0, 0.06));
    EXPECT_GT((c - nearest).norm(), 0.008) << name;  // the centre is farther from the box than the capsule's radius
  }
}

int ValidCount(const TargetSample& s) {
  int n = 0;
  for (int i = 0; i < s.count; ++i) n += s.valid[i];
  return n;
}

void ExpectFinite(const TargetSample& s) {
  for (int i = 0; i < s.count; ++i)
    EXPECT_TRUE(!s.valid[i] || (s.pose[i].t.allFinite() && s.pose[i].R.allFinite())) << i;
}

TEST(WholeHand, BadFingerBlocksLeaveTheirSegmentsInvalidAndNeverNaN) {
  Mapped m;
  std::string error;
  ASSERT_TRUE(Build(SceneText(), &m.scene, &error)) << error;
  m.Parse(1.5);
  const DTrackFrame good = m.frame;
  int code = 0;
  // a three-finger glove where the scene has five: ring and little are missing
  m.frame.hands[0].num_fingers = 3;
  m.Map();
  EXPECT_EQ(ValidCount(m.sample), 16 - 6);
  EXPECT_FALSE(m.sample.valid[m.Target("ring_outer")]);
  EXPECT_TRUE(m.sample.valid[m.Target("middle_outer")]);
  EXPECT_EQ(JudgeFrame(m.frame, 0, m.scene.tracker, m.sample, &code), ECarries::Missing);
  EXPECT_EQ(MissingLabel(m.scene.tracker, code),
            "finger 3 of hand 0 (or its gl block with a phalanx length or radius outside 5 to 120 mm)");
  // phalanx lengths of 0 and of 1 m, a NaN angle: that finger's segments only
  for (double bad : {0.0, 1000.0, std::nan("")}) {
    m.frame = good;
    m.frame.hands[0].fingers[1].phalanx_length[1] = bad;
    if (std::isnan(bad)) m.frame.hands[0].fingers[1].phalanx_angle[0] = bad;
    m.Map();
    EXPECT_EQ(ValidCount(m.sample), 16 - 3) << bad;
    EXPECT_FALSE(m.sample.valid[m.Target("index_inner")]);
    EXPECT_FALSE(m.sample.valid[m.Target("index_outer")]);
    EXPECT_EQ(JudgeFrame(m.frame, 0, m.scene.tracker, m.sample, &code), ECarries::Missing);
    EXPECT_EQ(MissingLabel(m.scene.tracker, code).rfind("finger 1 of hand 0 (or its gl block", 0), 0u);
    ExpectFinite(m.sample);
  }
  // a left hand where the scene has a right one: nothing
  m.frame = good;
  m.frame.hands[0].right = false;
  m.Map();
  EXPECT_EQ(ValidCount(m.sample), 0);
  EXPECT_EQ(JudgeFrame(m.frame, 0, m.scene.tracker, m.sample, &code), ECarries::Missing);
  EXPECT_EQ(code, -1);
  EXPECT_EQ(MissingLabel(m.scene.tracker, code), "hand 0 (right)");
  EXPECT_TRUE(CarriesOtherSide(m.frame, m.scene.tracker));
  m.frame = good;
  EXPECT_FALSE(CarriesOtherSide(m.frame, m.scene.tracker));
}

std::string WaitForText(const std::string& file, const std::string& text) {
  for (int i = 0; i < 600 && test::ReadFile(file).find(text) == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  return test::ReadFile(file);
}

// live judges the datagrams as replay does: a left glove's datagrams in the right
// hand's scene are said to drive nothing, with the scene's side: to change
TEST(WholeHand, LiveSaysAGloveOfTheOtherSideDroveNothing) {
  const std::string dir = test::TempDir("other_side_live");
  const std::string scene = dir + "/right.yaml", log = dir + "/left.lcmlog", out = dir + "/live.txt";
  std::ofstream(scene) << SceneText();
  WriteSession(log, std::vector<std::string>(100, LeftHanded(SizedDatagram(1.0))));
  const int port = test::FreeUdpPort();
  test::Child live({test::Binary(), "live", scene, "--port", std::to_string(port), "--publish-rate", "0",
                    "--rt-priority", "0"},
                   out);
  ASSERT_TRUE(live.started());
  ASSERT_NE(WaitForText(out, "live: listening on").find("live: listening on"), std::string::npos)
      << test::ReadFile(out);
  const test::Result send =
      test::Run(test::Binary() + " send " + log + " --port " + std::to_string(port) + " --delay 0");
  ASSERT_EQ(send.code, 0) << send.output;
  // the tracker's missing event says the datagrams came and lacked the hand
  ASSERT_NE(WaitForText(out, "absent from").find("absent from"), std::string::npos) << test::ReadFile(out);
  live.Signal(SIGINT);
  live.Wait();
  const std::string text = test::ReadFile(out);
  EXPECT_NE(text.find("live: none of the"), std::string::npos) << text;
  EXPECT_NE(text.find("carry hand 0 as a left hand, where the scene's hand has `side: right` (set `side: left`"),
            std::string::npos)
      << text;
}

TEST(WholeHand, LiveWaitsForTheTrackerToSizeTheHandAndStopsOnCtrlC) {
  const std::string dir = test::TempDir("tracker_sizes_live");
  const std::string scene = dir + "/sized.yaml", log = dir + "/session.lcmlog", out = dir + "/live.txt";
  std::ofstream(scene) << TrackerSizedText();
  WriteSession(log, {LeftHanded(SizedDatagram(1.2)), SizedDatagram(1.2)});
  const int port = test::FreeUdpPort();
  const std::string waiting = "live: waiting for the tracker's hand 0 on UDP port " + std::to_string(port);
  {
    test::Child live({test::Binary(), "live", scene, "--port", std::to_string(port), "--duration", "0.2",
                      "--publish-rate", "0", "--rt-priority", "0"},
                     out);
    ASSERT_TRUE(live.started());
    ASSERT_NE(WaitForText(out, waiting).find(waiting), std::string::npos) << test::ReadFile(out);
    const test::Result send = test::Run(test::Binary() + " send " + log + " --port " + std::to_string(port) +
                                        " --delay 0");
    ASSERT_EQ(send.code, 0) << send.output;
    EXPECT_EQ(live.Wait(), 0) << test::ReadFile(out);
  }
  const std::string text = test::ReadFile(out);
  EXPECT_NE(text.find("live: the hand sized from datagram 2 (sizes: tracker; the 1 before it could not: hand 0 is a "
                      "left hand"),
            std::string::npos)
      << text;
  EXPECT_LT(text.find("sized from datagram"), text.find("live: scene whole_hand_power_grasp")) << text;
  // nothing sent: Ctrl-C ends the wait with the interrupted exit code
  test::Child idle({test::Binary(), "live", scene, "--port", std::to_string(port), "--publish-rate", "0",
                    "--rt-priority", "0"},
                   out + ".idle");
  ASSERT_TRUE(idle.started());
  ASSERT_NE(WaitForText(out + ".idle", waiting).find(waiting), std::string::npos) << test::ReadFile(out + ".idle");
  idle.Signal(SIGINT);
  EXPECT_EQ(idle.Wait(), 130) << test::ReadFile(out + ".idle");
  EXPECT_NE(test::ReadFile(out + ".idle").find("interrupted while waiting for the tracker to size the hand"),
            std::string::npos)
      << test::ReadFile(out + ".idle");
  // any free port (--port 0): the loop keeps the port the wait printed, where the tracker sends
  const std::string any = out + ".any", prefix = "live: waiting for the tracker's hand 0 on UDP port ";
  test::Child live0({test::Binary(), "live", scene, "--port", "0", "--duration", "0.2", "--publish-rate", "0",
                     "--rt-priority", "0"},
                    any);
  ASSERT_TRUE(live0.started());
  const std::string said = WaitForText(any, prefix);
  ASSERT_NE(said.find(prefix), std::string::npos) << test::ReadFile(any);
  const int chosen = std::atoi(said.c_str() + said.find(prefix) + prefix.size());
  ASSERT_GT(chosen, 0) << said;
  const test::Result send0 =
      test::Run(test::Binary() + " send " + log + " --port " + std::to_string(chosen) + " --delay 0");
  ASSERT_EQ(send0.code, 0) << send0.output;
  EXPECT_EQ(live0.Wait(), 0) << test::ReadFile(any);
  EXPECT_NE(test::ReadFile(any).find("UDP port " + std::to_string(chosen) + ";"), std::string::npos)
      << test::ReadFile(any);
}

// steps the scene on the synthetic whole hand's datagrams at 100 Hz, in simulated time
class Session {
 public:
  explicit Session(const std::string& text, bool pinch = false, double hold_s = 3.0, bool right = true)
      : hand_(SyntheticHand::WholeHand(5, hold_s)) {
    hand_.pinch = pinch;
    hand_.right = right;
    const std::string path =
        std::filesystem::temp_directory_path() / ("graspsim_whole_hand_" + std::to_string(getpid()) + ".yaml");
    std::ofstream(path) << text;
    std::string error;
    ok_ = sim_.Load(path, &error);
    EXPECT_TRUE(ok_) << error;
    std::filesystem::remove(path);
  }
  bool ok() const { return ok_; }
  app::TrackedSim& sim() { return sim_; }
  SyntheticHand& hand() { return hand_; }
  /// from now on the datagrams carry this many fingers (a finger lost mid-grasp)
  void SendFingers(int n) { sent_fingers_ = n; }
  void RunTo(double t_end) {
    World& w = sim_.world();
    while (w.time < t_end - 0.5 * w.params.dt) {
      if (w.time >= next_ - 0.5 * w.params.dt) {
        std::string d = hand_.Datagram(next_, frame_++);
        if (sent_fingers_ < 5) d = CutFingers(d, sent_fingers_);
        TargetSample s;
        sim_.Ingest(d.data(), d.size(), false, &s);
        sim_.Push(s);
        next_ += 0.01;
      }
      sim_.Step();
    }
  }

 private:
  // the gl line with only the first n fingers (their blocks are three each)
  static std::string CutFingers(const std::string& d, int n) {
    std::string s = d;
    const size_t gl = s.find("gl 1 [0 1.000 1 5]");
    s.replace(gl, 18, "gl 1 [0 1.000 1 " + std::to_string(n) + "]");
    size_t at = s.find("] [", gl);  // the first finger's block starts after the hand's matrix
    for (int f = 0; f < n && at != std::string::npos; ++f) at = s.find("] [", at + 1);
    if (at != std::string::npos) s = s.substr(0, at + 1) + "\r\n";
    return s;
  }
  app::TrackedSim sim_;
  SyntheticHand hand_;
  bool ok_ = false;
  int sent_fingers_ = 5;
  double next_ = 0.0;
  uint32_t frame_ = 1;
};

bool AllFinite(const World& w) {
  for (const Body& b : w.bodies)
    if (!b.pose.t.allFinite() || !b.pose.R.allFinite() || !b.velocity.allFinite()) return false;
  return true;
}

// the two ends of a phalanx capsule (its axis is the body's z, length the link's)
void CapsuleEnds(const Body& b, double length, Vec3* proximal, Vec3* distal) {
  *proximal = b.pose.t - 0.5 * length * b.pose.R.col(2);
  *distal = b.pose.t + 0.5 * length * b.pose.R.col(2);
}

TEST(WholeHand, PhalangesStayJoinedAndRootedOnThePalmWhileTheBoxStopsThem) {
  Session s(SceneText());
  ASSERT_TRUE(s.ok());
  const World& w = s.sim().world();
  ASSERT_EQ(w.hand.fingers.size(), 5u);
  ASSERT_GE(w.hand.carrier, 0);
  EXPECT_EQ(w.bodies[w.hand.carrier].name, "palm");
  double worst_joint = 0.0, worst_root = 0.0, farthest_target = 0.0;
  int limit_rows = 0;
  while (w.time < 2.4) {
    const Pose palm_before = w.bodies[w.hand.carrier].pose;
    s.RunTo(w.time + w.params.dt);
    for (const Finger& f : w.hand.fingers) {
      Vec3 prox[3], dist[3];
      for (int l = 0; l < 3; ++l) {
        const Body& b = w.bodies[f.segment_body[l]];
        EXPECT_EQ(b.motion, EMotion::Fingertip) << b.name;
        CapsuleEnds(b, f.model.link_lengths[l], &prox[l], &dist[l]);
        farthest_target = std::max(farthest_target, (b.drive.target.t - b.pose.t).norm());
      }
      // inner to middle, middle to outer: one joint, however the box pushed them
      worst_joint = std::max({worst_joint, (dist[0] - prox[1]).norm(), (dist[1] - prox[2]).norm()});
      // the knuckle sits where the palm carried it at the step's start
      const Vec3 root = (palm_before * w.hand.carrier_offset * f.model.base).t;
      worst_root = std::max(worst_root, (prox[0] - root).norm());
    }
    limit_rows = std::max(limit_rows, static_cast<int>(w.limit_rows.size()));
  }
  EXPECT_LT(worst_joint, 1e-9);
  EXPECT_LT(worst_root, 1e-9);
  // the tracked hand closed through the box while the simulated one was stopped on it
  EXPECT_GT(farthest_target, 0.005);
  EXPECT_TRUE(AllFinite(w));
  EXPECT_EQ(w.rejected_steps, 0);
}

TEST(WholeHand, JointLimitsStopAFingerTheGloveBendsPastThem) {
  app::BuiltScene b;
  std::string error;
  ASSERT_TRUE(Build(SceneText(), &b, &error)) << error;
  World& w = b.world;
  const int index = 1;
  Finger& f = w.hand.fingers[index];
  ASSERT_EQ(f.name, "index");
  const double pip_max = f.model.limits[2][1];
  // the glove bends the index's middle joint 0.6 rad past its range (a tracker
  // glitch, or a hand larger than the model): every segment's target is that pose
  const Vec4 bent(0.0, 0.3, pip_max + 0.6, 0.3);
  const FingerKinematics k = FingerForward(f.model, w.hand.pose, bent);
  CouplingParams coupling;
  for (int step = 0; step < 400; ++step) {
    for (int l = 0; l < 3; ++l) {
      Body& seg = w.bodies[f.segment_body[l]];
      SetCouplingTarget(seg, w.params.gravity, coupling, k.link[l] * f.segment_offset[l], Vec3::Zero(), Vec3::Zero());
    }
    // the palm holds where it is
    SetCouplingTarget(w.bodies[w.hand.carrier], w.params.gravity, coupling, w.bodies[w.hand.carrier].pose,
                      Vec3::Zero(), Vec3::Zero());
    w.Step();
  }
  const Finger& g = w.hand.fingers[index];
  // the bent joint stops at its limit; the outer joint bends further than the glove's
  // 0.3 to bring the outer phalanx as near as it can to where the glove puts it
  EXPECT_NEAR(g.q[2], pip_max, 1e-3);
  EXPECT_NEAR(g.q[1], 0.3, 0.05);
  EXPECT_GT(g.q[3], 0.3 + 0.2);
  EXPECT_LE(g.q[3], g.model.limits[3][1] + 1e-3);
  // held there by the limit's row, which carries the springs' pull
  double torque = 0.0;
  for (const LimitRow& l : w.limit_rows)
    if (l.finger == index && l.joint == 2) torque = l.Torque();
  EXPECT_LT(torque, -1e-3);  // the upper limit pushes the joint back (negative torque)
  EXPECT_TRUE(AllFinite(w));
  EXPECT_EQ(w.rejected_steps, 0);
}

TEST(WholeHand, FingersLostMidGraspHoldThenReleaseWithoutNaN) {
  Session s(SceneText());
  ASSERT_TRUE(s.ok());
  const auto& tips = s.sim().config().fingertips;
  const auto target = [&](const char* body) {
    for (size_t i = 0; i < tips.size(); ++i)
      if (tips[i].body == body) return static_cast<int>(i);
    return -1;
  };
  const int ring = target("ring_outer"), little = target("little_inner"), index = target("index_outer");
  ASSERT_GE(ring, 0);
  // closed on the box and lifting it, the glove falls back to three fingers
  s.RunTo(1.6);
  EXPECT_EQ(s.sim().follower().state(ring), ETipState::Tracking);
  s.SendFingers(3);
  s.RunTo(1.75);
  EXPECT_EQ(s.sim().follower().state(ring), ETipState::Lost);
  EXPECT_EQ(s.sim().follower().state(little), ETipState::Lost);
  const Pose held = s.sim().follower().target(ring);
  s.RunTo(1.95);
  EXPECT_EQ(s.sim().follower().target(ring).t, held.t);  // held at the last pose
  s.RunTo(2.15);  // lost_timeout_s 0.5 after the last sample with them (1.59 s)
  EXPECT_EQ(s.sim().follower().state(ring), ETipState::Released);
  EXPECT_EQ(s.sim().follower().state(index), ETipState::Tracking);
  EXPECT_TRUE(AllFinite(s.sim().world()));
  EXPECT_EQ(s.sim().world().rejected_steps, 0);
  // the released ring and little let go (at mu 0.5 the box then slips down the
  // remaining fingers), and nothing passes through the table
  const World& w = s.sim().world();
  EXPECT_GT(w.bodies[s.sim().scene().tracked_body].pose.t.z(), 0.029);
  // tracked again
  s.SendFingers(5);
  s.RunTo(2.25);
  EXPECT_EQ(s.sim().follower().state(ring), ETipState::Tracking);
}

// the box's height through the synthetic hold (t = 2.0..5.0 s: lifted 5 cm at 2.0 s)
struct Hold {
  double lifted = 0.0, lowest = 1e9, highest = -1e9;
  int64_t rejected = 0;
  bool finite = true;
};

Hold RunGrasp(const std::string& text, double end, bool pinch = false) {
  Session s(text, pinch);
  Hold h;
  if (!s.ok()) return h;
  const World& w = s.sim().world();
  const int box = s.sim().scene().tracked_body;
  s.RunTo(2.1);
  h.lifted = w.bodies[box].pose.t.z();
  while (w.time < end - 0.5e-3) {
    s.RunTo(w.time + 0.05);
    h.lowest = std::min(h.lowest, w.bodies[box].pose.t.z());
    h.highest = std::max(h.highest, w.bodies[box].pose.t.z());
    h.finite &= AllFinite(w);
  }
  h.rejected = w.rejected_steps;
  return h;
}

// lifted most of the hand's 5 cm from resting at 30.2 mm, and held there: the box
// neither slips down nor is thrown
void ExpectHeld(const Hold& h) {
  EXPECT_GT(h.lifted, 0.0302 + 0.04);
  EXPECT_GT(h.lowest, h.lifted - 0.003);
  EXPECT_LT(h.highest, h.lifted + 0.003);
  EXPECT_TRUE(h.finite);
  EXPECT_EQ(h.rejected, 0);
}

TEST(WholeHand, PowerGraspHoldsTheBoxThroughAThreeSecondHoldAtFrictionHalf) {
  ExpectHeld(RunGrasp(SceneText(), 5.0));
}

// The lift (the synthetic hand raises the box 5 cm from 1.4 to 2.0 s, smoothstepped:
// its acceleration changes by at most 0.04 m/s^2 a step). The box rises with the
// hand, its speed changing smoothly from step to step, and the tracker's samples
// (every 10 steps) do not show in it: the step that ended as a target reached its
// sample used to lose the couplings' velocity feed-forward, and the box's speed
// dropped by a fifth at every sample, the fingers slipping to and fro by 20-60 um.
TEST(WholeHand, TheLiftedBoxRisesWithTheHandWithoutAJerkAtEachSample) {
  Session s(SceneText());
  ASSERT_TRUE(s.ok());
  World& w = s.sim().world();
  const int box = s.sim().scene().tracked_body;
  s.RunTo(1.55);
  double last = w.bodies[box].velocity.z(), worst = 0.0, fastest = 0.0;
  while (w.time < 1.85 - 0.5e-3) {
    s.RunTo(w.time + w.params.dt);
    const double vz = w.bodies[box].velocity.z();
    worst = std::max(worst, std::abs(vz - last));
    fastest = std::max(fastest, vz);
    last = vz;
  }
  std::printf("lift: fastest %.4f m/s, largest change in a step %.3g m/s\n", fastest, worst);
  EXPECT_GT(fastest, 0.1);  // the hand's top speed is 0.125 m/s
  // the hand's own speed changes by at most 0.83 mm/s a step (0.95 measured); the
  // drops at the samples were 25 mm/s
  EXPECT_LT(worst, 2e-3);
}

// The shipped scene at the paper's densities, with the solver's default sweep cap
// (it sets none), stepped offline as a replay steps it: every step of the synthetic
// grasp (closing, lift, 3 s hold, release) ends with its contacts solved to the
// scene's tolerance. There the box's control points lie 2 mm apart under skins 3-4 mm
// wide, and the lift's solves take up to 650 Gauss-Seidel sweeps; with the shipped
// scenes' cap of 50, 806 of the replay's 6,300 steps ended unconverged, at the old
// default of 100, 335.
TEST(WholeHand, ThePaperDensitySceneSolvesEveryStepOfTheGrasp) {
#ifdef GRASPSIM_SANITIZED
  // skipped under sanitizers only (far too slow there); the release suite runs it
  GTEST_SKIP() << "5,800 steps of a 74,400-point scene (an hour under sanitizers); the release build runs it";
#endif
  std::ifstream f(std::string(GRASPSIM_SOURCE_DIR) + "/config/whole_hand_paper_density.yaml");
  std::stringstream text;
  text << f.rdbuf();
  Session s(text.str());
  ASSERT_TRUE(s.ok());
  World& w = s.sim().world();
  EXPECT_EQ(w.params.solver.max_iterations, kStepSweepCap);
  const int box = s.sim().scene().tracked_body;
  int unconverged = 0, most_sweeps = 0;
  double highest = 0.0;
  while (w.time < s.hand().duration_s - 0.5e-3) {
    s.RunTo(w.time + w.params.dt);
    unconverged += !w.profile.converged;
    most_sweeps = std::max(most_sweeps, w.profile.iterations);
    highest = std::max(highest, w.bodies[box].pose.t.z());
  }
  std::printf("paper densities: %d unconverged steps, at most %d sweeps\n", unconverged, most_sweeps);
  EXPECT_EQ(unconverged, 0);
  EXPECT_EQ(w.rejected_steps, 0);
  EXPECT_GT(highest, 0.0302 + 0.04);  // lifted
}

TEST(WholeHand, PowerGraspCannotLiftTheBoxAtFrictionOneTenth) {
  // the same grasp with too little friction: the fingers slide up the faces
  const Hold h = RunGrasp(Replace(SceneText(), "default: 0.5", "default: 0.1"), 2.2);
  EXPECT_LT(h.lifted, 0.0302 + 0.01);
  EXPECT_TRUE(h.finite);
}

// the hand section as a user writes it with the defaults: the palm and phalanges
// unset, so two-pass contact (`contact_points: true`) and the default densities
std::string DefaultHandText() {
  std::string text = SceneText();
  for (const char* key : {"  palm: {", "  phalanx: {"}) {
    const size_t at = text.find(key);
    EXPECT_NE(at, std::string::npos) << key;
    if (at != std::string::npos) text.erase(at, text.find('\n', at) + 1 - at);
  }
  return text;
}

TEST(WholeHand, PowerGraspWithTheHandsDefaultsHoldsAtFrictionHalfAndNotAtOneTenth) {
  app::BuiltScene b;
  std::string error;
  ASSERT_TRUE(Build(DefaultHandText(), &b, &error)) << error;
  EXPECT_TRUE(b.world.bodies[BodyIndex(b.world, "palm")].emits_contacts);  // two-pass
  EXPECT_TRUE(b.world.bodies[BodyIndex(b.world, "index_outer")].emits_contacts);
  const Hold h = RunGrasp(DefaultHandText(), 5.0);
  ExpectHeld(h);
  const Hold slip = RunGrasp(Replace(DefaultHandText(), "default: 0.5", "default: 0.1"), 2.2);
  EXPECT_LT(slip.lifted, 0.0302 + 0.01);
  EXPECT_TRUE(slip.finite);
}

TEST(WholeHand, SyntheticLeftHandIsTheRightOneMirroredAndLiftsTheBox) {
  Mapped right, left;
  std::string error;
  ASSERT_TRUE(Build(SceneText(), &right.scene, &error)) << error;
  ASSERT_TRUE(Build(Replace(SceneText(), "side: right", "side: left"), &left.scene, &error)) << error;
  left.hand.right = false;
  EXPECT_NE(left.hand.Datagram(1.5, 1).find("gl 1 [0 1.000 0 5]"), std::string::npos);  // lr 0: left
  for (double t : {0.3, 1.5, 3.0}) {
    right.Parse(t);
    right.Map();
    left.Parse(t);
    left.Map();
    ASSERT_EQ(left.sample.count, 16);
    // every target of the left scene is the right scene's mirrored in the room's y
    const Mat3 mirror = Vec3(1.0, -1.0, 1.0).asDiagonal();
    for (const FingertipMap& f : left.scene.tracker.fingertips) {
      const int l = left.Target(f.body), r = right.Target(f.body);
      ASSERT_TRUE(left.sample.valid[l]) << f.body;
      EXPECT_LT((left.sample.pose[l].t - mirror * right.sample.pose[r].t).norm(), 2e-6) << f.body << " at " << t;
      EXPECT_LT((left.sample.pose[l].R - mirror * right.sample.pose[r].R * mirror).norm(), 1e-4) << f.body;
    }
  }
  // the scene's synthetic hand is a left one (bench step --scene, live tests), and it grasps
  app::TrackedSim sim;
  const std::string path = std::filesystem::temp_directory_path() / ("graspsim_left_" + std::to_string(getpid()) + ".yaml");
  std::ofstream(path) << Replace(SceneText(), "side: right", "side: left");
  ASSERT_TRUE(sim.Load(path, &error)) << error;
  std::filesystem::remove(path);
  EXPECT_FALSE(SyntheticHandFor(sim.config()).right);
  Session s(Replace(SceneText(), "side: right", "side: left"), false, 3.0, false);
  ASSERT_TRUE(s.ok());
  s.RunTo(3.0);
  const World& w = s.sim().world();
  EXPECT_GT(w.bodies[s.sim().scene().tracked_body].pose.t.z(), 0.0302 + 0.04);
  EXPECT_EQ(w.rejected_steps, 0);
}

TEST(WholeHand, AHandPulledThroughTheBoxIsLetThroughAndTheWorldGoesOn) {
  // the glove grasps 6 cm below the box: the tracked hand closes inside it and the
  // springs pull the segments through its lid; the steps that take a segment's centre
  // into the box are rejected, then let through (WorldParams::pass_through_retries)
  // instead of freezing the world while the pull lasts
  Session s(SceneText());
  ASSERT_TRUE(s.ok());
  s.hand().box_center_mm = Vec3(0.0, 0.0, -30.0);
  const World& w = s.sim().world();
  s.RunTo(5.0);
  EXPECT_GT(w.pass_through_steps, 0);
  EXPECT_GT(w.pass_throughs_let, 0);
  EXPECT_EQ(w.rejected_steps, w.pass_through_steps);
  EXPECT_TRUE(AllFinite(w));
  // the glove opens and rises (5.2 to 5.8 s): the hand follows it out, no step rejected
  s.RunTo(6.0);
  const int64_t rejected = w.rejected_steps;
  s.RunTo(6.5);
  EXPECT_EQ(w.rejected_steps, rejected);
  Pose hand;
  TrackedFinger f[5];
  s.hand().WholeHandPose(6.5, &hand, f);
  const Vec3 palm_target = hand.Apply(Vec3(0.0, 0.0, 0.0125));
  EXPECT_LT((w.bodies[BodyIndex(w, "palm")].pose.t - palm_target).norm(), 0.01);
  EXPECT_TRUE(AllFinite(w));
}

TEST(WholeHand, PowerGraspWithSelfContactHoldsTheBox) {
  // the segments of different fingers, and the fingers and the palm, touch
  const Hold h = RunGrasp(Replace(SceneText(), "self_contact: false", "self_contact: true"), 5.0);
  ExpectHeld(h);
}

// the least distance between two capsules' axes (each its body's z, of its half length)
double AxisDistance(const Body& a, const Body& b) {
  const Vec3 pa = a.pose.t - a.geometry.shape.half_length * a.pose.R.col(2);
  const Vec3 pb = b.pose.t - b.geometry.shape.half_length * b.pose.R.col(2);
  const Vec3 da = 2.0 * a.geometry.shape.half_length * a.pose.R.col(2);
  const Vec3 db = 2.0 * b.geometry.shape.half_length * b.pose.R.col(2);
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= 400; ++i) {  // along a, the closest point of b's axis
    const Vec3 p = pa + da * (i / 400.0);
    const double t = std::clamp((p - pb).dot(db) / db.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (p - pb - t * db).norm());
  }
  return best;
}

TEST(WholeHand, SelfContactSpreadsFingersTooThickForTheirKnuckles) {
  // index and middle 10.5 mm in radius on knuckles 18 mm apart: their tracked
  // capsules overlap by 3 mm along their whole length
  const std::string thick = Replace(
      SceneText(), "  self_contact: false\n",
      "  self_contact: false\n  sizes: {index: {lengths_m: [0.0223, 0.0265, 0.0432], radius_m: 0.0105}, "
      "middle: {lengths_m: [0.0241, 0.0299, 0.0473], radius_m: 0.0105}}\n");
  double outer[2] = {0.0, 0.0}, inner[2] = {0.0, 0.0};
  for (int self = 0; self < 2; ++self) {
    Session s(self ? Replace(thick, "self_contact: false", "self_contact: true") : thick);
    ASSERT_TRUE(s.ok());
    const World& w = s.sim().world();
    s.RunTo(3.0);  // in the hold
    outer[self] = AxisDistance(w.bodies[BodyIndex(w, "index_outer")], w.bodies[BodyIndex(w, "middle_outer")]);
    inner[self] = AxisDistance(w.bodies[BodyIndex(w, "index_inner")], w.bodies[BodyIndex(w, "middle_inner")]);
    EXPECT_GT(w.bodies[s.sim().scene().tracked_body].pose.t.z(), 0.0302 + 0.04) << "self contact " << self;
    EXPECT_EQ(w.rejected_steps, 0);
    EXPECT_TRUE(AllFinite(w));
  }
  // without self contact the outer phalanges follow the glove into each other; with
  // it they are pushed apart to within what their two skins give (21 mm less ~1 mm)
  EXPECT_LT(outer[0], 0.0185);
  EXPECT_GT(outer[1], 0.0195);
  EXPECT_LT(outer[1], 0.021);
  // the inner ones stay on their knuckles, 18 mm apart, either way (turned about
  // their abduction joints by the box's contacts by up to 0.35 mm)
  EXPECT_NEAR(inner[0], 0.018, 5e-4);
  EXPECT_NEAR(inner[1], 0.018, 5e-4);
}

std::string PinchText() {
  std::ifstream f(std::string(GRASPSIM_SOURCE_DIR) + "/config/tracked_whole_hand.yaml");
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// The friction threshold (hold at 1.01 mu*, slip at 0.99 mu*, both contact modes) of
// the pinch and the power grasp: `graspsim validate whole-hand`
// (validate/validate_whole_hand.cpp, tests/app/validation_test.cpp).

TEST(WholeHand, PrecisionPinchHoldsTheBoxAtFrictionPointEightAndNotAtPointFour) {
  const Hold h = RunGrasp(PinchText(), 5.0, true);
  ExpectHeld(h);
  // two pads only: at 0.3, below its least holding friction (0.37 to 0.43, `graspsim
  // validate whole-hand`), it does not lift
  const Hold slip = RunGrasp(Replace(PinchText(), "default: 0.8", "default: 0.3"), 2.2, true);
  EXPECT_LT(slip.lifted, 0.0302 + 0.01);
  EXPECT_TRUE(slip.finite);
}

TEST(WholeHand, ShippedPinchSessionReplaysBitIdenticallyAndLifts) {
  const std::string dir = test::TempDir("whole_hand_replay");
  uint64_t hashes[2] = {0, 0};
  std::string summary, tips;
  for (int run = 0; run < 2; ++run) {
    const std::string out = dir + "/replay" + std::to_string(run);
    const test::Result r = test::Run(test::Binary() + " replay config/tracked_whole_hand.yaml " +
                                     GRASPSIM_SOURCE_DIR + "/assets/tracked_whole_hand.lcmlog --duration 2.2 --out " + out);
    ASSERT_EQ(r.code, 0) << r.output;
    for (const char* f : {"trajectory.csv", "fingertips.csv", "tracker.csv", "summary.json"})
      hashes[run] = hashes[run] * 31 + test::Hash(test::ReadFile(out + "/" + f));
    summary = test::ReadFile(out + "/summary.json");
    tips = test::ReadFile(out + "/fingertips.csv");
  }
  EXPECT_EQ(hashes[0], hashes[1]) << "replays differ";
  EXPECT_NE(summary.find("\"lifted\":true"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"rejected_steps\":0"), std::string::npos) << summary;
  // every segment's state, target and coupling force
  for (const char* col : {"palm_state", "thumb_outer_force_x_N", "little_inner_target_z_m"})
    EXPECT_NE(tips.find(col), std::string::npos) << col;
}

}  // namespace
}  // namespace gs::tracking
