// The soak run of issue 7: a recorded tracker session replayed in a loop for a
// million steps, in the process, through the replay path (session log reader ->
// DTrack parser -> fingertip targets -> world step). The session is written
// first: the synthetic hand reaches for the box, closes and lifts it (2.1 s),
// then one second of the hand holding still; the replay plays the grasp once
// and then loops the held second, reading it from the log again each time.
// Measured: resident memory after warm-up and at the end (it must not grow:
// nothing in the step allocates), the held object's pose drift (it must not
// creep out of the grasp), NaN, and the step time.
#pragma once

#include <cstdint>
#include <string>

namespace gs::app {

struct SoakOptions {
  std::string scene;         ///< a scene with a tracker section (the box and three fingertips)
  std::string work_dir;      ///< where the session log is written
  int64_t steps = 1000000;
  int64_t warmup_steps = 0;  ///< 0: a tenth of the steps, at least 5,000
  bool progress = false;     ///< print memory and drift every tenth of the run
};

struct SoakResult {
  int64_t steps = 0;
  int loops = 0;                   ///< passes over the held second
  double simulated_s = 0.0, wall_s = 0.0;
  double step_median_ms = 0.0, step_max_ms = 0.0;
  double rss_warm_mb = 0.0, rss_end_mb = 0.0, rss_max_mb = 0.0;
  double rss_growth_mb = 0.0;      ///< end minus warm-up
  // the held object's pose, from the end of warm-up to the end
  double drift_um = 0.0;           ///< between the mean positions of the first and last 5% of the held samples
  double drift_rate_um_s = 0.0;    ///< drift_um over the time between those windows
  double drift_deg = 0.0;          ///< the same for the orientation
  double wobble_um = 0.0;          ///< largest distance of any held sample from the first window's mean
  double lift_mm = 0.0;            ///< height above its start at the end (the box is still held)
  bool finite = true;              ///< no NaN or Inf in any body's state, ever
  uint64_t datagrams = 0;
};

/// False with a message when the scene or the log cannot be used.
bool RunSoak(const SoakOptions& opt, SoakResult* out, std::string* error);

}  // namespace gs::app
