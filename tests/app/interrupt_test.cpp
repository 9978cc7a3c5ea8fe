// Ctrl-C and SIGTERM end every long command the same way (session/console.h):
// it stops at its next step, writes what it computed (the --out files, a video
// finalised up to its last frame, a summary marked interrupted) and exits 130.
// The signal goes to the command's whole process group, as a terminal's Ctrl-C
// does, so that an encoder child would be hit too. Each test waits for a state
// the command reports (a file's rows, a printed line) before signalling.
// Also: the outputs are checked before any work (a bad --video or --out is refused
// before the scene is built).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

#include "../shell.h"

namespace {

std::string ReadFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

size_t Lines(const std::string& path) {
  const std::string t = ReadFile(path);
  return static_cast<size_t>(std::count(t.begin(), t.end(), '\n'));
}

std::string TempDir(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() / ("graspsim_interrupt_" + name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

bool HaveProgram(const char* name) { return std::system((std::string("command -v ") + name + " >/dev/null").c_str()) == 0; }

/// graspsim ARGS in a process group of its own, stdout and stderr into `log`.
class Command {
 public:
  Command(const std::vector<std::string>& args, const std::string& log) : log_(log) {
    std::vector<std::string> argv = {GRASPSIM_BINARY};
    argv.insert(argv.end(), args.begin(), args.end());
    std::vector<char*> p;
    for (std::string& a : argv) p.push_back(a.data());
    p.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attr, 0);
    if (posix_spawn(&pid_, p[0], &fa, &attr, p.data(), environ) != 0) pid_ = -1;
    posix_spawnattr_destroy(&attr);
    posix_spawn_file_actions_destroy(&fa);
  }
  ~Command() {
    if (pid_ > 0) {
      kill(-pid_, SIGKILL);
      Wait();
    }
  }
  /// Like a terminal's Ctrl-C: the signal reaches the whole process group.
  void SignalGroup(int sig) {
    if (pid_ > 0) kill(-pid_, sig);
  }
  /// Waits (up to 10 minutes) for `done` to hold; false when the command ended first or time ran out.
  template <class F>
  bool WaitFor(F done) {
    for (int i = 0; i < 6000; ++i) {
      if (done()) return true;
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        return done();
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return false;
  }
  bool WaitForText(const std::string& text) {
    return WaitFor([&] { return ReadFile(log_).find(text) != std::string::npos; });
  }
  /// Exit status, or 128 + signal.
  int Wait() {
    if (pid_ > 0) {
      int status = 0;
      waitpid(pid_, &status, 0);
      pid_ = -1;
      code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }
    return code_;
  }
  std::string Output() const { return ReadFile(log_); }

 private:
  std::string log_;
  pid_t pid_ = -1;
  int code_ = -1;
};

double NumberAfter(const std::string& text, const std::string& key) {
  const size_t at = text.find(key);
  return at == std::string::npos ? -1.0 : std::strtod(text.c_str() + at + key.size(), nullptr);
}

TEST(Interrupt, RunWritesEveryStepItMadeAPlayableVideoAndExits130) {
  const std::string dir = TempDir("run");
  const bool video = HaveProgram("ffmpeg") && HaveProgram("ffprobe");
  std::vector<std::string> args = {"run", "config/paper_box_grasp.yaml", "--duration", "60", "--out", dir + "/out"};
  if (video) args.insert(args.end(), {"--video", dir + "/grasp.mp4", "--size", "160x120"});
  Command run(args, dir + "/log.txt");
  // trajectory.csv reaches the OS every 1,000 steps: the run is well under way
  ASSERT_TRUE(run.WaitFor([&] { return Lines(dir + "/out/trajectory.csv") >= 1000; })) << run.Output();
  run.SignalGroup(SIGINT);
  EXPECT_EQ(run.Wait(), 130) << run.Output();
  const std::string out = run.Output();
  EXPECT_NE(out.find("run: interrupted at t="), std::string::npos) << out;
  const std::string summary = ReadFile(dir + "/out/summary.json");
  ASSERT_FALSE(summary.empty()) << out;
  EXPECT_NE(summary.find("\"interrupted\":true"), std::string::npos) << summary;
  const double steps = NumberAfter(summary, "\"steps\":");
  EXPECT_GE(steps, 999) << summary;
  EXPECT_LT(steps, 60000) << summary;
  // every step made is in the files: the header and step 0, then one row per step
  EXPECT_EQ(Lines(dir + "/out/trajectory.csv"), static_cast<size_t>(steps) + 2);
  EXPECT_EQ(Lines(dir + "/out/timings.csv"), static_cast<size_t>(steps) + 1);
  if (video) {
    // the encoder was spared the group's signal and closed the file: it plays, as long as the run went
    const std::string cmd = "ffprobe -v error -show_entries format=duration -of csv=p=0 '" + dir + "/grasp.mp4'";
    FILE* p = popen(cmd.c_str(), "r");
    ASSERT_NE(p, nullptr);
    char buf[64] = "";
    const bool read = std::fgets(buf, sizeof buf, p) != nullptr;
    pclose(p);
    ASSERT_TRUE(read) << "ffprobe cannot read the video\n" << out;
    EXPECT_NEAR(std::strtod(buf, nullptr), steps * 1e-3, 0.2) << buf;
  }
  std::filesystem::remove_all(dir);
}

TEST(Interrupt, ValidateKeepsTheCasesItFinishedAndExits130) {
  const std::string dir = TempDir("validate");
  Command v({"validate", "all"}, dir + "/log.txt");
  // the first case's verdict line
  ASSERT_TRUE(v.WaitFor([&] { return v.Output().find(" error ") != std::string::npos; })) << v.Output();
  v.SignalGroup(SIGINT);
  EXPECT_EQ(v.Wait(), 130) << v.Output();
  const std::string out = v.Output();
  EXPECT_NE(out.find("interrupted"), std::string::npos) << out;
  EXPECT_NE(out.find("not run: "), std::string::npos) << out;  // the later families
  EXPECT_GE(NumberAfter(out, "validate: "), 1) << out;        // the finished case kept its verdict
  std::filesystem::remove_all(dir);
}

// a case cut short has no verdict in JSON either: pass null, never false (a reader
// that stops validate on a clock must not count the case it cut as failed). The stop
// comes once the slide family is written, while the hertz family runs (seconds long),
// whose cases come out cut short.
TEST(Interrupt, ValidateJsonGivesACaseCutShortNoVerdict) {
  const std::string dir = TempDir("validate_json");
  Command v({"validate", "all", "--json", "--quick"}, dir + "/log.txt");
  ASSERT_TRUE(v.WaitForText("\"slide_flat_rigid_one-pass\"")) << v.Output();
  v.SignalGroup(SIGTERM);
  EXPECT_EQ(v.Wait(), 130) << v.Output();
  const std::string out = v.Output();
  EXPECT_EQ(out.find("\"pass\":false"), std::string::npos) << out;  // the finished cases pass
  int cut = 0;
  for (size_t at = out.find("\"interrupted\":true"); at != std::string::npos;
       at = out.find("\"interrupted\":true", at + 1), ++cut) {
    const size_t line = out.rfind('\n', at);
    const size_t begin = line == std::string::npos ? 0 : line + 1;
    EXPECT_NE(out.substr(begin, at - begin).find("\"pass\":null"), std::string::npos) << out;
  }
  EXPECT_GE(cut, 1) << out;
  std::filesystem::remove_all(dir);
}

TEST(Interrupt, StressEndsWithASummaryMarkedInterrupted) {
  const std::string dir = TempDir("stress");
  Command s({"stress", "--json"}, dir + "/log.txt");
  ASSERT_TRUE(s.WaitForText("{\"name\":")) << s.Output();
  s.SignalGroup(SIGTERM);
  EXPECT_EQ(s.Wait(), 130) << s.Output();
  const std::string out = s.Output();
  const size_t last = out.rfind("{\"summary\":\"stress\"");
  ASSERT_NE(last, std::string::npos) << out;
  EXPECT_NE(out.find("\"interrupted\":true", last), std::string::npos) << out;
  EXPECT_NE(out.find("\"pass\":false", last), std::string::npos) << out;
  std::filesystem::remove_all(dir);
}

TEST(Interrupt, ReplayWithAVideoWritesItsOutputsAndExits130) {
  // skipped without ffmpeg: the test is about the video an interrupted replay leaves (setup.sh installs it)
  if (!HaveProgram("ffmpeg")) GTEST_SKIP() << "ffmpeg is not installed (scripts/setup.sh installs it)";
  const std::string dir = TempDir("replay");
  Command r({"replay", "--realtime", "config/tracked_hand.yaml", std::string(GRASPSIM_SOURCE_DIR) + "/assets/demo_session.lcmlog",
             "--out", dir + "/out", "--video", dir + "/replay.mp4", "--size", "160x120", "--tail", "60"},
            dir + "/log.txt");
  // a progress line (one per tenth through a pipe): the replay is simulating, about a
  // minute of paced session ahead of it (--tail 60), so the signal comes before its end
  ASSERT_TRUE(r.WaitForText("replay:  1")) << r.Output();
  r.SignalGroup(SIGINT);
  const int code = r.Wait();
  const std::string out = r.Output();
  EXPECT_NE(out.find("replay: interrupted"), std::string::npos) << out;
  EXPECT_EQ(code, 130) << out;
  const std::string summary = ReadFile(dir + "/out/summary.json");
  EXPECT_NE(summary.find("\"interrupted\":true"), std::string::npos) << out;
  EXPECT_GT(Lines(dir + "/out/trajectory.csv"), 2u) << out;
  EXPECT_GT(std::filesystem::file_size(dir + "/replay.mp4"), 1000u) << out;  // not the 48-byte stub of a killed encoder
  std::filesystem::remove_all(dir);
}

// ---- outputs checked before any work ----

using Result = gs::test::ShellResult;
using gs::test::Sh;

TEST(CheckBeforeWork, RunRefusesBadOutputsBeforeBuildingTheScene) {
  const std::string dir = TempDir("check");
  const std::string run = std::string(GRASPSIM_BINARY) + " run config/paper_box_grasp.yaml --duration 0.01 ";
  Result r = Sh(run + "--video " + dir + "/grasp.avi");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--video " + dir + "/grasp.avi"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("'.avi'"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("built in"), std::string::npos) << "the scene was built first\n" << r.output;
  std::ofstream(dir + "/plain_file") << "x";
  r = Sh(run + "--out " + dir + "/plain_file/out");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--out " + dir + "/plain_file/out"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("built in"), std::string::npos) << r.output;
  r = Sh(run + "--frames " + dir + "/f --size 640by480");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_EQ(r.output.find("built in"), std::string::npos) << r.output;
  // the --out folder is made first: a video may go into it
  if (HaveProgram("ffmpeg")) {
    r = Sh(run + "--out " + dir + "/new --video " + dir + "/new/grasp.mp4 --size 64x48 --quiet");
    EXPECT_EQ(r.code, 0) << r.output;
  }
    // replay checks its outputs before it reads the log or builds the scene
  r = Sh(std::string(GRASPSIM_BINARY) + " replay " + dir + "/no_such.lcmlog --video " + dir + "/x.gif");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("'.gif'"), std::string::npos) << r.output;
  std::filesystem::remove_all(dir);
}

}  // namespace
