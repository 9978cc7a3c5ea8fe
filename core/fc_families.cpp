#include "core/fc_families.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace gs {

namespace {

using Mat36 = Eigen::Matrix<double, 3, 6>;

// Rigid bodies and contacts between them (body -1: the ground), assembled into
// W = S H M^-1 H~^T S and q = S (H v_free + gap e_N).
class RigidScene {
 public:
  explicit RigidScene(uint64_t seed) : rng_(seed) {}

  int AddBody(const Vec3& centre, double mass, const Vec3& inertia, const Vec6& v_free) {
    Vec6 minv;
    minv << Vec3::Constant(1.0 / mass), inertia.cwiseInverse();
    bodies_.push_back({centre, minv, v_free});
    return static_cast<int>(bodies_.size()) - 1;
  }

  /// Contact at `point` whose normal force pushes body `a` along n and body `b`
  /// along -n; `tilt`: the angle by which H~'s frame differs from H's.
  void AddContact(const Vec3& point, const Vec3& n, int a, int b, double mu, double gap, double scale,
                  double tilt) {
    Mat3 frame;
    const Vec3 t0 = AnyPerpendicular(n);
    const double turn = Uniform(0.0, 2.0 * M_PI);
    const Vec3 t1 = std::cos(turn) * t0 + std::sin(turn) * n.cross(t0);
    frame.row(0) = n;
    frame.row(1) = t1;
    frame.row(2) = n.cross(t1);
    const Vec3 axis = Vec3(Uniform(-1, 1), Uniform(-1, 1), Uniform(-1, 1)).normalized();
    const Mat3 frame_tilde = frame * Eigen::AngleAxisd(tilt, axis).toRotationMatrix();
    Contact c{{}, mu, gap, scale};
    for (const auto& [body, sign] : {std::pair<int, double>{a, 1.0}, std::pair<int, double>{b, -1.0}}) {
      if (body < 0) continue;
      Mat36 J;
      J.leftCols<3>().setIdentity();
      J.rightCols<3>() = -Skew(point - bodies_[body].centre);
      c.sides.push_back({body, sign * frame * J, sign * frame_tilde * J});
    }
    contacts_.push_back(c);
  }

  double Uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
  std::mt19937_64& Rng() { return rng_; }
  const Vec3& Centre(int body) const { return bodies_[body].centre; }

  FcProblem Assemble() const {
    FcProblem p;
    p.contacts = static_cast<int>(contacts_.size());
    const int m = 3 * p.contacts;
    p.q.setZero(m);
    p.mu.resize(p.contacts);
    std::vector<std::vector<int>> by_body(bodies_.size());
    for (int c = 0; c < p.contacts; ++c) {
      const Contact& k = contacts_[c];
      Vec3 u(k.gap, 0.0, 0.0);
      for (const Side& s : k.sides) {
        u += s.h * bodies_[s.body].v_free;
        by_body[s.body].push_back(c);
      }
      p.q.segment<3>(3 * c) = k.scale * u;
      p.mu[c] = k.mu;
    }
    std::vector<Eigen::Triplet<double>> trip;
    for (size_t b = 0; b < bodies_.size(); ++b)
      for (int c : by_body[b])
        for (int d : by_body[b]) AddBlock(static_cast<int>(b), c, d, &trip);
    p.W.resize(m, m);
    p.W.setFromTriplets(trip.begin(), trip.end());  // sums the blocks of bodies shared by c and d
    p.W.makeCompressed();
    return p;
  }

 private:
  struct Body {
    Vec3 centre;
    Vec6 minv, v_free;
  };
  struct Side {
    int body;
    Mat36 h, h_tilde;
  };
  struct Contact {
    std::vector<Side> sides;
    double mu, gap, scale;
  };

  void AddBlock(int body, int c, int d, std::vector<Eigen::Triplet<double>>* trip) const {
    const Contact &kc = contacts_[c], &kd = contacts_[d];
    for (const Side& sc : kc.sides) {
      if (sc.body != body) continue;
      for (const Side& sd : kd.sides) {
        if (sd.body != body) continue;
        const Mat3 blk = kc.scale * kd.scale * sc.h * bodies_[body].minv.asDiagonal() * sd.h_tilde.transpose();
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) trip->emplace_back(3 * c + i, 3 * d + j, blk(i, j));
      }
    }
  }

  std::mt19937_64 rng_;
  std::vector<Body> bodies_;
  std::vector<Contact> contacts_;
};

Vec3 BoxInertia(double mass, const Vec3& half) {
  const Vec3 s = (2.0 * half).cwiseAbs2();
  return mass / 12.0 * Vec3(s[1] + s[2], s[0] + s[2], s[0] + s[1]);
}

// free velocity over one 10 ms step: gravity plus a random drift and spin
Vec6 FallingVelocity(RigidScene& s, double drift, double spin) {
  Vec6 v;
  v << drift * s.Uniform(-1, 1), drift * s.Uniform(-1, 1), -9.81e-2 + drift * s.Uniform(-1, 1),
      spin * s.Uniform(-1, 1), spin * s.Uniform(-1, 1), spin * s.Uniform(-1, 1);
  return v;
}

// a point on face `face` (0..5: -x, +x, -y, +y, -z, +z) of a box, and the face's inward normal
std::pair<Vec3, Vec3> PointOnFace(RigidScene& s, const Vec3& centre, const Vec3& half, int face) {
  const int axis = face / 2;
  const double side = (face & 1) ? 1.0 : -1.0;
  Vec3 local(s.Uniform(-0.9, 0.9) * half[0], s.Uniform(-0.9, 0.9) * half[1], s.Uniform(-0.9, 0.9) * half[2]);
  local[axis] = side * half[axis];
  Vec3 inward = Vec3::Zero();
  inward[axis] = -side;
  return {centre + local, inward};
}

// a box stack's four corner contacts of `upper` on `lower` (-1: the ground)
void CornerContacts(RigidScene& s, int upper, int lower, double half, double mu_lo, double mu_hi) {
  for (int k = 0; k < 4; ++k) {
    const Vec3 corner = s.Centre(upper) + Vec3((k & 1) ? half : -half, (k & 2) ? half : -half, -half);
    const Vec3 n = Vec3(0.05 * s.Uniform(-1, 1), 0.05 * s.Uniform(-1, 1), 1.0).normalized();
    s.AddContact(corner, n, upper, lower, s.Uniform(mu_lo, mu_hi), 0.0, 1.0, 0.0);
  }
}

}  // namespace

FcProblem GrippedBodyProblem(int contacts, uint64_t seed) { return GrippedBodyProblem(contacts, seed, GrippedBody()); }

FcProblem GrippedBodyProblem(int contacts, uint64_t seed, const GrippedBody& g) {
  RigidScene s(seed);
  const Vec3 half(0.03, 0.02, 0.05);
  const double mass = 0.2;
  const int body = s.AddBody(Vec3::Zero(), mass, BoxInertia(mass, half), FallingVelocity(s, g.drift, g.spin));
  contacts = std::max(contacts, 7);
  // five patches: a palm under the box, four fingertips on its sides
  const int faces[5] = {4, 0, 1, 2, 3};
  std::pair<Vec3, Vec3> patch[5];
  for (int k = 0; k < 5; ++k) patch[k] = PointOnFace(s, Vec3::Zero(), half, faces[k]);
  for (int c = 0; c < contacts; ++c) {
    const int k = c % 5, axis = faces[k] / 2;
    const double w = g.patch_radius;
    Vec3 point = patch[k].first + Vec3(s.Uniform(-w, w), s.Uniform(-w, w), s.Uniform(-w, w));
    point[axis] = patch[k].first[axis];
    const Vec3 n = (patch[k].second + g.normal_spread * Vec3(s.Uniform(-1, 1), s.Uniform(-1, 1), s.Uniform(-1, 1)))
                       .normalized();
    const double gap = s.Uniform(0.0, 1.0) < 0.1 ? s.Uniform(0.0, 1e-3) : 0.0;
    const double scale = std::sqrt(std::pow(g.diagonal_spread, s.Uniform(0.0, 1.0)));
    s.AddContact(point, n, body, -1, s.Uniform(g.mu_lo, g.mu_hi), gap, scale, g.tilt);
  }
  return s.Assemble();
}

FcProblem MassRatioStackProblem(int boxes, double ratio, uint64_t seed) {
  RigidScene s(seed);
  const double half = 0.05;
  boxes = std::max(boxes, 1);
  for (int k = 0; k < boxes; ++k) {
    const double mass = boxes > 1 ? std::pow(ratio, static_cast<double>(k) / (boxes - 1)) : 1.0;
    s.AddBody(Vec3(0, 0, half * (2 * k + 1)), mass, BoxInertia(mass, Vec3::Constant(half)),
              FallingVelocity(s, 0.02, 0.3));
  }
  for (int k = 0; k < boxes; ++k) CornerContacts(s, k, k - 1, half, 0.1, 1.0);
  return s.Assemble();
}

FcProblem PileProblem(int bodies, double mu_lo, double mu_hi, uint64_t seed) {
  RigidScene s(seed);
  bodies = std::max(bodies, 1);
  const int width = std::max(1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(bodies)))));
  const double half = 0.05;
  std::vector<int> prev, cur;
  for (int b = 0; b < bodies; ++b) {
    const int layer = b / width, slot = b % width;
    if (slot == 0) {
      prev = cur;
      cur.clear();
    }
    const double mass = std::exp(s.Uniform(std::log(0.3), std::log(3.0)));
    const Vec3 centre(2.0 * half * slot + (layer % 2) * half, 0.3 * half * s.Uniform(-1, 1),
                      half * (1.6 * layer + 1));
    const int id = s.AddBody(centre, mass, BoxInertia(mass, Vec3::Constant(half)), FallingVelocity(s, 0.05, 0.5));
    cur.push_back(id);
    const int supports = layer == 0 ? 1 : 1 + static_cast<int>(s.Rng()() % 3);
    for (int k = 0; k < supports; ++k) {
      const int below = layer == 0 ? -1 : prev[std::min<int>(prev.size() - 1, std::max(0, slot + k - 1))];
      const int points = 1 + static_cast<int>(s.Rng()() % 3);
      for (int j = 0; j < points; ++j) {
        const Vec3 tilt(s.Uniform(-0.4, 0.4), s.Uniform(-0.4, 0.4), 0.0);
        const Vec3 n = (Vec3::UnitZ() + tilt).normalized();
        const Vec3 point = centre + Vec3(s.Uniform(-half, half), s.Uniform(-half, half), -half);
        s.AddContact(point, n, id, below, s.Uniform(mu_lo, mu_hi), 0.0, 1.0, 0.0);
      }
    }
  }
  return s.Assemble();
}

FcProblem ConeProblem(double mu, uint64_t seed) {
  RigidScene s(seed);
  const double half = 0.05;
  for (int k = 0; k < 3; ++k) {
    Vec6 v = FallingVelocity(s, 0.02, 0.3);
    v[0] += 0.05 * (k + 1);  // pushed sideways, the top the most
    s.AddBody(Vec3(0, 0, half * (2 * k + 1)), 1.0, BoxInertia(1.0, Vec3::Constant(half)), v);
  }
  for (int k = 0; k < 3; ++k) CornerContacts(s, k, k - 1, half, mu, mu);
  return s.Assemble();
}

std::vector<FcFamilyCase> FcFamilySuite(int seeds, bool quick) {
  std::vector<FcFamilyCase> out;
  for (uint64_t seed = 1; seed <= static_cast<uint64_t>(std::max(seeds, 1)); ++seed) {
    const std::string s = "_s" + std::to_string(seed);
    for (int n : {12, 24, 48}) out.push_back({"gripped_" + std::to_string(n) + s, GrippedBodyProblem(n, seed)});
    for (int n : {4, 10})
      out.push_back({"mass_ratio_" + std::to_string(n) + "x1000" + s, MassRatioStackProblem(n, 1000.0, seed)});
    out.push_back({"pile_60" + s, PileProblem(60, 0.1, 1.0, seed)});
    if (!quick) out.push_back({"pile_400" + s, PileProblem(400, 0.1, 1.0, seed)});
    out.push_back({"cone_mu1e-3" + s, ConeProblem(1e-3, seed)});
    out.push_back({"cone_mu10" + s, ConeProblem(10.0, seed)});
  }
  return out;
}

}  // namespace gs
