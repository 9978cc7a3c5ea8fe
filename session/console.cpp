#include "session/console.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>

namespace gs::app {
namespace {

std::atomic<bool> g_stop{false};

extern "C" void OnStopSignal(int sig) {
  if (g_stop.exchange(true)) {  // the second request: the default action, now
    std::signal(sig, SIG_DFL);
    std::raise(sig);
  }
}

double Seconds(std::chrono::steady_clock::duration d) { return std::chrono::duration<double>(d).count(); }

}  // namespace

void InstallStopSignals() {
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool StopRequested() { return g_stop.load(); }

void ClearStopRequest() { g_stop.store(false); }

bool StdoutIsTerminal() { return isatty(STDOUT_FILENO) == 1; }

Progress::Progress(std::string label, int64_t total, bool quiet)
    : label_(std::move(label)), total_(std::max<int64_t>(total, 1)), quiet_(quiet), tty_(StdoutIsTerminal()) {
  start_ = last_draw_ = std::chrono::steady_clock::now();
}

Progress::~Progress() {
  if (!finished_) Done();
}

void Progress::Update(int64_t done, const std::string& detail) {
  if (quiet_) return;
  last_done_ = done;
  const auto now = std::chrono::steady_clock::now();
  if (tty_) {
    if (Seconds(now - last_draw_) < 0.1 && done < total_) return;
  } else {
    const bool tenth = done * 10 >= next_tenth_ * total_;
    if (!tenth && Seconds(now - last_draw_) < 10.0) return;
    while (next_tenth_ * total_ <= done * 10) ++next_tenth_;
  }
  last_draw_ = now;
  Draw(done, detail, false);
}

void Progress::Done(const std::string& detail) {
  if (finished_) return;
  finished_ = true;
  if (quiet_) return;
  if (tty_ || !detail.empty()) Draw(last_done_, detail, true);
  if (tty_ && open_line_) std::printf("\n");
  open_line_ = false;
  std::fflush(stdout);
}

void Progress::Draw(int64_t done, const std::string& detail, bool final_line) {
  const double fraction = std::clamp(static_cast<double>(done) / static_cast<double>(total_), 0.0, 1.0);
  const double elapsed = Seconds(std::chrono::steady_clock::now() - start_);
  char eta[48] = "";
  if (!final_line && fraction > 0.02 && fraction < 1.0)
    std::snprintf(eta, sizeof eta, ", %.0f s left", elapsed * (1.0 - fraction) / fraction);
  if (tty_) {
    constexpr int kWidth = 24;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(static_cast<size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::printf("\r\033[K%s [%s] %3.0f%%  %s%s", label_.c_str(), bar.c_str(), 100.0 * fraction, detail.c_str(), eta);
    open_line_ = true;
  } else {
    std::printf("%s: %3.0f%%  %s%s\n", label_.c_str(), 100.0 * fraction, detail.c_str(), eta);
  }
  std::fflush(stdout);
}

}  // namespace gs::app
