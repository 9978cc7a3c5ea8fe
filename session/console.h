// What every long command shares with the person at the console: Ctrl-C and
// SIGTERM as a request to stop (the command ends at its next step, writes what
// it has and exits 130), and progress shown as a bar on a terminal, as plain
// periodic lines through a pipe, or not at all with --quiet.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace gs::app {

/// SIGINT and SIGTERM set a flag instead of killing the process; a second
/// signal while the first is being honoured ends the process at once (the
/// default action), for a command stuck where it cannot look at the flag.
/// Idempotent: installing again keeps a request already made.
void InstallStopSignals();
/// A stop was requested (any thread).
bool StopRequested();
/// For tests and for commands that serve several sessions: forget a request.
void ClearStopRequest();

/// True when stdout is a terminal (progress bars and status lines only then).
bool StdoutIsTerminal();

/// Progress of one long piece of work of `total` units. On a terminal, one
/// line redrawn at most 10 times a second; through a pipe, a plain line at
/// every tenth of the work (and at least every 10 s of wall time); nothing
/// when quiet. `Done` ends the bar's line.
class Progress {
 public:
  Progress(std::string label, int64_t total, bool quiet);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;
  /// `done` units of `total` are finished; `detail` is shown after the count.
  void Update(int64_t done, const std::string& detail = std::string());
  /// Closes the bar's line (a terminal) or prints the last line (a pipe).
  void Done(const std::string& detail = std::string());
  bool tty() const { return tty_; }

 private:
  void Draw(int64_t done, const std::string& detail, bool final_line);
  std::string label_;
  int64_t total_;
  bool quiet_, tty_, open_line_ = false, finished_ = false;
  int64_t next_tenth_ = 1, last_done_ = 0;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace gs::app
