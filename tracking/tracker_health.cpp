#include "tracking/tracker_health.h"

#include <arpa/inet.h>

#include <cmath>
#include <cstdio>

namespace gs::tracking {

const char* HealthEventName(EHealthEvent e) {
  switch (e) {
    case EHealthEvent::NoData: return "no_data";
    case EHealthEvent::Silent: return "silent";
    case EHealthEvent::Back: return "back";
    case EHealthEvent::Rate: return "rate";
    case EHealthEvent::Garbage: return "garbage";
    case EHealthEvent::GarbageOver: return "garbage_over";
    case EHealthEvent::Flood: return "flood";
    case EHealthEvent::FloodOver: return "flood_over";
    case EHealthEvent::Rejected: return "rejected";
    case EHealthEvent::RejectedOver: return "rejected_over";
    case EHealthEvent::NotDTrack: return "not_dtrack";
    case EHealthEvent::NotDTrackOver: return "not_dtrack_over";
    case EHealthEvent::Missing: return "missing";
    case EHealthEvent::MissingOver: return "missing_over";
  }
  return "?";
}

void TrackerHealth::Start(int64_t t0_ns) {
  *this = TrackerHealth(opt_);
  t0_ = t0_ns;
  started_ = true;
  window_start_ns_ = t0_ns;
  window_first_.now_ns = t0_ns;
  window_disturbed_ = true;
}

const char* TrackerHealth::state() const {
  if (flooding_) return "flood";
  if (silent_) return "silent";
  if (garbage_) return "garbage";
  if (rejecting_) return "rejecting";
  if (not_dtrack_) return "not-dtrack";
  if (missing_) return "missing";
  if (rate_hz_ <= 0.0 && window_good_hz_ <= 0.0) return "waiting";
  return "ok";
}

HealthEvent* TrackerHealth::Emit(HealthEvent* out, int* n, EHealthEvent kind, double t) {
  // the last slot is overwritten rather than overrun (never more than a few per call)
  HealthEvent* e = &out[*n < kMaxEvents ? (*n)++ : kMaxEvents - 1];
  e->kind = kind;
  e->t_s = t;
  e->text[0] = '\0';
  return e;
}

int TrackerHealth::Update(const HealthCounters& c, HealthEvent* out) {
  if (!started_) Start(c.now_ns);
  int n = 0;
  const double t = 1e-9 * static_cast<double>(c.now_ns - t0_);
  const int64_t silent_ns = static_cast<int64_t>(opt_.silent_after_s * 1e9);

  // silence: judged on every call, not per window, so it is reported within silent_after_s
  if (c.datagrams == 0) {
    if (!no_data_reported_ && t >= 8 * opt_.silent_after_s) {
      no_data_reported_ = true;
      HealthEvent* e = Emit(out, &n, EHealthEvent::NoData, t);
      std::snprintf(e->text, sizeof(e->text), "no datagram from the tracker yet");
    }
  } else if (!silent_ && c.last_arrival_ns >= 0 && c.now_ns - c.last_arrival_ns > silent_ns) {
    silent_ = true;
    silent_since_ns_ = c.last_arrival_ns;
    datagrams_at_silence_ = c.datagrams;
    window_disturbed_ = true;
    ++counts_.silences;
    HealthEvent* e = Emit(out, &n, EHealthEvent::Silent, t);
    std::snprintf(e->text, sizeof(e->text), "tracker silent: no datagram for %.2f s (fingertips hold, then release)",
                  1e-9 * static_cast<double>(c.now_ns - c.last_arrival_ns));
  } else if (silent_ && c.datagrams > datagrams_at_silence_) {
    silent_ = false;
    window_disturbed_ = true;
    ++counts_.recoveries;
    HealthEvent* e = Emit(out, &n, EHealthEvent::Back, t);
    std::snprintf(e->text, sizeof(e->text), "tracker back after %.2f s of silence",
                  1e-9 * static_cast<double>(c.last_arrival_ns - silent_since_ns_));
  }

  // per window: rate, floods, garbage, rejected senders
  const double span = 1e-9 * static_cast<double>(c.now_ns - window_start_ns_);
  if (span < opt_.window_s) return n;
  const uint64_t got = c.datagrams - window_first_.datagrams;
  const uint64_t bad = c.bad_datagrams - window_first_.bad_datagrams;
  const uint64_t rejected = c.rejected - window_first_.rejected;
  const uint64_t not_dtrack = c.not_dtrack - window_first_.not_dtrack;
  const uint64_t missing = c.missing - window_first_.missing;
  // counters sampled while the receiver counts: a datagram's category may show a sample later than it
  const uint64_t good = got > not_dtrack + missing ? got - not_dtrack - missing : 0;
  window_rate_hz_ = static_cast<double>(got) / span;
  window_good_hz_ = static_cast<double>(good) / span;
  const double rate = window_rate_hz_;

  const bool flood = rate_hz_ > 0 ? rate > opt_.flood_factor * rate_hz_ && rate > opt_.flood_hz / 10
                                  : rate > opt_.flood_hz;
  if (flood && !flooding_) {
    flooding_ = true;
    ++counts_.floods;
    HealthEvent* e = Emit(out, &n, EHealthEvent::Flood, t);
    if (rate_hz_ > 0)
      std::snprintf(e->text, sizeof(e->text), "flood: %.0f datagrams/s, %.0fx the tracker's %.1f Hz (the simulation takes the newest)",
                    rate, rate / rate_hz_, rate_hz_);
    else
      std::snprintf(e->text, sizeof(e->text), "flood: %.0f datagrams/s (the simulation takes the newest)", rate);
  } else if (!flood && flooding_) {
    flooding_ = false;
    window_disturbed_ = true;  // the window still holds part of the flood
    HealthEvent* e = Emit(out, &n, EHealthEvent::FloodOver, t);
    std::snprintf(e->text, sizeof(e->text), "flood over: %.1f datagrams/s", rate);
  }

  if (bad > 0 && !garbage_) {
    garbage_ = true;
    ++counts_.garbage_bursts;
    HealthEvent* e = Emit(out, &n, EHealthEvent::Garbage, t);
    std::snprintf(e->text, sizeof(e->text), "garbage: %llu of %llu datagrams in the last %.2f s did not parse (kept the last good targets)",
                  static_cast<unsigned long long>(bad), static_cast<unsigned long long>(got), span);
  } else if (bad == 0 && garbage_) {
    garbage_ = false;
    HealthEvent* e = Emit(out, &n, EHealthEvent::GarbageOver, t);
    std::snprintf(e->text, sizeof(e->text), "datagrams parse cleanly again");
  }

  if (rejected > 0 && !rejecting_) {
    rejecting_ = true;
    ++counts_.rejected_bursts;
    char ip[INET_ADDRSTRLEN] = "?";
    in_addr a;
    a.s_addr = c.last_rejected_addr;
    inet_ntop(AF_INET, &a, ip, sizeof(ip));
    HealthEvent* e = Emit(out, &n, EHealthEvent::Rejected, t);
    std::snprintf(e->text, sizeof(e->text), "rejecting datagrams from %s (not in the allow list): %.0f/s", ip,
                  static_cast<double>(rejected) / span);
  } else if (rejected == 0 && rejecting_) {
    rejecting_ = false;
    HealthEvent* e = Emit(out, &n, EHealthEvent::RejectedOver, t);
    std::snprintf(e->text, sizeof(e->text), "no more datagrams from senders outside the allow list (%llu rejected in all)",
                  static_cast<unsigned long long>(c.rejected));
  }

  if (not_dtrack > 0 && !not_dtrack_) {
    not_dtrack_ = true;
    ++counts_.not_dtrack_bursts;
    HealthEvent* e = Emit(out, &n, EHealthEvent::NotDTrack, t);
    std::snprintf(e->text, sizeof(e->text),
                  "datagrams are not DTrack: %llu of %llu in the last %.2f s hold no DTrack line (kept the last good targets)",
                  static_cast<unsigned long long>(not_dtrack), static_cast<unsigned long long>(got), span);
  } else if (not_dtrack == 0 && not_dtrack_) {
    not_dtrack_ = false;
    HealthEvent* e = Emit(out, &n, EHealthEvent::NotDTrackOver, t);
    std::snprintf(e->text, sizeof(e->text), "no more datagrams that are not DTrack");
  }

  // of the DTrack datagrams, the share that lacks the hand or bodies the scene needs
  const uint64_t dtrack = got > not_dtrack ? got - not_dtrack : 0;
  const double missing_share = dtrack > 0 ? static_cast<double>(missing) / static_cast<double>(dtrack) : 0.0;
  const char* what = c.missing_label ? c.missing_label : "the tracked objects";
  if (dtrack > 0 && missing_share >= opt_.missing_fraction && !missing_) {
    missing_ = true;
    ++counts_.missing_bursts;
    HealthEvent* e = Emit(out, &n, EHealthEvent::Missing, t);
    std::snprintf(e->text, sizeof(e->text),
                  "%s absent from %.0f %% of datagrams in the last %.2f s (%llu of %llu; fingertips hold, then release)",
                  what, 100.0 * missing_share, span, static_cast<unsigned long long>(missing),
                  static_cast<unsigned long long>(dtrack));
  } else if (missing_ && dtrack > 0 && missing_share < 0.2 * opt_.missing_fraction) {
    missing_ = false;
    HealthEvent* e = Emit(out, &n, EHealthEvent::MissingOver, t);
    std::snprintf(e->text, sizeof(e->text), "%s tracked again (in %.0f %% of datagrams)", what,
                  100.0 * (1.0 - missing_share));
  }

  // the tracker's rate (of good datagrams): settled when a clean window gives it; changed
  // when two clean windows in a row agree on a new one
  const bool clean = !window_disturbed_ && !silent_ && !flood && !flooding_ && got > 0 && bad == 0 &&
                     not_dtrack == 0 && missing == 0;
  if (clean) {
    const double tol = opt_.rate_tolerance;
    if (rate_hz_ <= 0.0) {
      rate_hz_ = rate;
      HealthEvent* e = Emit(out, &n, EHealthEvent::Rate, t);
      std::snprintf(e->text, sizeof(e->text), "tracker at %.1f Hz", rate);
    } else if (std::fabs(rate - rate_hz_) > tol * rate_hz_) {
      if (candidate_hz_ > 0.0 && std::fabs(rate - candidate_hz_) <= tol * candidate_hz_) {
        ++counts_.rate_changes;
        HealthEvent* e = Emit(out, &n, EHealthEvent::Rate, t);
        const double now_hz = 0.5 * (rate + candidate_hz_);
        std::snprintf(e->text, sizeof(e->text), "tracker rate changed from %.1f Hz to %.1f Hz", rate_hz_, now_hz);
        rate_hz_ = now_hz;
        candidate_hz_ = 0.0;
      } else {
        candidate_hz_ = rate;
      }
    } else {
      candidate_hz_ = 0.0;
      rate_hz_ += 0.1 * (rate - rate_hz_);  // follows slow drift
    }
  }
  window_start_ns_ = c.now_ns;
  window_first_ = c;
  // a window that starts before the first datagram holds the tracker's start, not its rate
  window_disturbed_ = silent_ || c.datagrams == 0;
  return n;
}

}  // namespace gs::tracking
