#include "app/run_report.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>

namespace gs::app {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double Max(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); }

}  // namespace

StepRecord RecordStep(const World& w) {
  StepRecord r;
  r.time = w.time;
  r.profile = w.profile;
  for (const ContactRow& row : w.rows) {
    r.normal_force += row.r[0];
    r.max_penetration = std::max(r.max_penetration, -row.contact.gap);
    if (row.r[0] <= 0.0) {
      ++r.separate;
    } else if (row.r.tail<2>().norm() >= row.mu * row.r[0] * (1.0 - 1e-9) && row.mu > 0) {
      ++r.slide;
    } else {
      ++r.stick;
    }
  }
  return r;
}

bool WriteRunOutputs(const std::string& dir, const std::string& scene_name, const std::vector<StepRecord>& steps,
                     const std::string& summary_json, std::string* error) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    *error = "cannot create output folder '" + dir + "': " + ec.message();
    return false;
  }
  {
    std::ofstream f(fs::path(dir) / "timings.csv");
    f << "step,time_s,contacts,iterations,residual,converged,rejected,free_motion_ms,traverse_ms,"
         "interpenetration_ms,refit_ms,fill_w_rigid_ms,fill_w_deform_ms,solve_ms,constrained_motion_ms,total_ms\n";
    char line[512];
    for (size_t i = 0; i < steps.size(); ++i) {
      const StepProfile& p = steps[i].profile;
      std::snprintf(line, sizeof line, "%zu,%.6f,%d,%d,%.3e,%d,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f\n",
                    i + 1, steps[i].time, p.contacts, p.iterations, p.residual, p.converged ? 1 : 0,
                    p.rejected ? 1 : 0, 1e3 * p.free_motion, 1e3 * p.traverse, 1e3 * p.interpenetration,
                    1e3 * p.refit, 1e3 * p.fill_w_rigid, 1e3 * p.fill_w_deform, 1e3 * p.solve,
                    1e3 * p.constrained_motion, 1e3 * p.total);
      f << line;
    }
    if (!f) {
      *error = "cannot write '" + (fs::path(dir) / "timings.csv").string() + "'";
      return false;
    }
  }
  {
    std::ofstream f(fs::path(dir) / "contacts.csv");
    f << "step,time_s,contacts,stick,slide,separating,normal_force_N,max_penetration_m\n";
    char line[256];
    for (size_t i = 0; i < steps.size(); ++i) {
      const StepRecord& s = steps[i];
      std::snprintf(line, sizeof line, "%zu,%.6f,%d,%d,%d,%d,%.6e,%.6e\n", i + 1, s.time, s.profile.contacts,
                    s.stick, s.slide, s.separate, s.normal_force, s.max_penetration);
      f << line;
    }
    if (!f) {
      *error = "cannot write contacts.csv in '" + dir + "'";
      return false;
    }
  }
  {
    std::ofstream f(fs::path(dir) / "summary.json");
    f << summary_json << "\n";
    if (!f) {
      *error = "cannot write summary.json in '" + dir + "'";
      return false;
    }
  }
  (void)scene_name;
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
    coll.push_back(1e3 * (p.traverse + p.interpenetration + p.refit));
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
