#include "session/run_report.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/contact_jacobian.h"

namespace gs::app {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double Max(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); }

}  // namespace

// stick, slide or separating, as RecordStep counts them
enum class EContactState { Stick, Slide, Separate };
EContactState StateOf(const ContactRow& row) {
  if (row.r[0] <= 0.0) return EContactState::Separate;
  if (row.mu > 0 && row.r.tail<2>().norm() >= row.mu * row.r[0] * (1.0 - 1e-9)) return EContactState::Slide;
  return EContactState::Stick;
}

// one line of contacts.csv: a body pair's contacts in one step
struct PairTotals {
  int a = -1, b = -1;
  int contacts = 0, stick = 0, slide = 0, separate = 0;
  double fn = 0.0, ft = 0.0, before = 0.0, after = 0.0;
};

void Add(PairTotals* p, const World& w, const ContactRow& row) {
  ++p->contacts;
  const EContactState s = StateOf(row);
  (s == EContactState::Stick ? p->stick : s == EContactState::Slide ? p->slide : p->separate) += 1;
  p->fn += row.r[0];
  p->ft += row.r.tail<2>().norm();
  p->before = std::max(p->before, -row.contact.gap);
  p->after = std::max(p->after, -PostSolveGap(w, row));
}

void Cell(std::ostream& o, double v, const char* fmt) {
  char buf[40];
  std::snprintf(buf, sizeof buf, fmt, v);
  o << buf;
}

StepRecord RecordStep(const World& w) {
  StepRecord r;
  r.time = w.time;
  r.profile = w.profile;
  for (const ContactRow& row : w.rows) {
    r.normal_force += row.r[0];
    r.max_penetration = std::max(r.max_penetration, -row.contact.gap);
    const EContactState s = StateOf(row);
    (s == EContactState::Stick ? r.stick : s == EContactState::Slide ? r.slide : r.separate) += 1;
  }
  return r;
}

void WriteTimingsHeader(std::ostream& o) {
  o << "step,time_s,contacts,iterations,residual,converged,rejected,free_motion_ms,traverse_ms,"
       "interpenetration_ms,refit_ms,fill_w_rigid_ms,fill_w_deform_ms,solve_ms,constrained_motion_ms,total_ms\n";
}

void WriteTimingsRow(std::ostream& o, const World& w) {
  const StepProfile& p = w.profile;
  char line[512];
  std::snprintf(line, sizeof line, "%lld,%.6f,%d,%d,%.3e,%d,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f\n",
                static_cast<long long>(w.step_count), w.time, p.contacts, p.iterations, p.residual,
                p.converged ? 1 : 0, p.rejected ? 1 : 0, 1e3 * p.free_motion, 1e3 * p.traverse,
                1e3 * p.interpenetration, 1e3 * p.refit, 1e3 * p.fill_w_rigid, 1e3 * p.fill_w_deform,
                1e3 * p.solve, 1e3 * p.constrained_motion, 1e3 * p.total);
  o << line;
}

bool WriteSummaryJson(const std::string& dir, const std::string& summary_json, std::string* error) {
  const std::string path = (std::filesystem::path(dir) / "summary.json").string();
  const std::string tmp = path + ".part";
  {
    std::ofstream f(tmp, std::ios::binary);
    f << summary_json << "\n";
    if (!f) {
      *error = "cannot write '" + path + "'";
      return false;
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);  // whole or not at all
  if (ec) {
    *error = "cannot write '" + path + "': " + ec.message();
    return false;
  }
  return true;
}

double PostSolveGap(const World& w, const ContactRow& row) {
  Vec3 u = row.q + ArticulatedVelocity(w, row);
  for (const ContactSide& s : row.side) {
    if (s.count > 0) {
      const Body& b = w.bodies[s.body];
      Vec3 d = Vec3::Zero();
      for (int k = 0; k < s.count; ++k) d += s.w[k] * b.u_acc[s.idx[k]];
      u += s.sign * (row.frame * b.pose.Rotate(d));
    }
  }
  return u[0] - row.held_back;
}

std::string RejectText(const World& w) {
  return w.profile.reject_reason == kPassThroughReason ? PassThroughText(w) : w.profile.reject_reason;
}

std::string PassThroughText(const World& w) {
  const PassThrough& p = w.last_pass_through;
  const Body& a = w.bodies[p.body];
  const Body& b = w.bodies[p.other];
  char msg[512];
  if (b.geometry.is_plane)
    std::snprintf(msg, sizeof msg, "body '%s' passed through plane '%s' at step %lld (t = %.4f s): its centre went "
                  "%.3g mm below it", a.name.c_str(), b.name.c_str(), static_cast<long long>(p.step), p.time,
                  -1e3 * p.distance);
  else
    std::snprintf(msg, sizeof msg, "body '%s' passed through body '%s' at step %lld (t = %.4f s): the centres came "
                  "%.3g mm apart, inside the %.3g mm ball around a centre that lies within its body",
                  a.name.c_str(), b.name.c_str(), static_cast<long long>(p.step), p.time, 1e3 * p.distance,
                  1e3 * p.core);
  return msg;
}

// a body that moves under the step's forces: a free body, or one a finger carries
// (a fingertip, a whole hand's phalanx)
bool Moving(const Body& b) { return b.motion == EMotion::Free || b.motion == EMotion::Fingertip; }

void WriteTrajectoryHeader(std::ostream& o, const World& w) {
  o << "step,t_s";
  for (const Body& b : w.bodies)
    if (Moving(b))
      for (const char* c : {"x_m", "y_m", "z_m", "qw", "qx", "qy", "qz"}) o << "," << b.name << "_" << c;
  o << "\n";
}

void WriteTrajectoryRow(std::ostream& o, const World& w) {
  o << w.step_count;
  Cell(o, w.time, ",%.17g");
  for (const Body& b : w.bodies) {
    if (!Moving(b)) continue;
    const Quat q(b.pose.R);
    for (double v : {b.pose.t.x(), b.pose.t.y(), b.pose.t.z(), q.w(), q.x(), q.y(), q.z()}) Cell(o, v, ",%.17g");
  }
  o << "\n";
}

bool StepFiles::Open(const std::string& dir, const World& w, int every, std::string* error) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    *error = "cannot create output folder '" + dir + "': " + ec.message();
    return false;
  }
  dir_ = dir;
  every_ = std::max(1, every);
  trajectory_.open(fs::path(dir) / "trajectory.csv", std::ios::binary);
  contacts_.open(fs::path(dir) / "contacts.csv", std::ios::binary);
  timings_.open(fs::path(dir) / "timings.csv", std::ios::binary);
  if (!trajectory_ || !contacts_ || !timings_) {
    *error = "cannot write trajectory.csv, contacts.csv and timings.csv in '" + dir + "'";
    return false;
  }
  WriteTimingsHeader(timings_);
  WriteTrajectoryHeader(trajectory_, w);
  WriteTrajectoryRow(trajectory_, w);  // the start, step 0
  WriteContactsHeader(contacts_);
  return true;
}

void WriteContactsHeader(std::ostream& o) {
  o << "step,t_s,body_a,body_b,contacts,stick,slip,separating,fn_N,ft_N,penetration_before_m,"
       "penetration_after_m\n";
}

void WriteContactsRows(std::ostream& o, const World& w) {
  if (w.profile.rejected) return;
  std::vector<PairTotals> pairs;
  for (const ContactRow& row : w.rows) {
    const int a = std::min(row.contact.body[0], row.contact.body[1]), b = std::max(row.contact.body[0], row.contact.body[1]);
    auto it = std::find_if(pairs.begin(), pairs.end(), [&](const PairTotals& p) { return p.a == a && p.b == b; });
    if (it == pairs.end()) it = pairs.insert(pairs.end(), PairTotals{a, b});
    Add(&*it, w, row);
  }
  std::sort(pairs.begin(), pairs.end(), [](const PairTotals& x, const PairTotals& y) {
    return x.a != y.a ? x.a < y.a : x.b < y.b;
  });
  for (const PairTotals& p : pairs) {
    o << w.step_count;
    Cell(o, w.time, ",%.6f");
    o << "," << w.bodies[p.a].name << "," << w.bodies[p.b].name << "," << p.contacts << "," << p.stick << ","
      << p.slide << "," << p.separate;
    for (double v : {p.fn, p.ft, std::max(0.0, p.before), std::max(0.0, p.after)}) Cell(o, v, ",%.9g");
    o << "\n";
  }
}

void StepFiles::AfterStep(const World& w) {
  WriteTimingsRow(timings_, w);
  if (w.step_count % every_ != 0) return;
  WriteTrajectoryRow(trajectory_, w);
  WriteContactsRows(contacts_, w);
}

void StepFiles::Flush() {
  trajectory_.flush();
  contacts_.flush();
  timings_.flush();
}

bool StepFiles::Close(std::string* error) {
  trajectory_.close();
  contacts_.close();
  timings_.close();
  if (trajectory_.fail() || contacts_.fail() || timings_.fail()) {
    *error = "cannot write trajectory.csv, contacts.csv or timings.csv in '" + dir_ + "'";
    return false;
  }
  return true;
}

void PrintPaperTables(const std::vector<StepRecord>& steps) {
  std::vector<double> trav, interp, refit, coll, contacts, rig, def, it, gs, res, total, step;
  int max_contacts = 0;
  for (const StepRecord& s : steps) max_contacts = std::max(max_contacts, s.profile.contacts);
  for (const StepRecord& s : steps) {
    const StepProfile& p = s.profile;
    if (p.contacts == 0) continue;
    trav.push_back(1e3 * p.traverse);
    interp.push_back(1e3 * p.interpenetration);
    refit.push_back(1e3 * p.refit);
    coll.push_back(1e3 * p.detect);
    contacts.push_back(p.contacts);
    rig.push_back(1e3 * p.fill_w_rigid);
    def.push_back(1e3 * p.fill_w_deform);
    it.push_back(p.iterations);
    gs.push_back(1e3 * p.solve);
    res.push_back(p.residual);
    total.push_back(1e3 * (p.fill_w_rigid + p.fill_w_deform + p.solve));
    step.push_back(1e3 * p.total);
  }
  std::printf("\nCollision detection (paper Figure 6), over the %zu steps with contacts:\n", coll.size());
  std::printf("  %-32s %10s %10s %12s\n", "", "median", "max", "paper step3");
  std::printf("  %-32s %10.3f %10.3f %12.3f\n", "Traverse BV hierarchy (ms)", Median(trav), Max(trav), 2.973);
  std::printf("  %-32s %10.0f %10.0f %12d\n", "Nb contacts", Median(contacts), Max(contacts), 180);
  std::printf("  %-32s %10.3f %10.3f %12.3f\n", "Interpenetration computing (ms)", Median(interp), Max(interp), 4.100);
  std::printf("  %-32s %10.3f %10.3f %12.3f\n", "Hierarchy update (ms)", Median(refit), Max(refit), 2.549);
  std::printf("  %-32s %10.3f %10.3f %12.3f\n", "Total time (ms)", Median(coll), Max(coll), 10.200);
  std::printf("\nContact resolution (paper Figure 7):\n");
  std::printf("  %-32s %10s %10s %12s\n", "", "median", "max", "paper step3");
  std::printf("  %-32s %10.0f %10.0f %12d\n", "Nb contacts", Median(contacts), Max(contacts), 164);
  std::printf("  %-32s %10.3f %10.3f %12.3f\n", "Fill W_rigid (ms)", Median(rig), Max(rig), 25.030);
  std::printf("  %-32s %10.3f %10.3f %12.3f\n", "Fill W_deform (ms)", Median(def), Max(def), 7.350);
  std::printf("  %-32s %10.0f %10.0f %12d\n", "Gauss-Seidel iterations", Median(it), Max(it), 5);
  std::printf("  %-32s %10.3f %10.3f %12.3f\n", "Gauss-Seidel resolution (ms)", Median(gs), Max(gs), 5.410);
  std::printf("  %-32s %10.3f %10.3f %12.3f\n", "Total time (ms)", Median(total), Max(total), 43.060);
  std::printf("  %-32s %10.2e %10.2e %12s\n", "Residual (stopping measure)", Median(res), Max(res), "-");
  std::printf("\nWhole step (ms): median %.3f, max %.3f (paper: 53 ms at its deepest grasp)\n", Median(step),
              Max(step));
}

namespace {
struct Fnv {
  uint64_t h = 1469598103934665603ull;
  void Bytes(const void* p, size_t n) {
    const unsigned char* c = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h = (h ^ c[i]) * 1099511628211ull;
  }
  template <class M>
  void Eig(const M& m) {
    Bytes(m.data(), sizeof(double) * static_cast<size_t>(m.size()));
  }
};
}  // namespace

uint64_t StateHash(const World& w) {
  Fnv f;
  for (const Body& b : w.bodies) {
    f.Eig(b.pose.t);
    f.Eig(b.pose.R);
    f.Eig(b.velocity);
    f.Eig(b.angular_velocity);
    for (const Vec3& u : b.u) f.Eig(u);
  }
  for (const Finger& g : w.hand.fingers) f.Eig(g.q);
  for (const ContactRow& r : w.rows) f.Eig(r.r);
  return f.h;
}

std::string StateHashHex(const World& w) {
  char buf[24];
  std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(StateHash(w)));
  return buf;
}

}  // namespace gs::app
