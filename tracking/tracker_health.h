// Watches the tracker's stream from the outside: the counters the receiver
// thread keeps (datagrams, datagrams that did not parse, datagrams from senders
// outside the allow list, the last arrival) are sampled a few times a second by
// live's calling thread, and TrackerHealth turns them into events an operator can
// act on: the tracker went silent, came back, changed its frame rate, sends
// garbage, floods the port, or someone outside the allow list sends to it; and
// whether the datagrams carry what the scene needs (DTrack at all; the configured
// hand or bodies, tracked): the settled rate is that of the good datagrams only.
// Pure logic on the times and counts passed in (no clock, no I/O, no allocation
// after construction), so it is tested with made-up timelines.
#pragma once

#include <cstdint>

namespace gs::tracking {

struct HealthCounters {
  int64_t now_ns = 0;             ///< steady clock
  uint64_t datagrams = 0;         ///< accepted datagrams so far
  uint64_t bad_datagrams = 0;     ///< of those, the ones with a parse error
  uint64_t rejected = 0;          ///< datagrams from senders outside the allow list
  uint32_t last_rejected_addr = 0;  ///< IPv4, network byte order
  int64_t last_arrival_ns = -1;   ///< of the newest accepted datagram; -1: none yet
  /// What the datagrams carry (judged by the receiver: tracking/hand_mapping.h JudgeFrame).
  /// A datagram is good when it is neither of these: it carries every tracked object the
  /// scene needs. Left at 0, every accepted datagram counts as good.
  uint64_t not_dtrack = 0;        ///< datagrams with no DTrack line in them
  uint64_t missing = 0;           ///< DTrack datagrams without (or with untracked) what the scene needs
  const char* missing_label = nullptr;  ///< what the last of those lacked: "hand 0", "body 3" (static)
};

enum class EHealthEvent {
  NoData,       ///< nothing received since start
  Silent,       ///< the tracker stopped sending
  Back,         ///< it sends again
  Rate,         ///< its rate settled (first time) or changed
  Garbage,      ///< datagrams that do not parse
  GarbageOver,
  Flood,        ///< far more datagrams than the tracker's rate
  FloodOver,
  Rejected,     ///< datagrams from a sender outside the allow list
  RejectedOver,
  NotDTrack,    ///< datagrams that hold no DTrack line at all
  NotDTrackOver,
  Missing,      ///< DTrack datagrams without the hand or bodies the scene needs
  MissingOver,
};
const char* HealthEventName(EHealthEvent e);

struct HealthEvent {
  EHealthEvent kind = EHealthEvent::NoData;
  double t_s = 0.0;  ///< since Start
  char text[192] = {};
};

struct HealthOptions {
  double silent_after_s = 0.25;  ///< no datagram this long: silent
  double window_s = 0.5;         ///< rates are counted over windows this long
  double rate_tolerance = 0.2;   ///< a window rate this far (relative) from the settled rate is a change
  double flood_factor = 4.0;     ///< above this times the settled rate: a flood
  double flood_hz = 2000.0;      ///< with no settled rate yet: above this is a flood
  /// a window in which at least this fraction of the DTrack datagrams lacks what the
  /// scene needs begins a Missing event; it ends with a window where under a fifth of that does
  double missing_fraction = 0.5;
};

struct HealthCounts {
  int silences = 0, recoveries = 0, rate_changes = 0, garbage_bursts = 0, floods = 0, rejected_bursts = 0;
  int not_dtrack_bursts = 0, missing_bursts = 0;
};

class TrackerHealth {
 public:
  static constexpr int kMaxEvents = 8;  ///< at most this many events per Update

  explicit TrackerHealth(const HealthOptions& o = HealthOptions()) : opt_(o) {}
  void Start(int64_t t0_ns);
  /// Samples the counters; writes the new events to out (at most kMaxEvents) and returns their number.
  int Update(const HealthCounters& c, HealthEvent* out);

  bool silent() const { return silent_; }
  bool flooding() const { return flooding_; }
  double settled_rate_hz() const { return rate_hz_; }
  double window_rate_hz() const { return window_rate_hz_; }
  /// good datagrams (carrying what the scene needs) per second over the last window
  double window_good_hz() const { return window_good_hz_; }
  /// "ok", "waiting", "silent", "flood", "garbage", "rejecting", "not-dtrack", "missing"
  const char* state() const;
  const HealthCounts& counts() const { return counts_; }

 private:
  HealthEvent* Emit(HealthEvent* out, int* n, EHealthEvent kind, double t);

  HealthOptions opt_;
  int64_t t0_ = 0;
  bool started_ = false;
  bool no_data_reported_ = false;
  bool silent_ = false;
  int64_t silent_since_ns_ = 0;
  uint64_t datagrams_at_silence_ = 0;
  // the current counting window
  int64_t window_start_ns_ = 0;
  HealthCounters window_first_;
  bool window_disturbed_ = false;  ///< silence or restart inside: its rate means nothing
  double window_rate_hz_ = 0.0;
  // the settled rate and a candidate new one
  double rate_hz_ = 0.0;
  double candidate_hz_ = 0.0;
  double window_good_hz_ = 0.0;
  bool flooding_ = false, garbage_ = false, rejecting_ = false, not_dtrack_ = false, missing_ = false;
  HealthCounts counts_;
};

}  // namespace gs::tracking
