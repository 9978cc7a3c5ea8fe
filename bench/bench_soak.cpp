// `graspsim bench soak [--quick] [--json]`: the soak run (bench/soak.h) on the
// tracked-hand scene: a million steps (--quick: 50,000) of a looped session
// with the box held; resident memory growth after warm-up, the held box's
// drift, NaN, step times. Fails (exit 1) when memory grows by 1 MB or more,
// a NaN appears, or the box is no longer held at the end.
#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "bench/bench.h"
#include "scene/exit_code.h"
#include "scene/paths.h"
#include "bench/soak.h"

namespace gs::app {

int RunBenchSoak(const BenchOptions& opt) {
  SoakOptions so;
  so.scene = ResolveResource("config/tracked_hand.yaml");
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("graspsim_soak_" + std::to_string(getpid()));
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  so.work_dir = dir.string();
  so.steps = opt.quick ? 50000 : 1000000;
  so.warmup_steps = opt.quick ? 10000 : 0;
  so.progress = !opt.json;
  if (!opt.json)
    std::printf("soak: %s, %lld steps of a looped tracker session (grasp and lift once, then the held second "
                "again and again)\n", so.scene.c_str(), static_cast<long long>(so.steps));
  SoakResult r;
  std::string error;
  const bool ran = RunSoak(so, &r, &error);
  std::filesystem::remove_all(dir, ec);
  if (!ran) {
    std::fprintf(stderr, "bench soak: %s\n", error.c_str());
    return kExitBadInput;
  }
  const bool memory_ok = r.rss_growth_mb < 1.0;
  const bool held = r.lift_mm > 40.0;
  const bool pass = memory_ok && held && r.finite;
  if (opt.json) {
    std::printf("{\"bench\":\"soak\",\"steps\":%lld,\"loops\":%d,\"simulated_s\":%.3f,\"wall_s\":%.3f,"
                "\"step_median_ms\":%.5f,\"step_max_ms\":%.4f,\"datagrams\":%llu,\"finite\":%s,\"rss_warm_mb\":%.3f,"
                "\"rss_end_mb\":%.3f,\"rss_max_mb\":%.3f,\"drift_um\":%.4f,\"drift_rate_um_s\":%.6f,\"drift_deg\":%.6f,"
                "\"wobble_um\":%.4f,\"lift_mm\":%.3f,\"pass\":%s,\"rss_growth_mb\":%.4f}\n",
                static_cast<long long>(r.steps), r.loops, r.simulated_s, r.wall_s, r.step_median_ms, r.step_max_ms,
                static_cast<unsigned long long>(r.datagrams), r.finite ? "true" : "false", r.rss_warm_mb, r.rss_end_mb,
                r.rss_max_mb, r.drift_um, r.drift_rate_um_s, r.drift_deg, r.wobble_um, r.lift_mm,
                pass ? "true" : "false", r.rss_growth_mb);
  } else {
    std::printf("soak: %lld steps (%.0f s simulated, %d loops of the held second) in %.1f s wall; step median %.4f "
                "ms, max %.3f ms; %llu datagrams\n",
                static_cast<long long>(r.steps), r.simulated_s, r.loops, r.wall_s, r.step_median_ms, r.step_max_ms,
                static_cast<unsigned long long>(r.datagrams));
    std::printf("soak: resident %.2f MB after warm-up, %.2f MB at the end (growth %+.3f MB, limit 1 MB), at most "
                "%.2f MB\n", r.rss_warm_mb, r.rss_end_mb, r.rss_growth_mb, r.rss_max_mb);
    std::printf("soak: held box: drift %.3f um (%.5f um/s), %.5f deg; wobble %.3f um; %.2f mm above its start; "
                "%s\n", r.drift_um, r.drift_rate_um_s, r.drift_deg, r.wobble_um, r.lift_mm,
                r.finite ? "no NaN" : "NaN SEEN");
    std::printf("soak: %s\n", pass ? "pass" : "FAIL");
  }
  if (!pass)
    std::fprintf(stderr, "bench soak: failed:%s%s%s\n", memory_ok ? "" : " resident memory grew by 1 MB or more;",
                 held ? "" : " the box is no longer held;", r.finite ? "" : " NaN or Inf in a body's state;");
  return pass ? 0 : 1;
}

}  // namespace gs::app
