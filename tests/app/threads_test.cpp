// No render thread without an output, no tracking thread without a tracker
// (docs/skip.md): `graspsim run` of the paper grasp is watched from outside
// through /proc/PID/status while it runs; it must stay one thread. With
// --frames, the render thread shows up (so the watch does see threads).
// `replay` reads its log on the simulation thread and starts a render thread
// on the same FrameRecorder terms; only `live` and `record` receive datagrams
// on a thread of their own.
#include <gtest/gtest.h>

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace {

int ThreadsOf(pid_t pid) {
  const std::string path = "/proc/" + std::to_string(pid) + "/status";
  FILE* f = std::fopen(path.c_str(), "r");
  if (!f) return -1;
  char line[256];
  int threads = -1;
  while (std::fgets(line, sizeof line, f))
    if (std::sscanf(line, "Threads: %d", &threads) == 1) break;
  std::fclose(f);
  return threads;
}

struct Watched {
  int exit_code = -1;
  int max_threads = 0;
  int samples = 0;
};

// runs graspsim with `args`, sampling its thread count every half millisecond
Watched RunWatched(std::vector<std::string> args) {
  args.insert(args.begin(), GRASPSIM_BINARY);
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", 1 /*O_WRONLY*/, 0);
  pid_t pid = 0;
  Watched w;
  // Siconos Numerics (bench solver) links OpenBLAS, whose load starts a parked
  // pool of cores - 1 threads: told to use one, it starts none, and what is
  // counted is the threads of graspsim's own making
  std::vector<std::string> env_text;
  for (char** e = environ; *e; ++e)
    if (std::string(*e).rfind("OPENBLAS_NUM_THREADS=", 0) != 0) env_text.push_back(*e);
  env_text.push_back("OPENBLAS_NUM_THREADS=1");
  std::vector<char*> envp;
  for (std::string& e : env_text) envp.push_back(e.data());
  envp.push_back(nullptr);
  const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&fa);
  EXPECT_EQ(rc, 0);
  if (rc != 0) return w;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  for (;;) {
    int status = 0;
    const pid_t done = waitpid(pid, &status, WNOHANG);
    if (done == pid) {
      w.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
      break;
    }
    const int t = ThreadsOf(pid);
    if (t > 0) {
      w.max_threads = std::max(w.max_threads, t);
      ++w.samples;
    }
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      ADD_FAILURE() << "graspsim did not finish";
      break;
    }
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  return w;
}

// a light scene (the tracked fingertips' 3,000-point box on its table, held by the
// fingertips' start pose: its pairs take a few microseconds a step, far below
// WorldParams::lanes_from_s even on a machine busy with other work) starts no
// collision worker either; `--threads 1` never does. (The paper grasp's pairs take
// 0.09 ms a step, within a factor of two of the 0.15 ms threshold: on a loaded
// machine its run did start one, rightly.)
TEST(Threads, RunWithoutOutputOrTrackerIsOneThread) {
  const std::string out = std::string(::testing::TempDir()) + "/threads_run";
  const std::string light = std::string(GRASPSIM_SOURCE_DIR) + "/config/tracked_hand.yaml";
  const Watched w = RunWatched({"run", light, "--duration", "1", "--quiet", "--out", out});
  EXPECT_EQ(w.exit_code, 0);
  EXPECT_GT(w.samples, 20);
  EXPECT_EQ(w.max_threads, 1);
  const Watched one = RunWatched({"run", "--duration", "0.4", "--threads", "1", "--quiet", "--out", out});
  EXPECT_EQ(one.exit_code, 0);
  EXPECT_EQ(one.max_threads, 1);
}

TEST(Threads, RunWithFramesHasARenderThread) {
  const std::string frames = std::string(::testing::TempDir()) + "/threads_frames";
  std::system(("rm -rf " + frames + " && mkdir -p " + frames).c_str());
  const Watched w = RunWatched({"run", "--duration", "0.2", "--quiet", "--frames", frames, "--size", "80x60"});
  EXPECT_EQ(w.exit_code, 0);
  EXPECT_GT(w.max_threads, 1);
}

}  // namespace
