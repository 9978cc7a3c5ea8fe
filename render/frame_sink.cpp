// PNG sequences through stb_image_write (header-only here) and MP4 through ffmpeg.
#define STB_IMAGE_WRITE_IMPLEMENTATION
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#include <stb/stb_image_write.h>
#pragma GCC diagnostic pop

#include "render/frame_sink.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <vector>

extern char** environ;

namespace gs::render {

std::string FindExecutable(const std::string& name) {
  if (name == "ffmpeg") {
    if (const char* o = std::getenv("GRASPSIM_FFMPEG")) {
      return access(o, X_OK) == 0 ? std::string(o) : std::string();
    }
  }
  const char* path = std::getenv("PATH");
  if (!path) return "";
  std::string p = path;
  size_t start = 0;
  while (start <= p.size()) {
    const size_t end = std::min(p.find(':', start), p.size());
    const std::string dir = p.substr(start, end - start);
    if (!dir.empty()) {
      const std::string full = dir + "/" + name;
      struct stat st;
      if (stat(full.c_str(), &st) == 0 && S_ISREG(st.st_mode) && access(full.c_str(), X_OK) == 0) return full;
    }
    start = end + 1;
  }
  return "";
}

bool WritePng(const std::string& path, const Image& img, std::string* error) {
  stbi_write_png_compression_level = 4;  // about twice as fast as the default 8, files ~10% larger
  if (!stbi_write_png(path.c_str(), img.width, img.height, 4, img.rgba.data(), img.width * 4)) {
    *error = "cannot write " + path + ": " + std::strerror(errno);
    return false;
  }
  return true;
}

bool PngSequence::Open(const std::string& dir, std::string* error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    *error = "--frames: cannot create folder " + dir + (ec ? ": " + ec.message() : std::string(": not a folder"));
    return false;
  }
  dir_ = dir;
  count_ = 0;
  return true;
}

std::string PngSequence::FramePath(int i) const {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%06d.png", i);
  return dir_ + "/" + name;
}

bool PngSequence::Write(const Image& img, std::string* error) {
  if (!WritePng(FramePath(count_), img, error)) return false;
  ++count_;
  return true;
}

bool PngSequence::Close(std::string*) { return true; }

FfmpegVideo::~FfmpegVideo() {
  if (!pipe_) return;
  std::fclose(pipe_);
  int status = 0;
  waitpid(pid_, &status, 0);
}

// ffmpeg runs in a process group of its own: the terminal's Ctrl-C reaches only
// graspsim, which stops at its next step and closes the video properly (an
// encoder killed with us would leave an unplayable file without its index).
bool FfmpegVideo::Spawn(const std::string& exe, const std::string& path, int width, int height, int fps,
                        std::string* error) {
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  const std::string rate = std::to_string(fps);
  std::vector<std::string> argv = {exe, "-nostdin", "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt",
                                   "rgb24", "-s", size, "-r", rate, "-i", "-", "-c:v", "libx264", "-preset",
                                   "veryfast", "-crf", "20", "-pix_fmt", "yuv420p", "-movflags", "+faststart", path};
  std::vector<char*> args;
  for (std::string& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) {
    *error = "--video: cannot start ffmpeg: " + std::string(std::strerror(errno));
    return false;
  }
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, fds[0], STDIN_FILENO);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attr, 0);
  const int rc = posix_spawn(&pid_, exe.c_str(), &fa, &attr, args.data(), environ);
  posix_spawnattr_destroy(&attr);
  posix_spawn_file_actions_destroy(&fa);
  close(fds[0]);
  if (rc != 0) {
    close(fds[1]);
    *error = "--video: cannot start ffmpeg (" + exe + "): " + std::string(std::strerror(rc));
    return false;
  }
  pipe_ = fdopen(fds[1], "w");
  if (!pipe_) {
    close(fds[1]);
    waitpid(pid_, nullptr, 0);
    *error = "--video: cannot write to ffmpeg: " + std::string(std::strerror(errno));
    return false;
  }
  return true;
}

bool FfmpegVideo::Open(const std::string& path, int width, int height, int fps, std::string* error) {
  if (width % 2 != 0 || height % 2 != 0) {
    *error = "--video: the size " + std::to_string(width) + "x" + std::to_string(height) +
             " has an odd side; H.264 (yuv420p) needs even width and height";
    return false;
  }
  if (fps < 1 || fps > 240) {
    *error = "--video: frame rate " + std::to_string(fps) + " is out of range (1 to 240)";
    return false;
  }
  const std::string exe = FindExecutable("ffmpeg");
  if (exe.empty()) {
    *error = "--video: ffmpeg was not found on PATH (install it: apt-get install ffmpeg), or use --frames DIR";
    return false;
  }
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty() && !std::filesystem::is_directory(parent)) {
    *error = "--video: folder " + parent.string() + " does not exist";
    return false;
  }
  // the encoder quitting must give an error, not kill us
  signal(SIGPIPE, SIG_IGN);
  if (!Spawn(exe, path, width, height, fps, error)) return false;
  path_ = path;
  width_ = width;
  height_ = height;
  count_ = 0;
  rgb_.resize(static_cast<size_t>(width) * height * 3);
  return true;
}

bool FfmpegVideo::Write(const Image& img, std::string* error) {
  if (!pipe_) {
    *error = "--video: the encoder is not running";
    return false;
  }
  if (img.width != width_ || img.height != height_) {
    *error = "--video: frame size changed";
    return false;
  }
  const size_t n = static_cast<size_t>(width_) * height_;
  for (size_t i = 0; i < n; ++i) {
    rgb_[3 * i] = img.rgba[4 * i];
    rgb_[3 * i + 1] = img.rgba[4 * i + 1];
    rgb_[3 * i + 2] = img.rgba[4 * i + 2];
  }
  if (std::fwrite(rgb_.data(), 1, rgb_.size(), pipe_) != rgb_.size()) {
    *error = "--video: ffmpeg stopped reading frames (" + std::string(std::strerror(errno)) +
             "); its message, if any, is above";
    return false;
  }
  ++count_;
  return true;
}

bool FfmpegVideo::Close(std::string* error) {
  if (!pipe_) return true;
  std::fclose(pipe_);
  pipe_ = nullptr;
  int status = 0;
  if (waitpid(pid_, &status, 0) == -1) {
    *error = "--video: cannot wait for ffmpeg: " + std::string(std::strerror(errno));
    return false;
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    *error = "--video: ffmpeg failed writing " + path_ + " (exit status " +
             std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status)) + ")";
    return false;
  }
  return true;
}

}  // namespace gs::render
