#include "tracking/synthetic_hand.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace gs::tracking {
namespace {

struct Key {
  double t, open, approach, lift;  // open: 1 open, 0 closed; mm back along the palm's normal and up from the grasp
};

// the open factor, approach and lift at time t, smoothstepped between keys
void Interpolate(const Key* keys, int n, double t, double* open, double* approach, double* lift) {
  const Key* k = &keys[n - 1];
  if (t <= keys[0].t) k = &keys[0];
  for (int i = 1; i < n && k == &keys[n - 1]; ++i) {
    if (t > keys[i].t) continue;
    double s = (t - keys[i - 1].t) / (keys[i].t - keys[i - 1].t);
    s = s * s * (3 - 2 * s);  // smoothstep: no velocity jumps at the keys
    const Key& a = keys[i - 1];
    const Key& b = keys[i];
    *open = a.open + s * (b.open - a.open);
    *approach = a.approach + s * (b.approach - a.approach);
    *lift = a.lift + s * (b.lift - a.lift);
    return;
  }
  *open = k->open;
  *approach = k->approach;
  *lift = k->lift;
}

// Reach open, close, settle, lift, hold, release, back off: the approach along the
// palm's normal (up for a grasp from above), the lift up. Released, a hand from above
// rises to reach_mm over the grasp; one from the side backs off reach_mm, still lifted.
void Phase(const SyntheticHand& h, double t, double* open, double* approach, double* lift) {
  const double r = h.reach_mm, l = h.lift_mm;
  if (h.whole_hand) {
    const double e = h.hold_s, back = h.side_grasp && !h.pinch ? r : r - l;
    const Key keys[] = {{0.0, 1, r, 0.0},     {0.2, 1, r, 0.0},     {0.8, 1, 0.0, 0.0},
                        {1.2, 0, 0.0, 0.0},   {1.4, 0, 0.0, 0.0},   {2.0, 0, 0.0, l},
                        {2.0 + e, 0, 0.0, l}, {2.3 + e, 1, 0.0, l}, {2.8 + e, 1, back, l}};
    Interpolate(keys, sizeof(keys) / sizeof(keys[0]), t, open, approach, lift);
    return;
  }
  const Key keys[] = {{0.0, 1, r, 0.0},   {0.2, 1, r, 0.0},   {0.8, 1, 0.0, 0.0},
                      {1.1, 0, 0.0, 0.0}, {1.3, 0, 0.0, 0.0}, {1.9, 0, 0.0, l},
                      {2.3, 0, 0.0, l},   {2.5, 1, 0.0, l},   {h.duration_s, 1, r - l, l}};
  Interpolate(keys, sizeof(keys) / sizeof(keys[0]), t, open, approach, lift);
}

// flexions (root, middle-inner, outer-middle) of a planar two-phalanx chain whose
// middle joint reaches p (x, z of the root frame) and whose outer phalanx then
// points at `outer_angle` from the root's x toward its z
Vec3 ReachFlexions(const HandFingerModel& f, const Vec3& p, double outer_angle) {
  const double li = f.length[2], lm = f.length[1];
  const double d2 = p.x() * p.x() + p.z() * p.z();
  const double c = std::clamp((d2 - li * li - lm * lm) / (2.0 * li * lm), -1.0, 1.0);
  const double q1 = std::acos(c);
  const double q0 = std::atan2(p.z(), p.x()) - std::atan2(lm * std::sin(q1), li + lm * std::cos(q1));
  return Vec3(q0, q1, outer_angle - q0 - q1);
}

void AppendMatrix(std::string* s, const Mat3& R) {
  char buf[160];
  // column by column: b0 b1 b2 is the first column
  std::snprintf(buf, sizeof(buf), "[%.6f %.6f %.6f %.6f %.6f %.6f %.6f %.6f %.6f]", R(0, 0), R(1, 0), R(2, 0), R(0, 1),
                R(1, 1), R(2, 1), R(0, 2), R(1, 2), R(2, 2));
  *s += buf;
}

}  // namespace

SyntheticHand SyntheticHand::WholeHand(int fingers, double hold_s) {
  SyntheticHand h;
  h.whole_hand = true;
  h.fingers = fingers == 3 ? 3 : 5;
  h.hold_s = hold_s;
  h.duration_s = 2.8 + hold_s;
  return h;
}

namespace {

// where a whole-hand grasp puts the box and the thumb's middle joint, in the hand frame
struct Grasp {
  Vec3 box;                     ///< the box's centre
  Vec3 thumb;                   ///< the thumb's middle joint, closed
  double half = 0.0, height = 0.0, squeeze = 0.0;  ///< half extents along the hand's x and z
  bool shifted = false;         ///< moved back within the thumb's reach
  double Lid() const { return box.z() - height; }
};

// the thumb's plane (its root frame's x-z plane) at the hand frame's x: its y
double ThumbPlaneY(const HandFingerModel& th, double x) {
  const Vec3 along = th.root.R.col(0);
  return th.root.t.y() + (x - th.root.t.x()) * along.y() / along.x();
}

// the largest x (hand frame) at which the thumb's middle joint reaches depth z in its
// plane: its two inner phalanges stretched from its root
double ThumbReach(const HandFingerModel& th, double z) {
  const Vec3 along = th.root.R.col(0);
  const double k = along.y() / along.x(), reach = th.length[1] + th.length[2], dz = z - th.root.t.z();
  return th.root.t.x() + std::sqrt(std::max(0.0, reach * reach - dz * dz) / (1.0 + k * k));
}

// Power grasp: the lid 1 mm under the palm, the far face where the fingers' middle
// joints (x = 9.5 cm) put their phalanges `squeeze` into it, unless the thumb's
// middle joint could not reach the near face there: then the box goes back toward
// the thumb (`shifted`; the fingers must then wrap it). Pinch: the lid 5 mm under
// the palm, the box centred between the thumb's and the index's pads. The thumb's
// middle joint lies in its plane (the root frame's x-z plane), `squeeze` into the
// near face, 4 mm under the lid (a curved object: a quarter of its half height
// above its centre; WrapThumb finds its surface there).
Grasp GraspGeometry(const HandModel& m, bool pinch, double half, double height, double squeeze, bool curved) {
  Grasp g;
  g.half = half;
  g.height = height;
  g.squeeze = squeeze;
  const double palm = m.palm.t.z() + 0.5 * m.palm_size.z();
  g.box = pinch ? Vec3(0.05, 0.0, palm + 5e-3 + height)
                : Vec3(0.095 - half - m.finger[1].radius + squeeze, 0.0, palm + 1e-3 + height);
  const HandFingerModel& th = m.finger[0];
  const double z = pinch ? g.Lid() + 8e-3 : (curved ? g.box.z() - 0.25 * height : g.Lid() + 4e-3);
  double x = g.box.x() - half - th.radius + squeeze;
  const double reach = ThumbReach(th, z);
  if (!pinch && x > reach) {
    g.box.x() -= x - reach;
    x = reach;
    g.shifted = true;
  }
  const double y = ThumbPlaneY(th, x);
  if (pinch) g.box.y() = 0.5 * (y + m.finger[1].root.t.y());
  g.thumb = Vec3(x, y, z);
  return g;
}

// The hand's orientation for a grasp: palm down, fingers along the room's +x (from
// above); or palm toward the room's +x, fingers along -y and the thumb up (from the side)
Mat3 GraspRotation(bool side) {
  if (!side) return Eigen::AngleAxisd(M_PI, Vec3::UnitX()).toRotationMatrix();
  Mat3 R;
  R.col(0) = -Vec3::UnitY();
  R.col(1) = -Vec3::UnitZ();
  R.col(2) = Vec3::UnitX();
  return R;
}

// the hand's pose (room, m) that puts the grasp's box centre at `center`, `reach`
// back along the palm's normal (the approach) and `lift` up
Pose GraspHandPose(const Grasp& g, bool side, const Vec3& center, double reach, double lift) {
  Pose hand;
  hand.R = GraspRotation(side);
  hand.t = center - reach * hand.R.col(2) + Vec3(0, 0, lift) - hand.R * g.box;
  return hand;
}

// how far a phalanx's capsule (axis a-b, radius r) goes into the object (m; negative:
// its gap), the axis sampled at 9 points; `body` is the object's pose in the chain's frame
double CapsuleDepth(const ShapeDesc& shape, const Pose& body, const Vec3& a, const Vec3& b, double r) {
  double least = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= 8; ++i) {
    const Vec3 p = a + (i / 8.0) * (b - a);
    least = std::min(least, AnalyticDistance(shape, body.ApplyInverse(p)));
  }
  return r - least;
}

// Finger f wrapped on the object (`body`: its pose in the hand frame): from the open
// flexions, each joint, root first, closes until a phalanx it moves presses `squeeze`
// into the surface (or the joint reaches its anatomical range)
Vec3 WrapFinger(const HandModel& m, int f, const ShapeDesc& shape, const Pose& body, const Vec3& open, double squeeze) {
  constexpr double kMax[3] = {1.6, 1.8, 1.5};  // inside the scene's limits (scene/scene_hand.cpp)
  constexpr double kStep = 0.004;              // rad: 0.2 mm at a 5 cm lever
  Vec3 q = open;
  for (int j = 0; j < 3; ++j) {
    for (;;) {
      const FingerChain c = ChainFromTip(PoseFinger(m, f, Pose(), q));
      double depth = -std::numeric_limits<double>::infinity();
      // joint j (root, middle-inner, outer-middle) moves phalanges 2 - j .. 0 (inner .. outer)
      for (int k = 0; k <= 2 - j; ++k)
        depth = std::max(depth, CapsuleDepth(shape, body, c.joint[k + 1], c.joint[k], m.finger[f].radius));
      if (!(depth < squeeze) || q[j] >= kMax[j]) break;
      q[j] = std::min(q[j] + kStep, kMax[j]);
    }
  }
  return q;
}

// The thumb's middle joint on the object's near side, in its plane at the grasp's
// depth (GraspGeometry), `squeeze` into it (hand frame); the grasp's point when the
// plane misses the object there
Vec3 WrapThumb(const HandModel& m, const Grasp& g, const ShapeDesc& shape, const Pose& body) {
  const HandFingerModel& th = m.finger[0];
  const double z = g.thumb.z();
  const auto at = [&](double x) { return Vec3(x, ThumbPlaneY(th, x), z); };
  const auto gap = [&](double x) { return AnalyticDistance(shape, body.ApplyInverse(at(x))) - (th.radius - g.squeeze); };
  double out = g.box.x() - g.half - th.radius - 0.02, in = g.box.x();
  if (!(gap(out) > 0.0 && gap(in) < 0.0)) return g.thumb;
  for (int i = 0; i < 40; ++i) (gap(0.5 * (out + in)) > 0.0 ? out : in) = 0.5 * (out + in);
  return at(0.5 * (out + in));
}

bool Curved(EShape s) {
  return s == EShape::Sphere || s == EShape::Ellipsoid || s == EShape::Capsule || s == EShape::Cylinder;
}

// the pose mirrored in the room's y about the plane y = y0 (frames conjugated: M R M is a rotation)
Pose MirroredY(const Pose& p, double y0) {
  const Mat3 mirror = Vec3(1.0, -1.0, 1.0).asDiagonal();
  return Pose{mirror * p.R * mirror, Vec3(p.t.x(), 2.0 * y0 - p.t.y(), p.t.z())};
}

// the four fingers hook over the far face (or wrap the object: `wrapped`); open, they stretch forward
void PowerFingers(const HandModel& m, const Pose& hand, double open, const Vec3* wrapped, TrackedFinger* out) {
  const Vec3 opened = SyntheticOpenFlexion();
  for (int f = 1; f < m.fingers; ++f) {
    const Vec3 closed = wrapped ? wrapped[f] : Vec3(0.0, 0.5 * M_PI, 0.0);
    out[f] = PoseFinger(m, f, hand, open * opened + (1.0 - open) * closed);
  }
}

// the index's outer phalanx on the far face, its middle joint 8 mm over the lid; the
// other fingers stay stretched above the box
void PinchFingers(const HandModel& m, const Pose& hand, const Grasp& g, double open, TrackedFinger* out) {
  for (int f = 2; f < m.fingers; ++f) out[f] = PoseFinger(m, f, hand, Vec3(0.0, 0.2, 0.1));
  const HandFingerModel& ix = m.finger[1];
  const Vec3 closed(g.box.x() + g.half + ix.radius - g.squeeze, ix.root.t.y(), g.Lid() + 8e-3);
  const Vec3 dip = closed + open * Vec3(0.02, 0.0, -0.004);
  out[1] = PoseFinger(m, 1, hand, ReachFlexions(ix, ix.root.ApplyInverse(dip), (1.0 - open) * 0.5 * M_PI + open * 0.35));
}

// the thumb's middle joint on the near face (g.thumb), its outer phalanx down along it
TrackedFinger Thumb(const HandModel& m, const Pose& hand, const Grasp& g, bool pinch, double open) {
  const HandFingerModel& th = m.finger[0];
  const Vec3 ip_open = pinch ? g.thumb + Vec3(-0.03, 0.0, -0.006) : Vec3(-0.015, 0.0, g.Lid() - 6e-3);
  const Vec3 ip = open * ip_open + (1.0 - open) * g.thumb;
  return PoseFinger(m, 0, hand, ReachFlexions(th, th.root.ApplyInverse(ip), (1.0 - open) * 0.5 * M_PI + open * 0.35));
}

}  // namespace

namespace {

HandModel ScaledHand(const SyntheticHand& h) {
  HandModel m = AverageAdultHand(h.fingers, true);
  for (HandFingerModel& f : m.finger) {
    for (double& l : f.length) l *= h.size_scale;
    f.radius *= h.size_scale;
  }
  return m;
}

// the grasp of the hand's object: from above, its x and z extents; from the side
// (the hand's x along the room's -y, its z along x), its y and x ones
Grasp GraspFor(const SyntheticHand& h, const HandModel& m, bool curved) {
  const bool side = h.side_grasp && !h.pinch;
  return GraspGeometry(m, h.pinch, 1e-3 * (side ? h.box_half_width_mm : h.box_half_mm),
                       1e-3 * (side ? h.box_half_mm : h.box_half_height_mm), 1e-3 * h.squeeze_mm, curved);
}

}  // namespace

void SyntheticHand::AimAt(const GraspObject& o) {
  const Vec3 center = 0.5 * (o.low + o.high), half = 0.5 * (o.high - o.low);
  box_center_mm = 1e3 * center;
  box_half_mm = 1e3 * half.x();
  box_half_width_mm = 1e3 * half.y();
  box_half_height_mm = 1e3 * half.z();
  object = o;
  AimTips(o);
  const bool curved = Curved(o.shape.type);
  side_grasp = whole_hand && !pinch && curved && half.z() > 1.2 * std::max(half.x(), half.y());
  const HandModel m = ScaledHand(*this);
  Grasp g = GraspFor(*this, m, curved);
  wrap = whole_hand && !pinch && (curved || g.shifted);
  if (!wrap) return;
  // the right hand's grasp (a left one is its mirror image: WholeHandPose), on the
  // object mirrored for a left hand
  const Pose room = right ? o.pose : MirroredY(o.pose, center.y());
  Pose body;
  for (int i = 0; i < 4; ++i) {
    // where the thumb finds the surface may lie past its reach (a curved side is
    // nearer the centre than the bounding box's): the object goes back toward it
    body = GraspHandPose(g, side_grasp, center, 0.0, 0.0).Inverse() * room;
    wrap_thumb = WrapThumb(m, g, o.shape, body);
    const double over = wrap_thumb.x() - ThumbReach(m.finger[0], wrap_thumb.z());
    if (over <= 1e-6) break;
    g.box.x() -= over;
    g.thumb.x() -= over;
  }
  wrap_box = g.box;
  const Vec3 opened = SyntheticOpenFlexion();
  for (int f = 1; f < m.fingers; ++f) wrap_flexion[f] = WrapFinger(m, f, o.shape, body, opened, g.squeeze);
}

void SyntheticHand::WholeHandPose(double t, Pose* hand, TrackedFinger* out) const {
  double open = 0, approach = 0, lift = 0;
  Phase(*this, t, &open, &approach, &lift);
  const HandModel m = ScaledHand(*this);
  const bool wrapped = wrap && !pinch;
  Grasp g = GraspFor(*this, m, wrapped && Curved(object.shape.type));
  if (wrapped) {
    g.box = wrap_box;
    g.thumb = wrap_thumb;
  }
  *hand = GraspHandPose(g, side_grasp && !pinch, 1e-3 * box_center_mm, 1e-3 * approach, 1e-3 * lift);
  if (pinch)
    PinchFingers(m, *hand, g, open, out);
  else
    PowerFingers(m, *hand, open, wrapped ? wrap_flexion : nullptr, out);
  out[0] = Thumb(m, *hand, g, pinch, open);
  if (!right) {
    // the mirror image in the room's y about the box's centre; the hand model's left
    // hand is the right one mirrored in the hand frame's y, which this gives (the
    // chain back from a tip bends about its phalanges' y, which the mirror reverses
    // twice: the same angles give the mirrored chain)
    const double y0 = 1e-3 * box_center_mm.y();
    *hand = MirroredY(*hand, y0);
    for (int f = 0; f < fingers; ++f) out[f].tip = MirroredY(out[f].tip, y0);
  }
}

void SyntheticHand::Tips(double t, Vec3* tips) const {
  double open = 0, approach = 0, lift = 0;
  Phase(*this, t, &open, &approach, &lift);
  const double height = approach + lift;  // the fingertips come from above
  const double x = box_half_mm + tip_radius_mm - squeeze_mm + open * open_mm;
  const double z = box_center_mm.z() + height;
  const Vec3& c = box_center_mm;
  const double opened = open * open_mm;
  tips[0] = Vec3(c.x() - (tip_closed_mm[0] + opened), c.y(), z);         // thumb
  tips[1] = Vec3(c.x() + tip_closed_mm[1] + opened, c.y() + 15.0, z);    // index
  tips[2] = Vec3(c.x() + tip_closed_mm[2] + opened, c.y() - 15.0, z);    // middle
  tips[3] = Vec3(c.x() + x + 10.0, c.y() - 40.0, z + 25.0);  // ring, curled above
  tips[4] = Vec3(c.x() + x + 5.0, c.y() - 60.0, z + 35.0);   // little
}

namespace {

// How far from the object's centre along the room's x (side -1 or +1), at y and z
// off it (mm), a fingertip of radius r presses `squeeze` into its surface (mm): the
// bounding box's side when that line misses the object
double TipReach(const GraspObject& o, double side, double dy, double dz, double r, double squeeze, double half) {
  const Vec3 center = 0.5 * (o.low + o.high);
  const auto gap = [&](double s) {
    const Vec3 p = center + 1e-3 * Vec3(side * s, dy, dz);
    return 1e3 * AnalyticDistance(o.shape, o.pose.ApplyInverse(p)) - (r - squeeze);
  };
  double in = 0.0, out = half + r + 20.0;
  if (!(gap(in) < 0.0 && gap(out) > 0.0)) return half + r - squeeze;
  for (int i = 0; i < 50; ++i) (gap(0.5 * (in + out)) > 0.0 ? out : in) = 0.5 * (in + out);
  return 0.5 * (in + out);
}

}  // namespace

void SyntheticHand::AimTips(const GraspObject& o) {
  const double dy[3] = {0.0, 15.0, -15.0}, side[3] = {-1.0, 1.0, 1.0};
  for (int f = 0; f < 3; ++f)
    tip_closed_mm[f] = TipReach(o, side[f], dy[f], 0.0, tip_radius_mm, squeeze_mm, box_half_mm);
}

Pose SyntheticHand::HandPose(double t) const {
  Vec3 tips[5];
  Tips(t, tips);
  Pose p;
  p.R = (Eigen::AngleAxisd(25.0 * M_PI / 180, Vec3::UnitZ()) * Eigen::AngleAxisd(-15.0 * M_PI / 180, Vec3::UnitX()))
            .toRotationMatrix();
  p.t = (tips[0] + tips[1] + tips[2]) / 3.0 + Vec3(20.0, 0.0, 60.0);
  return p;
}

namespace {

// the gl line of a whole hand: the back of the hand and each finger's block, mm and degrees
void AppendWholeHand(const SyntheticHand& h, double t, std::string* s) {
  Pose hand;
  TrackedFinger f[kHandMaxFingers];
  h.WholeHandPose(t, &hand, f);
  const int nf = h.fingers == 3 ? 3 : 5;
  char buf[256];
  std::snprintf(buf, sizeof(buf), "gl 1 [0 1.000 %d %d][%.3f %.3f %.3f]", h.right ? 1 : 0, nf, 1e3 * hand.t.x(),
                1e3 * hand.t.y(), 1e3 * hand.t.z());
  *s += buf;
  AppendMatrix(s, hand.R);
  for (int i = 0; i < nf; ++i) {
    const Vec3 local = 1e3 * hand.ApplyInverse(f[i].tip.t);
    std::snprintf(buf, sizeof(buf), " [%.3f %.3f %.3f]", local.x(), local.y(), local.z());
    *s += buf;
    AppendMatrix(s, hand.R.transpose() * f[i].tip.R);
    const double deg = 180.0 / M_PI;
    std::snprintf(buf, sizeof(buf), "[%.3f %.3f %.3f %.3f %.3f %.3f]", 1e3 * f[i].tip_radius, 1e3 * f[i].length[0],
                  deg * f[i].angle[0], 1e3 * f[i].length[1], deg * f[i].angle[1], 1e3 * f[i].length[2]);
    *s += buf;
  }
  *s += "\r\n";
}

}  // namespace

std::string SyntheticHand::Datagram(double t, uint32_t frame) const {
  Vec3 tips[5];
  Tips(t, tips);
  const Pose hand = HandPose(t);
  const int nf = fingers == 5 ? 5 : 3;
  std::string s;
  s.reserve(1600);
  char buf[256];
  std::snprintf(buf, sizeof(buf), "fr %u\r\nts %.6f\r\n6dcal 0\r\n6d 0\r\nglcal 1\r\n", frame,
                std::fmod(43200.0 + t, 86400.0));
  s += buf;
  if (whole_hand) {
    AppendWholeHand(*this, t, &s);
    return s;
  }
  std::snprintf(buf, sizeof(buf), "gl 1 [0 1.000 1 %d][%.3f %.3f %.3f]", nf, hand.t.x(), hand.t.y(), hand.t.z());
  s += buf;
  AppendMatrix(&s, hand.R);
  static const double kParams[5][6] = {{9.5, 31.65, 24.19, 33.87, 12.044, 45.0},
                                       {8.0, 22.31, 38.522, 26.47, 41.903, 43.15},
                                       {8.0, 24.06, 33.14, 29.88, 37.416, 47.32},
                                       {7.5, 23.31, 14.01, 27.15, 17.5, 44.23},
                                       {7.0, 20.48, 19.742, 21.36, 22.085, 38.2}};
  for (int f = 0; f < nf; ++f) {
    // tips in the hand frame; the outer phalanx turned so that it is level in the room
    const Vec3 local = hand.R.transpose() * (tips[f] - hand.t);
    std::snprintf(buf, sizeof(buf), " [%.3f %.3f %.3f]", local.x(), local.y(), local.z());
    s += buf;
    AppendMatrix(&s, hand.R.transpose());
    const double* p = kParams[f];
    std::snprintf(buf, sizeof(buf), "[%.3f %.3f %.3f %.3f %.3f %.3f]", p[0], p[1], p[2], p[3], p[4], p[5]);
    s += buf;
  }
  s += "\r\n";
  return s;
}

SyntheticHand SyntheticHandFor(const TrackerConfig& c) {
  int fingers = 0;
  bool whole = false;
  for (const FingertipMap& f : c.fingertips) {
    fingers = std::max(fingers, f.finger + 1);
    whole |= f.segment != ESegment::Tip;
  }
  if (whole) {
    SyntheticHand h = SyntheticHand::WholeHand(fingers, 3.0);
    h.right = c.hand_side != 0;
    return h;
  }
  SyntheticHand h;
  h.fingers = fingers > 3 ? 5 : 3;
  return h;
}

SyntheticHand SyntheticHandFor(const TrackerConfig& c, const GraspObject& object) {
  SyntheticHand h = SyntheticHandFor(c);
  h.AimAt(object);
  return h;
}

}  // namespace gs::tracking
