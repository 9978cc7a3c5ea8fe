#include "session/tracker_app.h"

#include <unistd.h>

#include <atomic>
#include <csignal>

namespace gs::app {
namespace {

std::atomic<bool> g_stop{false};

extern "C" void OnStopSignal(int) { g_stop.store(true); }

}  // namespace

void InstallStopSignals() {
  g_stop = false;
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool StopRequested() { return g_stop.load(); }

bool StdoutIsTerminal() { return isatty(STDOUT_FILENO) == 1; }

std::string FormatParseErrors(const tracking::ParseStats& s) {
  std::string out = std::to_string(s.TotalErrors());
  std::string detail;
  for (int i = 0; i < static_cast<int>(tracking::EParseError::Count); ++i) {
    if (!s.errors[i]) continue;
    detail += (detail.empty() ? "" : ", ") + std::string(tracking::ErrorName(static_cast<tracking::EParseError>(i))) +
              " " + std::to_string(s.errors[i]);
  }
  return detail.empty() ? out : out + " (" + detail + ")";
}

std::string ParseErrorsJson(const tracking::ParseStats& s) {
  std::string out = "{";
  for (int i = 0; i < static_cast<int>(tracking::EParseError::Count); ++i) {
    if (i) out += ",";
    out += "\"" + std::string(tracking::ErrorName(static_cast<tracking::EParseError>(i))) +
           "\":" + std::to_string(s.errors[i]);
  }
  return out + "}";
}

}  // namespace gs::app
