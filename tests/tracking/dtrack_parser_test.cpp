// DTrack parser: the protocol reference's example packets (tests/data/dtrack/)
// and malformed variants of them.
#include "tracking/dtrack_parser.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

namespace gs::tracking {
namespace {

std::string ReadPacket(const std::string& name) {
  std::ifstream f(std::string(GRASPSIM_TEST_DATA) + "/dtrack/" + name, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  EXPECT_FALSE(ss.str().empty()) << name;
  return ss.str();
}

int ErrorCount(const DTrackParser& p, EParseError e) { return static_cast<int>(p.stats().errors[static_cast<int>(e)]); }

bool AllFinite(const DTrackFrame& f) {
  for (const Body6d& b : f.bodies)
    if (!b.position.allFinite() || !b.rotation.allFinite()) return false;
  for (const Hand& h : f.hands) {
    if (!h.position.allFinite() || !h.rotation.allFinite()) return false;
    for (int i = 0; i < h.num_fingers; ++i)
      if (!h.fingers[i].room_position.allFinite() || !h.fingers[i].room_rotation.allFinite()) return false;
  }
  for (const Marker& m : f.markers)
    if (!m.position.allFinite()) return false;
  for (const Flystick& s : f.flysticks)
    if (!s.position.allFinite()) return false;
  return std::isfinite(f.timestamp);
}

TEST(DTrackParser, PacketA_BodiesAndMarkers) {
  DTrackParser p;
  DTrackFrame f;
  EXPECT_EQ(p.Parse(ReadPacket("a_bodies_markers.txt"), &f), 0) << p.last_error();
  EXPECT_EQ(f.frame, 214233u);
  EXPECT_EQ(f.timestamp, 43671.538022);
  EXPECT_EQ(f.cal_bodies, 2);
  ASSERT_EQ(f.bodies.size(), 2u);
  const Body6d* b1 = f.FindBody(1);
  ASSERT_NE(b1, nullptr);
  EXPECT_EQ(b1->quality, 0.873);
  // bit for bit the correctly rounded values
  EXPECT_EQ(b1->position, Vec3(-740.266, 395.520, 1102.318));
  EXPECT_TRUE(b1->has_euler);
  EXPECT_EQ(b1->euler_deg, Vec3(170.2275, -31.0046, -45.5003));
  // column-wise matrix: b0 b1 b2 is the first column
  EXPECT_EQ(b1->rotation(0, 0), 0.600764);
  EXPECT_EQ(b1->rotation(1, 0), 0.641623);
  EXPECT_EQ(b1->rotation(0, 1), 0.611349);
  // the Euler angles describe the same rotation: R = Rx(eta) Ry(theta) Rz(phi)
  for (const Body6d& b : f.bodies) {
    const Mat3 R = RotationFromEulerDeg(b.euler_deg[0], b.euler_deg[1], b.euler_deg[2]);
    EXPECT_LT((R - b.rotation).cwiseAbs().maxCoeff(), 1e-5) << "body " << b.id;
  }
  ASSERT_EQ(f.markers.size(), 3u);
  ASSERT_NE(f.FindMarker(7), nullptr);
  EXPECT_EQ(f.FindMarker(7)->position, Vec3(12.003, 1.579, 2015.660));
  EXPECT_EQ(f.FindMarker(3), nullptr);
  EXPECT_TRUE(f.Has(ELine::Fr) && f.Has(ELine::Ts) && f.Has(ELine::Cal6d) && f.Has(ELine::Body6d) &&
              f.Has(ELine::Marker));
  EXPECT_FALSE(f.Has(ELine::Hand));
  EXPECT_EQ(p.stats().lines, 5u);
  EXPECT_EQ(p.stats().lines_parsed, 5u);
}

TEST(DTrackParser, PacketB_UntrackedObjects) {
  DTrackParser p;
  DTrackFrame f;
  EXPECT_EQ(p.Parse(ReadPacket("b_untracked.txt"), &f), 0) << p.last_error();
  EXPECT_EQ(f.cal_bodies, 4);
  ASSERT_EQ(f.bodies.size(), 1u);
  EXPECT_EQ(f.FindBody(0), nullptr);  // keyed by id: body 2 is not at index 2
  ASSERT_NE(f.FindBody(2), nullptr);
  EXPECT_EQ(f.FindBody(2)->position.z(), 980.771);
  ASSERT_EQ(f.flysticks.size(), 2u);
  EXPECT_EQ(f.cal_flysticks, 2);
  const Flystick* s0 = f.FindFlystick(0);
  ASSERT_NE(s0, nullptr);
  // untracked with an all-zero matrix: accepted, and its buttons stay valid
  EXPECT_FALSE(s0->tracked());
  EXPECT_TRUE(s0->rotation.isZero(0));
  EXPECT_EQ(s0->num_buttons, 6);
  EXPECT_EQ(s0->buttons, 5u);  // buttons 0 and 2
  EXPECT_EQ(s0->num_analogs, 2);
  EXPECT_EQ(s0->analogs[1], -1.0);
  const Flystick* s1 = f.FindFlystick(1);
  ASSERT_NE(s1, nullptr);
  EXPECT_TRUE(s1->tracked());
  EXPECT_EQ(s1->num_analogs, 3);
  EXPECT_EQ(s1->analogs[0], 0.12);
  EXPECT_EQ(s1->analogs[2], 0.98);
  // gl 0 and 3d 0: present but empty
  EXPECT_TRUE(f.Has(ELine::Hand));
  EXPECT_TRUE(f.hands.empty());
  EXPECT_EQ(f.cal_hands, 1);
  EXPECT_TRUE(f.Has(ELine::Marker));
  EXPECT_TRUE(f.markers.empty());
}

TEST(DTrackParser, PacketC_RightHandTipsComposedFromHandFrame) {
  DTrackParser p;
  DTrackFrame f;
  EXPECT_EQ(p.Parse(ReadPacket("c_right_hand_3.txt"), &f), 0) << p.last_error();
  ASSERT_EQ(f.hands.size(), 1u);
  const Hand& h = f.hands[0];
  EXPECT_TRUE(h.right);
  EXPECT_EQ(h.num_fingers, 3);
  EXPECT_EQ(h.position, Vec3(213.640, -310.452, 1088.190));
  const Mat3 R = h.rotation;
  const Vec3 f0(38.512, -62.077, -27.905);
  EXPECT_EQ(h.fingers[0].position, f0);
  EXPECT_LT((h.fingers[0].room_position - (h.position + R * f0)).norm(), 1e-9);
  EXPECT_LT((h.fingers[1].room_rotation - R * h.fingers[1].rotation).norm(), 1e-12);
  // the tips lie a hand's length from the back of the hand
  for (int i = 0; i < 3; ++i) {
    const double d = (h.fingers[i].room_position - h.position).norm();
    EXPECT_GT(d, 50.0);
    EXPECT_LT(d, 150.0);
  }
  // [ro lo aom lm ami li]
  EXPECT_EQ(h.fingers[0].tip_radius, 9.5);
  EXPECT_EQ(h.fingers[0].phalanx_length[0], 31.65);
  EXPECT_EQ(h.fingers[0].phalanx_angle[0], 24.19);
  EXPECT_EQ(h.fingers[0].phalanx_length[1], 33.87);
  EXPECT_EQ(h.fingers[0].phalanx_angle[1], 12.044);
  EXPECT_EQ(h.fingers[0].phalanx_length[2], 45.0);
  EXPECT_TRUE(f.Has(ELine::Body6d));
  EXPECT_TRUE(f.bodies.empty());
}

TEST(DTrackParser, PacketD_Ts2AndLeftHandWithFiveFingers) {
  DTrackParser p;
  DTrackFrame f;
  EXPECT_EQ(p.Parse(ReadPacket("d_ts2_left_hand_5.txt"), &f), 0) << p.last_error();
  EXPECT_TRUE(f.Has(ELine::Ts2));
  EXPECT_FALSE(f.Has(ELine::Ts));
  EXPECT_NEAR(f.timestamp, 34523.250114, 1e-9);
  EXPECT_EQ(f.latency_us, 4380);
  EXPECT_EQ(f.cal_hands, 2);
  EXPECT_EQ(f.FindHand(0), nullptr);
  const Hand* h = f.FindHand(1);
  ASSERT_NE(h, nullptr);
  EXPECT_FALSE(h->right);
  EXPECT_EQ(h->num_fingers, 5);
  EXPECT_EQ(h->fingers[4].tip_radius, 7.0);
}

TEST(DTrackParser, PacketE_ToolInertialStatusUnknownLine) {
  DTrackParser p;
  DTrackFrame f;
  EXPECT_EQ(p.Parse(ReadPacket("e_other_types.txt"), &f), 0) << p.last_error();
  EXPECT_EQ(p.stats().unknown_lines, 1u);
  ASSERT_EQ(f.tools.size(), 1u);
  const MeasurementTool& t = f.tools[0];
  EXPECT_TRUE(t.tracked());
  EXPECT_EQ(t.tip_radius, 2.0);
  EXPECT_EQ(t.num_buttons, 1);
  EXPECT_EQ(t.buttons, 0u);
  EXPECT_EQ(t.tip_covariance(0, 1), -6.468e-04);
  EXPECT_EQ(t.tip_covariance(1, 0), -6.468e-04);
  EXPECT_EQ(t.tip_covariance(1, 2), 9.944e-02);
  EXPECT_EQ(t.tip_covariance(2, 2), 6.639e-01);
  ASSERT_EQ(f.inertials.size(), 2u);
  EXPECT_EQ(f.FindInertial(0)->state, 3);
  EXPECT_EQ(f.FindInertial(1)->state, 1);
  EXPECT_EQ(f.FindInertial(1)->drift_deg, 1.25);
  EXPECT_TRUE(f.status.has_general);
  EXPECT_EQ(f.status.num_cameras, 4);
  EXPECT_EQ(f.status.num_markers, 1);
  EXPECT_TRUE(f.status.has_messages);
  EXPECT_EQ(f.status.other_warnings, 2);
  EXPECT_EQ(f.status.info, 17);
  ASSERT_EQ(f.status.cameras.size(), 2u);
  EXPECT_EQ(f.status.cameras[1].id, 1);
  EXPECT_EQ(f.status.cameras[0].reflections, 14);
  EXPECT_EQ(f.status.cameras[0].max_intensity, 10);
}

TEST(DTrackParser, EveryCategoryIsResetPerDatagram) {
  DTrackParser p;
  DTrackFrame f;
  ASSERT_EQ(p.Parse(ReadPacket("a_bodies_markers.txt"), &f), 0);
  ASSERT_EQ(f.markers.size(), 3u);
  ASSERT_EQ(p.Parse(ReadPacket("c_right_hand_3.txt"), &f), 0);
  EXPECT_FALSE(f.Has(ELine::Marker));
  EXPECT_TRUE(f.markers.empty());
  EXPECT_TRUE(f.bodies.empty());
  ASSERT_EQ(p.Parse("fr 7\r\n", &f), 0);
  EXPECT_EQ(f.present, 1u << static_cast<int>(ELine::Fr));
  EXPECT_TRUE(f.hands.empty());
  EXPECT_EQ(f.timestamp, -1.0);
}

TEST(DTrackParser, LineEndingsAndSpacing) {
  const std::string crlf = ReadPacket("c_right_hand_3.txt");
  DTrackParser p;
  DTrackFrame ref, f;
  ASSERT_EQ(p.Parse(crlf, &ref), 0);
  auto same = [&](const std::string& text) {
    DTrackFrame g;
    EXPECT_EQ(p.Parse(text, &g), 0) << p.last_error();
    ASSERT_EQ(g.hands.size(), 1u);
    EXPECT_EQ(g.present, ref.present);
    EXPECT_EQ(g.hands[0].fingers[2].room_position, ref.hands[0].fingers[2].room_position);
  };
  std::string lf, cr;
  for (char c : crlf)
    if (c != '\r') lf += c;
  for (char c : crlf)
    if (c != '\n') cr += c;
  same(lf);
  same(cr);
  same(crlf + std::string(1, '\0') + "6d garbage after the NUL");
  // runs of spaces inside blocks, none between objects, a trailing space
  std::string spaced;
  for (char c : crlf) {
    if (c == '[') spaced += "[  ";
    else if (c == ']') spaced += "  ]";
    else if (c == '\r') spaced += " \r";
    else spaced += c;
  }
  same(spaced);
  std::string tight;
  for (size_t i = 0; i < crlf.size(); ++i)
    if (!(crlf[i] == ' ' && i > 0 && crlf[i - 1] == ']')) tight += crlf[i];
  same(tight);
}

TEST(DTrackParser, NumbersAreCorrectlyRoundedLikeStrtodInTheCLocale) {
  const char* values[] = {"0.1", "2.2250738585072011e-308", "9007199254740993", "1.000000000000000111",
                          "-0.000001", "1.082e-01", "+5.5", "123456.789012345678"};
  DTrackParser p;
  for (const char* v : values) {
    DTrackFrame f;
    const std::string line = std::string("3d 1 [1 1.000][") + v + " 0 0]\r\n";
    ASSERT_EQ(p.Parse(line, &f), 0) << v << ": " << p.last_error();
    ASSERT_EQ(f.markers.size(), 1u);
    EXPECT_EQ(f.markers[0].position.x(), std::strtod(v, nullptr)) << v;
  }
}

TEST(DTrackParser, SixDPositionBlockOfThreeOrMoreValues) {
  DTrackParser p;
  DTrackFrame f;
  const char* rot = "[1 0 0 0 1 0 0 0 1]";
  ASSERT_EQ(p.Parse(std::string("6d 1 [4 1.0][1 2 3]") + rot + "\r\n", &f), 0) << p.last_error();
  ASSERT_EQ(f.bodies.size(), 1u);
  EXPECT_FALSE(f.bodies[0].has_euler);
  EXPECT_EQ(f.bodies[0].position, Vec3(1, 2, 3));
  ASSERT_EQ(p.Parse(std::string("6d 1 [4 1.0][1 2 3 0 0 0 99]") + rot + "\r\n", &f), 0);
  EXPECT_TRUE(f.bodies[0].has_euler);
  DTrackFrame g;
  EXPECT_EQ(p.Parse(std::string("6d 1 [4 1.0][1 2]") + rot + "\r\n", &g), 1);
  EXPECT_EQ(p.last_error_category(), EParseError::MissingBlock);
}

// a malformed line is dropped with its category; the rest of the datagram is kept
struct BadLine {
  const char* line;
  EParseError category;
  const char* name;
};
// gtest prints the case by its name (not its bytes) in test listings
void PrintTo(const BadLine& b, std::ostream* os) { *os << b.name; }

class DTrackMalformed : public ::testing::TestWithParam<BadLine> {};

TEST_P(DTrackMalformed, LineDroppedRestKept) {
  const BadLine& bad = GetParam();
  const std::string packet = std::string("fr 12\r\n") + bad.line + "\r\n3d 1 [1 1.000][1.5 2.5 3.5]\r\n";
  DTrackParser p;
  DTrackFrame f;
  EXPECT_EQ(p.Parse(packet, &f), 1) << bad.line;
  EXPECT_EQ(p.last_error_category(), bad.category) << bad.line << ": " << p.last_error();
  EXPECT_EQ(ErrorCount(p, bad.category), 1);
  EXPECT_EQ(p.stats().TotalErrors(), 1u);
  EXPECT_NE(std::string(p.last_error()).find("line 2"), std::string::npos) << p.last_error();
  // the bad line's category is absent and empty; the others are whole
  EXPECT_TRUE(f.bodies.empty());
  EXPECT_TRUE(f.hands.empty());
  EXPECT_EQ(f.frame, 12u);
  ASSERT_EQ(f.markers.size(), 1u);
  EXPECT_EQ(f.markers[0].position, Vec3(1.5, 2.5, 3.5));
  EXPECT_TRUE(AllFinite(f));
}

const char* kId = "[0 1.000]";
const char* kRot = "[1 0 0 0 1 0 0 0 1]";

std::string Body(const std::string& pos, const std::string& rot = kRot) { return std::string(kId) + pos + rot; }

const std::string kBodyTruncated = "6d 2 " + Body("[1 2 3 0 0 0]") + " [1 1.000][4 5";
const std::string kBodyNan = "6d 1 " + Body("[nan 2 3]");
const std::string kBodyInf = "6d 1 " + Body("[1 -inf 3]");
const std::string kBodyHuge = "6d 1 " + Body("[1 2 1e999]");
const std::string kBodyComma = "6d 1 " + Body("[1,5 2 3]");
const std::string kBodyCountTooLarge = "6d 3 " + Body("[1 2 3]");
const std::string kBodyZeroRot = "6d 1 " + Body("[1 2 3]", "[0 0 0 0 0 0 0 0 0]");
const std::string kBodySkewRot = "6d 1 " + Body("[1 2 3]", "[1 0 0 0.5 1 0 0 0 1]");
const std::string kBodyMirror = "6d 1 " + Body("[1 2 3]", "[1 0 0 0 1 0 0 0 -1]");
const std::string kBodyDuplicate = "6d 2 " + Body("[1 2 3]") + " " + Body("[1 2 3]");
const std::string kBodyQuality = "6d 1 [0 1.5][1 2 3]" + std::string(kRot);
const std::string kBodyNegCount = "6d -1";
const std::string kBodyTextCount = "6d two";
const std::string kBodyNoBracket = "6d 1 0 1.000][1 2 3]" + std::string(kRot);
const std::string kBodyNestedBracket = "6d 1 [0 [1.000][1 2 3]" + std::string(kRot);
const std::string kBodyFloatId = "6d 1 [0.5 1.000][1 2 3]" + std::string(kRot);
const std::string kBodyMissingRot = "6d 1 [0 1.000][1 2 3]";
const std::string kHandSixFingers = "gl 1 [0 1.000 1 6][1 2 3]" + std::string(kRot);
const std::string kHandZeroFingerRot =
    "gl 1 [0 1.000 1 1][1 2 3]" + std::string(kRot) + "[1 2 3][0 0 0 0 0 0 0 0 0][9 30 20 30 10 40]";
const std::string kHandMissingFinger = "gl 1 [0 1.000 1 2][1 2 3]" + std::string(kRot) + "[1 2 3]" + kRot + "[9 30 20 30 10 40]";
const std::string kHandBadSide = "gl 1 [0 1.000 2 0][1 2 3]" + std::string(kRot);
const std::string kFlystickButtons = "6df2 1 1 [0 1.000 40 2][1 2 3]" + std::string(kRot) + "[0 0 0]";
const std::string kFlystickAnalogsMissing = "6df2 1 1 [0 1.000 8 3][1 2 3]" + std::string(kRot) + "[0 0.5]";
const std::string kFlystickWordTooBig = "6df2 1 1 [0 1.000 2 0][1 2 3]" + std::string(kRot) + "[4]";
const std::string kHumanJoints = "6dj 1 1 [0 201]";
const std::string kInertialState = "6di 1 [0 4 0.0][1 2 3]" + std::string(kRot);
const std::string kFrameNegative = "fr -3";
const std::string kTsOutsideDay = "ts 90000.5";
const std::string kTs2Usec = "ts2 1717666523 1000000 4380";
const std::string kHugeBlock = "6d 1 [0 1.000][" + [] {
  std::string s;
  for (int i = 0; i < 100; ++i) s += "1 ";
  return s;
}() + "]" + kRot;

INSTANTIATE_TEST_SUITE_P(
    Variants, DTrackMalformed,
    ::testing::Values(BadLine{kBodyTruncated.c_str(), EParseError::Syntax, "BodyTruncated"},
                      BadLine{kBodyNan.c_str(), EParseError::NonFinite, "BodyNan"},
                      BadLine{kBodyInf.c_str(), EParseError::NonFinite, "BodyInf"},
                      BadLine{kBodyHuge.c_str(), EParseError::NonFinite, "BodyHuge"},
                      BadLine{kBodyComma.c_str(), EParseError::BadNumber, "BodyComma"},
                      BadLine{kBodyCountTooLarge.c_str(), EParseError::MissingBlock, "BodyCountTooLarge"},
                      BadLine{kBodyZeroRot.c_str(), EParseError::ZeroRotation, "BodyZeroRot"},
                      BadLine{kBodySkewRot.c_str(), EParseError::BadRotation, "BodySkewRot"},
                      BadLine{kBodyMirror.c_str(), EParseError::BadRotation, "BodyMirror"},
                      BadLine{kBodyDuplicate.c_str(), EParseError::BadValue, "BodyDuplicate"},
                      BadLine{kBodyQuality.c_str(), EParseError::BadValue, "BodyQuality"},
                      BadLine{kBodyNegCount.c_str(), EParseError::BadCount, "BodyNegCount"},
                      BadLine{kBodyTextCount.c_str(), EParseError::BadNumber, "BodyTextCount"},
                      BadLine{kBodyNoBracket.c_str(), EParseError::Syntax, "BodyNoBracket"},
                      BadLine{kBodyNestedBracket.c_str(), EParseError::Syntax, "BodyNestedBracket"},
                      BadLine{kBodyFloatId.c_str(), EParseError::BadNumber, "BodyFloatId"},
                      BadLine{kBodyMissingRot.c_str(), EParseError::MissingBlock, "BodyMissingRot"},
                      BadLine{kHandSixFingers.c_str(), EParseError::BadCount, "HandSixFingers"},
                      BadLine{kHandZeroFingerRot.c_str(), EParseError::ZeroRotation, "HandZeroFingerRot"},
                      BadLine{kHandMissingFinger.c_str(), EParseError::MissingBlock, "HandMissingFinger"},
                      BadLine{kHandBadSide.c_str(), EParseError::BadValue, "HandBadSide"},
                      BadLine{kFlystickButtons.c_str(), EParseError::BadCount, "FlystickButtons"},
                      BadLine{kFlystickAnalogsMissing.c_str(), EParseError::MissingBlock, "FlystickAnalogsMissing"},
                      BadLine{kFlystickWordTooBig.c_str(), EParseError::BadValue, "FlystickWordTooBig"},
                      BadLine{kHumanJoints.c_str(), EParseError::BadCount, "HumanJoints"},
                      BadLine{kInertialState.c_str(), EParseError::BadValue, "InertialState"},
                      BadLine{kTs2Usec.c_str(), EParseError::BadValue, "Ts2Usec"},
                      BadLine{kHugeBlock.c_str(), EParseError::BadCount, "HugeBlock"}),
    [](const ::testing::TestParamInfo<BadLine>& info) { return std::string(info.param.name); });

TEST(DTrackParser, FrameCounterAndTimestampRange) {
  DTrackParser p;
  DTrackFrame f;
  EXPECT_EQ(p.Parse(kFrameNegative + "\r\n" + kTsOutsideDay + "\r\n", &f), 2);
  EXPECT_FALSE(f.Has(ELine::Fr));
  EXPECT_FALSE(f.Has(ELine::Ts));
  EXPECT_EQ(ErrorCount(p, EParseError::BadValue), 2);
}

TEST(DTrackParser, TruncatedLineDoesNotSwallowTheNextOne) {
  // section 7: the SDK's '[' search ran into the next line
  const std::string packet = "6d 2 [0 1.000][325.412 -112.094 1604.875\r\n" +
                             std::string("6df2 1 1 [0 1.000 2 1][1 2 3]") + kRot + "[1 0.5]\r\n";
  DTrackParser p;
  DTrackFrame f;
  EXPECT_EQ(p.Parse(packet, &f), 1);
  EXPECT_FALSE(f.Has(ELine::Body6d));
  ASSERT_EQ(f.flysticks.size(), 1u);
  EXPECT_EQ(f.flysticks[0].buttons, 1u);
  EXPECT_EQ(f.flysticks[0].analogs[0], 0.5);
}

TEST(DTrackParser, ZeroMatrixIsFineOnAnUntrackedObject) {
  DTrackParser p;
  DTrackFrame f;
  EXPECT_EQ(p.Parse("6d 1 [3 -1.000][0 0 0][0 0 0 0 0 0 0 0 0]\r\n", &f), 0) << p.last_error();
  ASSERT_EQ(f.bodies.size(), 1u);
  EXPECT_FALSE(f.bodies[0].tracked());
}

TEST(DTrackParser, OversizedDatagramIsRefusedWhole) {
  DTrackParser p(ParseOptions{1000});
  DTrackFrame f;
  std::string big = ReadPacket("a_bodies_markers.txt");
  while (big.size() <= 1000) big += "xyz 1 [padding]\r\n";
  EXPECT_EQ(p.Parse(big, &f), 1);
  EXPECT_EQ(ErrorCount(p, EParseError::Oversized), 1);
  EXPECT_EQ(f.present, 0u);
  EXPECT_TRUE(f.bodies.empty());
  EXPECT_EQ(p.Parse(ReadPacket("a_bodies_markers.txt"), &f), 0);
  EXPECT_EQ(f.bodies.size(), 2u);
}

TEST(DTrackParser, RepeatedLineTypeKeepsTheLastGoodOne) {
  DTrackParser p;
  DTrackFrame f;
  EXPECT_EQ(p.Parse("3d 1 [1 1.0][1 1 1]\r\n3d 1 [2 1.0][2 2 2]\r\n3d 1 [3 1.0][nan 3 3]\r\n", &f), 1);
  EXPECT_EQ(p.stats().duplicate_lines, 2u);
  ASSERT_EQ(f.markers.size(), 1u);
  EXPECT_EQ(f.markers[0].id, 2);
}

TEST(DTrackParser, OldFlystickHatSwitchAndTools) {
  DTrackParser p;
  DTrackFrame f;
  const std::string packet = "6df 1 [0 1.000 161][1 2 3 0 0 0]" + std::string(kRot) + "\r\n6dmt 1 [0 -1.000 3][0 0 0]" +
                             "[0 0 0 0 0 0 0 0 0]\r\n6dmtr 2 1 [1 1.000][5 6 7]" + kRot + "\r\n";
  EXPECT_EQ(p.Parse(packet, &f), 0) << p.last_error();
  ASSERT_EQ(f.flysticks.size(), 1u);
  EXPECT_EQ(f.flysticks[0].buttons, 161u);
  EXPECT_EQ(f.flysticks[0].analogs[0], -1.0);  // 0x20
  EXPECT_EQ(f.flysticks[0].analogs[1], 0.0);
  EXPECT_EQ(f.flysticks[0].buttons & 0x80, 0x80u);
  ASSERT_EQ(f.tools.size(), 1u);
  EXPECT_EQ(f.tools[0].buttons, 3u);
  ASSERT_EQ(f.tool_refs.size(), 1u);
  EXPECT_EQ(f.cal_tool_refs, 2);
  EXPECT_EQ(f.tool_refs[0].position, Vec3(5, 6, 7));
}

TEST(DTrackParser, HumanJointsAndCovariance) {
  DTrackParser p;
  DTrackFrame f;
  std::string cov = "[";
  for (int i = 1; i <= 21; ++i) cov += std::to_string(i) + ".5e-3 ";
  cov += "]";
  const std::string packet = "6dj 2 1 [0 2][0 1.000][1 2 3 10 20 30]" + std::string(kRot) + "[1 -1.000][0 0 0 0 0 0]" +
                             "[0 0 0 0 0 0 0 0 0]\r\n6dcov 1 [0 1 2 3]" + cov + "\r\n";
  EXPECT_EQ(p.Parse(packet, &f), 0) << p.last_error();
  ASSERT_EQ(f.humans.size(), 1u);
  EXPECT_EQ(f.humans[0].num_joints, 2);
  ASSERT_EQ(f.human_joints.size(), 2u);
  EXPECT_EQ(f.human_joints[0].angles_deg, Vec3(10, 20, 30));
  EXPECT_EQ(f.cal_humans, 2);
  ASSERT_EQ(f.covariances.size(), 1u);
  EXPECT_EQ(f.covariances[0].upper[20], 21.5e-3);
}

// every truncation and many byte flips of every example packet: no crash, no
// non-finite value kept, errors only ever counted
TEST(DTrackParser, TruncationsAndByteFlipsNeverCorrupt) {
  const char* files[] = {"a_bodies_markers.txt", "b_untracked.txt", "c_right_hand_3.txt", "d_ts2_left_hand_5.txt",
                         "e_other_types.txt"};
  DTrackParser p;
  DTrackFrame f;
  std::mt19937 rng(7);
  const char alphabet[] = "0123456789.-+e[] \r\n\0xnaif";
  for (const char* name : files) {
    const std::string packet = ReadPacket(name);
    for (size_t n = 0; n <= packet.size(); ++n) {
      p.Parse(packet.data(), n, &f);
      ASSERT_TRUE(AllFinite(f)) << name << " truncated at " << n;
    }
    for (int k = 0; k < 2000; ++k) {
      std::string m = packet;
      for (int j = 0; j < 3; ++j) m[rng() % m.size()] = alphabet[rng() % (sizeof(alphabet) - 1)];
      p.Parse(m, &f);
      for (const Body6d& b : f.bodies) {
        ASSERT_TRUE(b.position.allFinite());
        if (b.tracked()) {
          ASSERT_NEAR(std::abs(b.rotation.determinant()), 1.0, 0.05);
        }
      }
      for (const Hand& h : f.hands) ASSERT_LE(h.num_fingers, 5);
    }
  }
  EXPECT_GT(p.stats().TotalErrors(), 0u);
}

}  // namespace
}  // namespace gs::tracking
