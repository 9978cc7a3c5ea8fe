// Helpers of the tracking tests: free UDP ports, running graspsim, file hashes.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "../shell.h"

extern char** environ;

namespace gs::tracking::test {

/// A UDP port that was free a moment ago on 127.0.0.1 (asked from the kernel).
inline int FreeUdpPort() {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof(sa));
  socklen_t len = sizeof(sa);
  getsockname(fd, reinterpret_cast<sockaddr*>(&sa), &len);
  close(fd);
  return ntohs(sa.sin_port);
}

/// A fresh empty folder under the build's temporary directory.
inline std::string TempDir(const std::string& name) {
  const std::filesystem::path p =
      std::filesystem::temp_directory_path() / ("graspsim_" + name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

using Result = ::gs::test::ShellResult;

/// Runs a shell command line, stdout and stderr captured (exit status, or 128 + signal).
inline Result Run(const std::string& cmd) { return ::gs::test::Sh(cmd); }

/// A process started in the background; Wait() collects its output.
class Background {
 public:
  explicit Background(const std::string& cmd) { pipe_ = popen((cmd + " 2>&1").c_str(), "r"); }
  ~Background() {
    if (pipe_) Wait();
  }
  /// Reads one line of the process's output (kept for Wait()); empty at end of output.
  std::string ReadLine() {
    std::string line;
    if (!pipe_) return line;
    char buf[4096];
    while (std::fgets(buf, sizeof(buf), pipe_)) {
      line += buf;
      if (!line.empty() && line.back() == '\n') break;
    }
    early_ += line;
    return line;
  }
  /// Reads lines until one holds `text` (true) or the output ends (false).
  bool ReadUntil(const std::string& text) {
    for (;;) {
      const std::string line = ReadLine();
      if (line.empty()) return false;
      if (line.find(text) != std::string::npos) return true;
    }
  }
  Result Wait() {
    Result r;
    r.output = early_;
    if (!pipe_) return r;
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof(buf), pipe_)) > 0) r.output.append(buf, n);
    const int status = pclose(pipe_);
    pipe_ = nullptr;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
  }

 private:
  FILE* pipe_ = nullptr;
  std::string early_;
};

/// A child process started directly (its pid known, so that the test can signal exactly it).
class Child {
 public:
  /// argv[0] is looked up on PATH; stdout and stderr go to `log`.
  Child(const std::vector<std::string>& argv, const std::string& log) {
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    if (posix_spawnp(&pid_, args[0], &fa, nullptr, args.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&fa);
  }
  ~Child() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      Wait();
    }
  }
  bool started() const { return pid_ > 0; }
  void Signal(int sig) {
    if (pid_ > 0) kill(pid_, sig);
  }
  /// Exit code (-1 when killed by a signal).
  int Wait() {
    if (pid_ <= 0) return -1;
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  pid_t pid_ = -1;
};

inline std::string ReadFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

/// FNV-1a, 64 bits.
inline uint64_t Hash(const std::string& s) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

inline std::string Binary() { return GRASPSIM_BINARY; }

}  // namespace gs::tracking::test
