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

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>

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

namespace {
std::string ShellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}
}  // namespace

FfmpegVideo::~FfmpegVideo() {
  if (pipe_) pclose(pipe_);
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
  const std::string cmd = ShellQuote(exe) + " -nostdin -y -loglevel error -f rawvideo -pix_fmt rgb24 -s " +
                          std::to_string(width) + "x" + std::to_string(height) + " -r " + std::to_string(fps) +
                          " -i - -c:v libx264 -preset veryfast -crf 20 -pix_fmt yuv420p -movflags +faststart " +
                          ShellQuote(path);
  pipe_ = popen(cmd.c_str(), "w");
  if (!pipe_) {
    *error = "--video: cannot start ffmpeg: " + std::string(std::strerror(errno));
    return false;
  }
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
  const int status = pclose(pipe_);
  pipe_ = nullptr;
  if (status == -1) {
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
