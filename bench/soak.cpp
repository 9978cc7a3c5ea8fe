#include "bench/soak.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <vector>

#include "session/tracked_sim.h"
#include "tracking/session_log.h"
#include "tracking/synthetic_hand.h"
#include "tracking/udp_receiver.h"
#include "session/console.h"

namespace gs::app {
namespace {

constexpr double kRate = 100.0;    // tracker frames per second
constexpr double kGrasp = 2.1;     // s: the synthetic hand has lifted the box and holds it
constexpr double kHold = 1.0;      // s: the held second that loops

double ResidentMb() {
  std::ifstream f("/proc/self/statm");
  long pages = 0, resident = 0;
  f >> pages >> resident;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

bool WriteSession(const std::string& path, int* grasp_events, std::string* error) {
  tracking::SessionWriter w;
  if (!w.Open(path, error)) return false;
  tracking::SyntheticHand hand;
  uint32_t frame = 0;
  auto put = [&](double arrival, double pose_t) {
    const std::string s = hand.Datagram(pose_t, frame);
    tracking::Datagram d;
    d.data = s.data();
    d.size = s.size();
    d.monotonic_ns = static_cast<int64_t>(std::llround(arrival * 1e9));
    d.utime = d.monotonic_ns / 1000;
    d.sequence = frame++;
    std::snprintf(d.source, sizeof(d.source), "soak");
    return w.Write(d);
  };
  const int grasp = static_cast<int>(std::lround(kGrasp * kRate));
  const int hold = static_cast<int>(std::lround(kHold * kRate));
  for (int i = 0; i < grasp; ++i)
    if (!put(i / kRate, i / kRate)) return false;
  for (int i = 0; i < hold; ++i)
    if (!put(kGrasp + i / kRate, kGrasp)) return false;  // the hand holds still
  w.Close();
  *grasp_events = grasp;
  return true;
}

bool Finite(const World& w) {
  for (const Body& b : w.bodies)
    if (!b.pose.t.allFinite() || !b.pose.R.allFinite() || !b.velocity.allFinite() || !b.angular_velocity.allFinite())
      return false;
  return true;
}

}  // namespace

bool RunSoak(const SoakOptions& opt, SoakResult* out, std::string* error) {
  *out = SoakResult();
  const std::string log = opt.work_dir + "/soak_session.lcmlog";
  int grasp_events = 0;
  if (!WriteSession(log, &grasp_events, error)) return false;
  auto sim = std::make_unique<TrackedSim>();
  if (!sim->Load(opt.scene, error)) return false;
  World& w = sim->world();
  const int body = sim->scene().tracked_body;
  if (body < 0) {
    *error = opt.scene + ": no free body besides the fingertips to hold";
    return false;
  }
  const Vec3 start = w.bodies[body].pose.t;
  const double dt = w.params.dt;
  const int64_t steps = opt.steps;
  const int64_t warmup = opt.warmup_steps > 0 ? opt.warmup_steps
                                              : std::max<int64_t>(5000, steps / 10);
  if (warmup >= steps) {
    *error = "soak: the warm-up (" + std::to_string(warmup) + " steps) must be shorter than the run";
    return false;
  }
  // everything the loop records is sized here
  const int64_t sample_every = 100;
  // (resized, not reserved: their pages are touched now, before the warm-up's memory figure)
  std::vector<Vec3> pos(static_cast<size_t>((steps - warmup) / sample_every + 2), Vec3::Zero());
  std::vector<Quat> rot(pos.size(), Quat::Identity());
  size_t samples = 0;
  std::vector<float> step_ms(static_cast<size_t>(steps), 0.0f);

  tracking::SessionReader reader;
  if (!reader.Open(log, error)) return false;
  tracking::RecordedDatagram d;
  tracking::TargetSample sample;
  double offset = 0.0;  // added to recorded arrivals: loop k of the held second is k seconds later
  int loop = 0;
  auto next = [&]() -> bool {
    if (reader.Next(&d)) return true;
    if (!reader.error().empty()) return false;
    // end of the log: read it again from the held second
    if (!reader.Open(log, error)) return false;
    for (int i = 0; i < grasp_events; ++i)
      if (!reader.Next(&d)) return false;
    ++loop;
    offset = loop * kHold;
    return reader.Next(&d);
  };
  bool pending = next();
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  for (int64_t step = 0; step < steps; ++step) {
    while (pending && 1e-6 * static_cast<double>(d.monotonic_utime) + offset <= w.time + 1e-9) {
      sim->Ingest(d.data.data(), d.data.size(), false, &sample);
      sim->Push(sample);
      ++out->datagrams;
      pending = next();
    }
    if (!pending && !reader.error().empty()) {
      *error = "soak: " + reader.error();
      return false;
    }
    if (StopRequested()) {  // Ctrl-C: a soak cut short measures nothing it promises
      *error = "soak: interrupted at step " + std::to_string(step) + " of " + std::to_string(steps);
      return false;
    }
    sim->Step();
    step_ms[static_cast<size_t>(step)] = static_cast<float>(1e3 * w.profile.total);
    if (!Finite(w)) out->finite = false;
    if (step + 1 == warmup) out->rss_warm_mb = ResidentMb();
    if (step >= warmup && (step - warmup) % sample_every == 0) {
      pos[samples] = w.bodies[body].pose.t;
      rot[samples] = Quat(w.bodies[body].pose.R);
      ++samples;
    }
    if ((step + 1) % std::max<int64_t>(1, steps / 10) == 0) {
      const double rss = ResidentMb();
      out->rss_max_mb = std::max(out->rss_max_mb, rss);
      if (opt.progress)
        std::printf("  step %9lld  t=%8.1f s  resident %.2f MB  box at (%.3f, %.3f, %.3f) mm\n",
                    static_cast<long long>(step + 1), w.time, rss, 1e3 * w.bodies[body].pose.t.x(),
                    1e3 * w.bodies[body].pose.t.y(), 1e3 * w.bodies[body].pose.t.z());
    }
  }
  out->wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  out->rss_end_mb = ResidentMb();
  out->rss_max_mb = std::max(out->rss_max_mb, out->rss_end_mb);
  out->rss_growth_mb = out->rss_end_mb - out->rss_warm_mb;
  out->steps = steps;
  out->loops = loop;
  out->simulated_s = w.time;
  out->lift_mm = 1e3 * (w.bodies[body].pose.t.z() - start.z());
  std::sort(step_ms.begin(), step_ms.end());
  out->step_median_ms = step_ms[step_ms.size() / 2];
  out->step_max_ms = step_ms.back();

  // drift: first against last 5% of the held samples
  const size_t n = samples;
  const size_t k = std::max<size_t>(1, n / 20);
  Vec3 a = Vec3::Zero(), b = Vec3::Zero();
  for (size_t i = 0; i < k; ++i) {
    a += pos[i] / static_cast<double>(k);
    b += pos[n - k + i] / static_cast<double>(k);
  }
  out->drift_um = 1e6 * (b - a).norm();
  const double span = static_cast<double>(n - k) * sample_every * dt;
  out->drift_rate_um_s = span > 0 ? out->drift_um / span : 0.0;
  out->drift_deg = rot[0].angularDistance(rot[n - 1]) * 180.0 / M_PI;
  for (size_t i = 0; i < n; ++i) out->wobble_um = std::max(out->wobble_um, 1e6 * (pos[i] - a).norm());
  return true;
}

}  // namespace gs::app
