#include "session/live_loop.h"

#include <lcm/lcm-cpp.hpp>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <thread>

#include "session/frame_recorder.h"
#include "session/tracker_app.h"
#include "graspsim/contacts_t.hpp"
#include "graspsim/poses_t.hpp"
#include "tracking/lcm_receiver.h"
#include "tracking/mailbox.h"
#include "tracking/session_log.h"
#include "tracking/tracker_health.h"

namespace gs::app {
namespace {

using tracking::SteadyNanoseconds;

int64_t WallMicroseconds() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// what the simulation hands to the publisher (vectors sized once, then reused)
struct Snapshot {
  struct BodyState {
    Pose pose;
    Vec3 v = Vec3::Zero(), w = Vec3::Zero();
  };
  struct Tip {
    int state = 0;
    Pose pose, target;
    Vec3 force = Vec3::Zero();
  };
  struct ContactState {
    int a = -1, b = -1;
    Vec3 point, normal, force;
    double gap = 0;
  };
  double time = 0;
  int64_t step = 0;
  std::vector<BodyState> bodies;
  std::vector<Tip> tips;
  std::vector<ContactState> contacts;
  int num_contacts = 0;

  void Reserve(size_t nb, size_t nt, size_t nc) {
    bodies.resize(nb);
    tips.resize(nt);
    contacts.resize(nc);
  }
};

void TakeSnapshot(const World& w, tracking::TargetFollower& f, Snapshot* s) {
  s->time = w.time;
  s->step = w.step_count;
  for (size_t i = 0; i < w.bodies.size() && i < s->bodies.size(); ++i) {
    s->bodies[i].pose = w.bodies[i].pose;
    s->bodies[i].v = w.bodies[i].velocity;
    s->bodies[i].w = w.bodies[i].angular_velocity;
  }
  for (int i = 0; i < f.size() && i < static_cast<int>(s->tips.size()); ++i) {
    Snapshot::Tip& t = s->tips[i];
    t.state = static_cast<int>(f.state(i));
    t.target = f.target(i);
    const int b = f.body(i);
    t.pose = b >= 0 ? w.bodies[b].pose : Pose();
    t.force = b >= 0 ? CouplingSpringForce(w.bodies[b]) : Vec3::Zero();
  }
  const int n = std::min(static_cast<int>(w.rows.size()), static_cast<int>(s->contacts.size()));
  for (int i = 0; i < n; ++i) {
    const ContactRow& r = w.rows[i];
    Snapshot::ContactState& c = s->contacts[i];
    c.a = r.contact.body[0];
    c.b = r.contact.body[1];
    c.point = r.world_point;
    c.normal = r.contact.normal;
    c.force = r.frame.transpose() * r.r;
    c.gap = r.contact.gap;
  }
  s->num_contacts = n;
}

void Fill(double* out, const Vec3& v) {
  for (int i = 0; i < 3; ++i) out[i] = v[i];
}
void Fill(double* out, const Mat3& R) {
  const Quat q(R);
  out[0] = q.w();
  out[1] = q.x();
  out[2] = q.y();
  out[3] = q.z();
}

uint64_t Publish(lcm::LCM& lc, const World& w, const tracking::TrackerConfig& cfg, const Snapshot& s) {
  graspsim::poses_t poses;
  poses.utime = WallMicroseconds();
  poses.sim_time = s.time;
  poses.step = s.step;
  poses.num_bodies = static_cast<int32_t>(s.bodies.size());
  poses.bodies.resize(s.bodies.size());
  for (size_t i = 0; i < s.bodies.size(); ++i) {
    graspsim::body_pose_t& b = poses.bodies[i];
    b.name = w.bodies[i].name;
    Fill(b.position, s.bodies[i].pose.t);
    Fill(b.orientation, s.bodies[i].pose.R);
    Fill(b.velocity, s.bodies[i].v);
    Fill(b.angular_velocity, s.bodies[i].w);
  }
  poses.num_fingertips = static_cast<int32_t>(s.tips.size());
  poses.fingertips.resize(s.tips.size());
  for (size_t i = 0; i < s.tips.size(); ++i) {
    graspsim::fingertip_state_t& t = poses.fingertips[i];
    t.name = cfg.fingertips[i].name;
    t.body = cfg.fingertips[i].body;
    t.state = static_cast<int8_t>(s.tips[i].state);
    Fill(t.position, s.tips[i].pose.t);
    Fill(t.orientation, s.tips[i].pose.R);
    Fill(t.target_position, s.tips[i].target.t);
    Fill(t.target_orientation, s.tips[i].target.R);
    Fill(t.coupling_force, s.tips[i].force);
  }
  graspsim::contacts_t contacts;
  contacts.utime = poses.utime;
  contacts.sim_time = s.time;
  contacts.step = s.step;
  contacts.num_contacts = s.num_contacts;
  contacts.contacts.resize(static_cast<size_t>(s.num_contacts));
  for (int i = 0; i < s.num_contacts; ++i) {
    const Snapshot::ContactState& c = s.contacts[i];
    graspsim::contact_t& m = contacts.contacts[i];
    m.body_a = c.a >= 0 ? w.bodies[c.a].name : "";
    m.body_b = c.b >= 0 ? w.bodies[c.b].name : "";
    Fill(m.point, c.point);
    Fill(m.normal, c.normal);
    Fill(m.force, c.force);
    m.normal_force = c.force.dot(c.normal);
    m.gap = c.gap;
  }
  uint64_t n = 0;
  n += lc.publish(tracking::kPosesChannel, &poses) == 0;
  n += lc.publish(tracking::kContactsChannel, &contacts) == 0;
  return n;
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5))];
}

}  // namespace

std::unique_ptr<tracking::DatagramSource> OpenLiveSource(const LiveOptions& opt, std::string* error) {
  if (opt.lcm_channel.empty()) {
    auto udp = std::make_unique<tracking::UdpReceiver>();
    if (!udp->Open(opt.udp, error)) return nullptr;
    return udp;
  }
  auto lcm_in = std::make_unique<tracking::LcmReceiver>();
  if (!lcm_in->Open(opt.lcm_url, opt.lcm_channel, error)) return nullptr;
  return lcm_in;
}

bool RunLive(TrackedSim& sim, const LiveOptions& opt, LiveStats* stats, std::string* error, FrameRecorder* frames) {
  World& w = sim.world();
  const tracking::TrackerConfig cfg = sim.config();
  std::unique_ptr<tracking::DatagramSource> source = OpenLiveSource(opt, error);
  if (!source) return false;
  tracking::DatagramSource& rx = *source;
  // from here on, datagrams sent to the port (or channel) are queued for the receiver (a sender may start)
  std::printf("live: listening on %s\n", rx.Describe().c_str());
  std::fflush(stdout);
  // what a good datagram carries, and the names of what may be missing (code -1: the hand; i: fingertip i)
  std::vector<std::string> missing_labels;
  for (int code = -1; code < static_cast<int>(cfg.fingertips.size()); ++code)
    missing_labels.push_back(tracking::MissingLabel(cfg, code));
  stats->needs = tracking::NeedsLabel(cfg);

  // receiver thread: parse, map, hand over the newest sample
  tracking::LatestMailbox<tracking::TargetSample> samples;
  tracking::DTrackParser parser;
  tracking::DTrackFrame frame;
  std::atomic<uint64_t> datagrams{0}, parse_errors{0}, bad_datagrams{0}, good{0}, not_dtrack{0}, missing{0},
      other_side{0};
  std::atomic<int64_t> first_ns{-1}, last_ns{-1}, first_good_ns{-1}, last_good_ns{-1};
  std::atomic<int> missing_code{-1};
  tracking::TargetSample rx_sample;
  rx.Start([&](const tracking::Datagram& d) {
    int errors;
    if (d.truncated) {
      parser.CountOversized(d.size);
      frame.Clear();
      errors = 1;
    } else {
      errors = parser.Parse(d.data, d.size, &frame);
    }
    tracking::MapFrame(frame, cfg, &rx_sample);
    rx_sample.parse_errors = errors;
    rx_sample.arrival_ns = d.monotonic_ns;
    rx_sample.sequence = d.sequence;
    samples.Write(rx_sample);
    if (first_ns.load(std::memory_order_relaxed) < 0) first_ns = d.monotonic_ns;
    last_ns = d.monotonic_ns;
    parse_errors = parser.stats().TotalErrors();
    if (errors > 0) bad_datagrams.fetch_add(1);
    datagrams.fetch_add(1);  // before its category: a category counted is never ahead of the total
    int code = -1;
    switch (tracking::JudgeFrame(frame, errors, cfg, rx_sample, &code)) {
      case tracking::ECarries::Good:
        if (first_good_ns.load(std::memory_order_relaxed) < 0) first_good_ns = d.monotonic_ns;
        last_good_ns = d.monotonic_ns;
        good.fetch_add(1);
        break;
      case tracking::ECarries::NotDTrack: not_dtrack.fetch_add(1); break;
      case tracking::ECarries::Missing:
        missing_code = code;
        missing.fetch_add(1);
        if (tracking::CarriesOtherSide(frame, cfg)) other_side.fetch_add(1);
        break;
    }
  });

  // simulation thread
  const double dt = w.params.dt;
  const int64_t period_ns = static_cast<int64_t>(std::llround(dt * 1e9));
  const int publish_every =
      opt.publish_rate > 0 ? std::max(1, static_cast<int>(std::lround(1.0 / (opt.publish_rate * dt)))) : 0;
  tracking::LatestMailbox<Snapshot> snapshots;
  Snapshot snap;
  snap.Reserve(w.bodies.size(), cfg.fingertips.size(), static_cast<size_t>(w.params.max_contacts));
  // the mailbox's buffers get their capacity before the loop, so the loop never allocates
  snapshots.Fill(snap);
  Snapshot pub = snap;  // the publisher's copy, sized before the simulation thread starts writing `snap`
  std::atomic<bool> stop{false};
  std::atomic<int64_t> steps{0}, overruns{0}, skipped{0}, applied{0};
  std::atomic<int64_t> sim_end_ns{0};  // when the simulation thread left its loop
  std::atomic<double> last_step_ms{0.0};
  // the tracker's health for the frames' HUD (and the live view): set by the status loop, read by the simulation thread
  std::atomic<const char*> hud_tracker_state{"waiting"};
  std::atomic<double> hud_good_hz{0.0};
  w.params.budget_may_skip_solve = opt.skip_late_solves;
  w.params.carry_contacts_after_s = CarryContactsAfter(opt.step_budget, opt.detect_every_step, dt);
  double residual_max = 0.0;  // simulation thread; read after it is joined
  const int tracked = sim.scene().tracked_body;
  const double start_z = tracked >= 0 ? w.bodies[tracked].pose.t.z() : 0.0;
  double max_rise = 0.0;  // simulation thread, as residual_max
  int max_contacts = 0;
  const int64_t unconverged_before = w.unconverged_steps, budget_before = w.budget_stopped_steps;
  const int64_t skipped_solves_before = w.skipped_solves, carried_before = w.carried_steps;
  std::vector<double> step_ms;
  const size_t max_records = 4000000;
  step_ms.reserve(std::min<size_t>(max_records, opt.duration > 0 ? static_cast<size_t>(opt.duration / dt) + 16 : max_records));
  stats->latency_steps.clear();
  stats->latency_us.clear();
  stats->latency_steps.reserve(200000);
  stats->latency_us.reserve(200000);
  // memory is locked before the clock starts: it takes a while in a large process
  const PacingGrant locked = LockMemory(opt.pacing);
  const int64_t start_ns = SteadyNanoseconds() + (2 + opt.lead_steps) * period_ns;
  if (frames && !frames->active()) frames = nullptr;
  std::thread sim_thread([&] {
    // this thread alone: the receiver and render threads keep normal scheduling
    stats->pacing = EnterRealtime(opt.pacing, &locked);
    sim.UseThreads(opt.threads);
    tracking::TargetSample s;
    char tracker_text[160] = "";
    int64_t k = 0;  // step index on the schedule
    StepSchedule schedule;  // session/pacing.h: step k ends by start + (k+1) dt, may begin lead_steps earlier
    schedule.start_ns = start_ns;
    schedule.period_ns = period_ns;
    schedule.lead = opt.lead_steps;
    WaitUntilNs(schedule.ReleaseNs(0), opt.pacing.spin_ns);
    while (!stop.load(std::memory_order_relaxed)) {
      const int64_t begin = SteadyNanoseconds();
      bool fresh = false;
      if (samples.Read(&s)) {
        sim.Push(s);
        fresh = true;
        applied.fetch_add(1, std::memory_order_relaxed);
      }
      const int64_t deadline = schedule.DeadlineNs(k);
      // step_budget of a timestep, never past as far into the step's slot (late steps get what is left, at least one sweep)
      if (opt.step_budget > 0.0) w.params.step_time_budget_s = schedule.BudgetS(k, begin, opt.step_budget);
      sim.Step();
      const int64_t end = SteadyNanoseconds();
      if (!w.profile.solve_skipped) residual_max = std::max(residual_max, w.profile.residual);
      if (tracked >= 0) max_rise = std::max(max_rise, w.bodies[tracked].pose.t.z() - start_z);
      max_contacts = std::max(max_contacts, w.profile.contacts);
      if (fresh && stats->latency_us.size() < stats->latency_us.capacity()) {
        // the step in progress when it arrived, and the one that applied it: the
        // step the schedule released last before its arrival, or, when the loop runs
        // behind its schedule (catching up), the step then executing (k - 1); the
        // schedule alone would count steps not yet run and give a negative latency
        const int64_t since = s.arrival_ns - schedule.ReleaseNs(0);
        const int64_t released = since >= 0 ? since / period_ns : -1;
        const int64_t k_arrival = std::min(released, k - 1);
        stats->latency_steps.push_back(static_cast<int>(k - k_arrival));
        stats->latency_us.push_back(1e-3 * static_cast<double>(end - s.arrival_ns));
      }
      const double ms = 1e-6 * static_cast<double>(end - begin);
      if (step_ms.size() < step_ms.capacity()) step_ms.push_back(ms);
      last_step_ms.store(ms, std::memory_order_relaxed);
      if (end > deadline) overruns.fetch_add(1, std::memory_order_relaxed);
      if (publish_every && (w.step_count % publish_every) == 0) {
        TakeSnapshot(w, sim.follower(), &snap);
        snapshots.Write(snap);
      }
      if (frames) {
        if (frames->FrameDue(w)) {
          // "tracker ok 100 Hz, 3/3 tracking": no allocation, a fixed buffer
          const int n = std::snprintf(tracker_text, sizeof tracker_text, "tracker %s %.0f Hz, ",
                                      hud_tracker_state.load(std::memory_order_relaxed),
                                      hud_good_hz.load(std::memory_order_relaxed));
          if (n > 0 && static_cast<size_t>(n) < sizeof tracker_text)
            sim.HudText(tracker_text + n, sizeof tracker_text - static_cast<size_t>(n));
        }
        frames->AfterStep(w, tracker_text);
      }
      steps.fetch_add(1, std::memory_order_relaxed);
      ++k;
      const int64_t next = schedule.ReleaseNs(k);
      if (end - next > 50000000) {
        // more than 50 ms behind: give up the missed deadlines instead of racing to catch up
        const int64_t behind = (end - next) / period_ns;
        skipped.fetch_add(behind, std::memory_order_relaxed);
        schedule.start_ns += behind * period_ns;
        continue;
      }
      WaitUntilNs(next, opt.pacing.spin_ns);
    }
    // a thread held off the core at the end (another real-time loop on it, throttling)
    // gave up the slots from its schedule's position to now: counted as skipped
    const int64_t exit_ns = SteadyNanoseconds();
    const int64_t next = schedule.ReleaseNs(k);
    if (exit_ns - next >= period_ns) skipped.fetch_add((exit_ns - next) / period_ns, std::memory_order_relaxed);
    sim_end_ns.store(exit_ns);
    sim.UseThreads(1);  // the workers end with the thread that started them
  });

  // this thread: LCM publishing and the status line
  std::unique_ptr<lcm::LCM> lc;
  if (publish_every) {
    lc = std::make_unique<lcm::LCM>(opt.lcm_url);
    stats->lcm_ok = lc->good();
    if (!stats->lcm_ok)
      std::fprintf(stderr, "live: LCM is unavailable at '%s' (for udpm: a multicast route, e.g. 'ip route add "
                           "239.0.0.0/8 dev lo'); not publishing\n",
                   opt.lcm_url.empty() ? "udpm://239.255.76.67:7667?ttl=0" : opt.lcm_url.c_str());
  }
  const bool tty = StdoutIsTerminal() && opt.status && !opt.quiet;
  const int64_t t0 = SteadyNanoseconds();
  int64_t last_status = t0;
  uint64_t last_datagrams = 0, last_good = 0;
  // the tracker's health, judged from the receiver's counters; events are printed as they happen
  tracking::HealthOptions ho;
  ho.silent_after_s = opt.silent_after_s;
  tracking::TrackerHealth health(ho);
  health.Start(start_ns);
  tracking::HealthEvent events[tracking::TrackerHealth::kMaxEvents];
  bool status_pending = false;  // a tty status line without its newline
  while (!StopRequested()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(publish_every ? std::max(1, static_cast<int>(500 / std::max(1.0, opt.publish_rate))) : 20));
    const int64_t now = SteadyNanoseconds();
    if (lc && stats->lcm_ok && snapshots.Read(&pub)) stats->published += Publish(*lc, w, cfg, pub);
    if (opt.duration > 0 && now - start_ns >= static_cast<int64_t>(opt.duration * 1e9)) break;
    tracking::HealthCounters hc;
    hc.now_ns = now;
    hc.last_arrival_ns = last_ns.load();  // before the counts: a datagram counted is never newer than it
    hc.not_dtrack = not_dtrack.load();  // before the total: never more than it (counted after it)
    hc.missing = missing.load();
    hc.missing_label = missing_labels[static_cast<size_t>(missing_code.load() + 1)].c_str();
    hc.datagrams = datagrams.load();
    hc.bad_datagrams = bad_datagrams.load();
    hc.rejected = rx.stats().rejected_sender.load();
    hc.last_rejected_addr = rx.stats().last_rejected_addr.load();
    const int ne = health.Update(hc, events);
    hud_tracker_state.store(health.state(), std::memory_order_relaxed);
    hud_good_hz.store(health.window_good_hz(), std::memory_order_relaxed);
    for (int i = 0; i < ne; ++i) {
      if (opt.quiet) continue;
      std::printf("%slive: t=%.2f s: %s\n", status_pending ? "\n" : "", events[i].t_s, events[i].text);
      status_pending = false;
    }
    if (ne && !opt.quiet) std::fflush(stdout);
    const double since = 1e-9 * static_cast<double>(now - last_status);
    if (opt.status && !opt.quiet && since >= (tty ? 0.25 : 5.0)) {
      const uint64_t n = datagrams.load(), ng = good.load();
      char render[80] = "";
      if (frames)
        std::snprintf(render, sizeof render, "  frames %d (%d dropped)", frames->frames_drawn(),
                      frames->frames_dropped());
      std::printf("%s  t=%7.2f s  tracker %-10s %6.1f Hz good of %6.1f Hz  parse errors %llu  rejected %llu  step %.3f ms  overruns %lld  skipped %lld%s%s",
                  tty ? "\r" : "", 1e-9 * static_cast<double>(now - start_ns), health.state(),
                  static_cast<double>(ng - last_good) / since, static_cast<double>(n - last_datagrams) / since,
                  static_cast<unsigned long long>(parse_errors.load()),
                  static_cast<unsigned long long>(hc.rejected), last_step_ms.load(),
                  static_cast<long long>(overruns.load()), static_cast<long long>(skipped.load()), render,
                  tty ? "   " : "\n");
      status_pending = tty;
      std::fflush(stdout);
      last_status = now;
      last_datagrams = n;
      last_good = ng;
    }
  }
  stop = true;
  const int64_t stop_ns = SteadyNanoseconds();
  sim_thread.join();
  rx.Stop();
  if (status_pending) std::printf("\n");
  stats->health = health.counts();
  stats->tracker_state = health.state();
  // the run lasts until the simulation thread's last step: a step under way at the stop
  // ends after it, and a loop running behind gives up the slots up to that step's end;
  // from the first step's release (lead_steps timesteps before its slot)
  stats->wall_s =
      1e-9 * static_cast<double>(std::max(stop_ns, sim_end_ns.load()) - (start_ns - opt.lead_steps * period_ns));
  stats->steps = steps.load();
  stats->overruns = overruns.load();
  stats->skipped_steps = skipped.load();
  stats->unconverged_steps = w.unconverged_steps - unconverged_before;
  stats->budget_stops = w.budget_stopped_steps - budget_before;
  stats->skipped_solves = w.skipped_solves - skipped_solves_before;
  stats->carried_steps = w.carried_steps - carried_before;
  stats->residual_max = residual_max;
  w.params.step_time_budget_s = 0.0;
  w.params.carry_contacts_after_s = 0.0;
  stats->datagrams = datagrams.load();
  stats->samples_applied = static_cast<uint64_t>(applied.load());
  stats->parse = parser.stats();
  stats->last_parse_error = parser.last_error();
  stats->rejected_senders = rx.stats().rejected_sender.load();
  const double span = 1e-9 * static_cast<double>(last_ns.load() - first_ns.load());
  stats->tracker_hz = stats->datagrams > 1 && span > 0 ? static_cast<double>(stats->datagrams - 1) / span : 0.0;
  stats->good_datagrams = good.load();
  stats->not_dtrack = not_dtrack.load();
  stats->missing = missing.load();
  stats->other_side = other_side.load();
  stats->missing_code = missing_code.load();
  const double good_span = 1e-9 * static_cast<double>(last_good_ns.load() - first_good_ns.load());
  stats->good_hz = stats->good_datagrams > 1 && good_span > 0 ? static_cast<double>(stats->good_datagrams - 1) / good_span : 0.0;
  stats->foreign_messages = rx.stats().foreign_messages.load();
  stats->max_rise_m = max_rise;
  stats->max_contacts = max_contacts;
  stats->step_median_ms = Percentile(step_ms, 0.5);
  stats->step_p99_ms = Percentile(step_ms, 0.99);
  stats->step_max_ms = step_ms.empty() ? 0.0 : *std::max_element(step_ms.begin(), step_ms.end());
  if (frames) {
    stats->frames_drawn = frames->frames_drawn();
    stats->frames_dropped = frames->frames_dropped();
  }
  return true;
}

}  // namespace gs::app
