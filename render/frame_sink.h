// Where frames go: a PNG sequence (stb_image_write) or an MP4 through an ffmpeg
// pipe (libx264, yuv420p). Errors are reported, never fatal: a missing ffmpeg,
// an odd size (yuv420p needs even sides), a folder that cannot be made, an
// encoder that quits (its SIGPIPE is ignored and pclose's status checked).
#pragma once

#include <sys/types.h>

#include <cstdio>
#include <string>
#include <vector>

#include "render/image.h"

namespace gs::render {

class FrameSink {
 public:
  virtual ~FrameSink() = default;
  virtual bool Write(const Image& img, std::string* error) = 0;
  /// Flushes and closes; false when the output is incomplete.
  virtual bool Close(std::string* error) = 0;
  virtual int frames() const = 0;
};

/// DIR/frame_000000.png, frame_000001.png, ...
class PngSequence : public FrameSink {
 public:
  /// Creates the folder if needed; false when it cannot be made or written.
  bool Open(const std::string& dir, std::string* error);
  bool Write(const Image& img, std::string* error) override;
  bool Close(std::string* error) override;
  int frames() const override { return count_; }
  std::string FramePath(int i) const;

 private:
  std::string dir_;
  int count_ = 0;
};

/// An MP4 (or any container ffmpeg knows by the name's extension) encoded by ffmpeg.
class FfmpegVideo : public FrameSink {
 public:
  ~FfmpegVideo() override;
  bool Open(const std::string& path, int width, int height, int fps, std::string* error);
  bool Write(const Image& img, std::string* error) override;
  bool Close(std::string* error) override;
  int frames() const override { return count_; }

 private:
  bool Spawn(const std::string& exe, const std::string& path, int width, int height, int fps, std::string* error);
  FILE* pipe_ = nullptr;  ///< ffmpeg's stdin
  pid_t pid_ = -1;
  std::string path_;
  int width_ = 0, height_ = 0, count_ = 0;
  std::vector<uint8_t> rgb_;
};

/// Full path of an executable found on PATH, or "" (GRASPSIM_FFMPEG overrides ffmpeg's).
std::string FindExecutable(const std::string& name);

/// Writes one PNG (for tests and single figures).
bool WritePng(const std::string& path, const Image& img, std::string* error);

}  // namespace gs::render
