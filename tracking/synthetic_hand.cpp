#include "tracking/synthetic_hand.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace gs::tracking {
namespace {

struct Key {
  double t, open, height;  // open: 1 open, 0 closed; height: mm above the grasp height
};

// the open factor and height at time t, smoothstepped between keys
void Interpolate(const Key* keys, int n, double t, double* open, double* height) {
  if (t <= keys[0].t) {
    *open = keys[0].open;
    *height = keys[0].height;
    return;
  }
  for (int i = 1; i < n; ++i) {
    if (t <= keys[i].t) {
      double s = (t - keys[i - 1].t) / (keys[i].t - keys[i - 1].t);
      s = s * s * (3 - 2 * s);  // smoothstep: no velocity jumps at the keys
      *open = keys[i - 1].open + s * (keys[i].open - keys[i - 1].open);
      *height = keys[i - 1].height + s * (keys[i].height - keys[i - 1].height);
      return;
    }
  }
  *open = keys[n - 1].open;
  *height = keys[n - 1].height;
}

// reach down open, close, settle, lift, hold, release, rise
void Phase(const SyntheticHand& h, double t, double* open, double* height) {
  if (h.whole_hand) {
    const double e = h.hold_s;
    const Key keys[] = {{0.0, 1, h.reach_mm},      {0.2, 1, h.reach_mm},      {0.8, 1, 0.0},
                        {1.2, 0, 0.0},             {1.4, 0, 0.0},             {2.0, 0, h.lift_mm},
                        {2.0 + e, 0, h.lift_mm},   {2.3 + e, 1, h.lift_mm},   {2.8 + e, 1, h.reach_mm}};
    Interpolate(keys, sizeof(keys) / sizeof(keys[0]), t, open, height);
    return;
  }
  const Key keys[] = {{0.0, 1, h.reach_mm},        {0.2, 1, h.reach_mm},        {0.8, 1, 0.0},
                      {1.1, 0, 0.0},               {1.3, 0, 0.0},               {1.9, 0, h.lift_mm},
                      {2.3, 0, h.lift_mm},         {2.5, 1, h.lift_mm},         {h.duration_s, 1, h.reach_mm}};
  Interpolate(keys, sizeof(keys) / sizeof(keys[0]), t, open, height);
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
  double half = 0.0, squeeze = 0.0;
  double Lid() const { return box.z() - half; }
};

// Power grasp: the lid 1 mm under the palm, the far face where the fingers' middle
// joints (x = 9.5 cm) put their phalanges `squeeze` into it. Pinch: the lid 5 mm under
// the palm, the box centred between the thumb's and the index's pads. The thumb's
// middle joint lies in its plane (the root frame's x-z plane), `squeeze` into the near face.
Grasp GraspGeometry(const HandModel& m, bool pinch, double half, double squeeze) {
  Grasp g;
  g.half = half;
  g.squeeze = squeeze;
  const double palm = m.palm.t.z() + 0.5 * m.palm_size.z();
  g.box = pinch ? Vec3(0.05, 0.0, palm + 5e-3 + half)
                : Vec3(0.095 - half - m.finger[1].radius + squeeze, 0.0, palm + 1e-3 + half);
  const HandFingerModel& th = m.finger[0];
  const double x = g.box.x() - half - th.radius + squeeze;
  const Vec3 along = th.root.R.col(0);
  const double y = th.root.t.y() + (x - th.root.t.x()) * along.y() / along.x();
  if (pinch) g.box.y() = 0.5 * (y + m.finger[1].root.t.y());
  g.thumb = Vec3(x, y, g.Lid() + (pinch ? 8e-3 : 4e-3));
  return g;
}

// the four fingers hook over the far face; open, they stretch forward
void PowerFingers(const HandModel& m, const Pose& hand, double open, TrackedFinger* out) {
  const Vec3 closed(0.0, 0.5 * M_PI, 0.0), opened(0.0, 0.35, 0.15);
  for (int f = 1; f < m.fingers; ++f) out[f] = PoseFinger(m, f, hand, open * opened + (1.0 - open) * closed);
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

// the thumb's middle joint on the near face, its outer phalanx down along it
TrackedFinger Thumb(const HandModel& m, const Pose& hand, const Grasp& g, bool pinch, double open) {
  const HandFingerModel& th = m.finger[0];
  const Vec3 ip_open = pinch ? g.thumb + Vec3(-0.03, 0.0, -0.006) : Vec3(-0.015, 0.0, g.Lid() - 6e-3);
  const Vec3 ip = open * ip_open + (1.0 - open) * g.thumb;
  return PoseFinger(m, 0, hand, ReachFlexions(th, th.root.ApplyInverse(ip), (1.0 - open) * 0.5 * M_PI + open * 0.35));
}

}  // namespace

void SyntheticHand::WholeHandPose(double t, Pose* hand, TrackedFinger* out) const {
  double open = 0, height = 0;
  Phase(*this, t, &open, &height);
  HandModel m = AverageAdultHand(fingers, true);
  for (HandFingerModel& f : m.finger) {
    for (double& l : f.length) l *= size_scale;
    f.radius *= size_scale;
  }
  const Grasp g = GraspGeometry(m, pinch, 1e-3 * box_half_mm, 1e-3 * squeeze_mm);
  // palm down, fingers along the room's +x, the box where the grasp wants it
  hand->R = Eigen::AngleAxisd(M_PI, Vec3::UnitX()).toRotationMatrix();
  hand->t = 1e-3 * box_center_mm + Vec3(0, 0, 1e-3 * height) - hand->R * g.box;
  if (pinch)
    PinchFingers(m, *hand, g, open, out);
  else
    PowerFingers(m, *hand, open, out);
  out[0] = Thumb(m, *hand, g, pinch, open);
  if (!right) {
    // the mirror image in the room's y: positions reflected, frames conjugated (M R M
    // is a rotation); the hand model's left hand is the right one mirrored in the
    // hand frame's y, which this gives
    const Mat3 mirror = Vec3(1.0, -1.0, 1.0).asDiagonal();
    const auto reflect = [&](Pose* p) {
      p->t = mirror * p->t;
      p->R = mirror * p->R * mirror;
    };
    reflect(hand);
    // (the chain back from a tip bends about its phalanges' y, which the mirror
    // reverses twice: the same angles give the mirrored chain)
    for (int f = 0; f < fingers; ++f) reflect(&out[f].tip);
  }
}

void SyntheticHand::Tips(double t, Vec3* tips) const {
  double open = 0, height = 0;
  Phase(*this, t, &open, &height);
  const double x = box_half_mm + tip_radius_mm - squeeze_mm + open * open_mm;
  const double z = box_center_mm.z() + height;
  const Vec3& c = box_center_mm;
  tips[0] = Vec3(c.x() - x, c.y(), z);          // thumb
  tips[1] = Vec3(c.x() + x, c.y() + 15.0, z);   // index
  tips[2] = Vec3(c.x() + x, c.y() - 15.0, z);   // middle
  tips[3] = Vec3(c.x() + x + 10.0, c.y() - 40.0, z + 25.0);  // ring, curled above
  tips[4] = Vec3(c.x() + x + 5.0, c.y() - 60.0, z + 35.0);   // little
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

}  // namespace gs::tracking
