// The live view (issue 22): `--view [ADDR:]PORT` on `live` and `replay` serves a
// page that draws the grasp as it happens in the browser (three.js, WebGL, all
// files served from the binary: nothing is fetched from the internet).
//
// Threads: the view is a SnapshotReader of the FrameRecorder (session/frame_recorder.h),
// so it reads the very snapshots the off-screen renderer reads, on the render
// thread, at the frame rate (--fps, 30 by default); in live the simulation thread
// only fills a fixed pool of snapshots and drops frames rather than wait. Read()
// encodes a snapshot into a JSON string and swaps it in under a short lock; the
// HTTP server (cpp-httplib) answers on its own threads (nice 10, off the
// simulation's core), each client holding its own reference to the frame it
// sends, so a client that stalls or disconnects holds up nothing but itself.
//
// Endpoints: /  (the page), /view.js, /three.module.min.js, /OrbitControls.js,
// /scene.json (static: camera, bodies' rest points at reduced density), and
// /state.json?after=N (the newest frame; waits up to 1 s for one newer than N).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/snapshot.h"
#include "scene/scene_file.h"
#include "session/frame_recorder.h"

namespace httplib {
class Server;
}

namespace gs::view {

/// "8080" (every interface), "127.0.0.1:8080", "0" (any free port); false with a message.
bool ParseViewAddress(const std::string& text, std::string* host, int* port, std::string* error);

class LiveView final : public app::SnapshotReader {
 public:
  LiveView();
  ~LiveView() override;
  LiveView(const LiveView&) = delete;
  LiveView& operator=(const LiveView&) = delete;

  /// Builds the static scene data, binds ADDR:PORT and starts serving; prints
  /// "view: serving http://HOST:PORT/". `avoid_cpu`: keep the server's threads off this core.
  bool Start(const std::string& address, const app::BuiltScene& scene, std::string* error, int avoid_cpu = -1);
  /// Stops serving (waiting clients are answered at once); prints a summary line unless quiet.
  void Stop(bool quiet = false);
  void Read(const WorldSnapshot& s) override;  ///< render thread

  int port() const { return port_; }
  std::string url() const;
  int64_t frames() const { return frames_.load(std::memory_order_relaxed); }
  int64_t requests() const { return requests_.load(std::memory_order_relaxed); }

 private:
  std::string Encode(const WorldSnapshot& s, int64_t frame);
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  std::string host_;
  int port_ = 0;
  std::shared_ptr<const SnapshotRig> rig_;
  std::vector<std::vector<int>> kept_;  ///< per body, the surface points sent (every k-th)
  std::vector<bool> fingertip_;
  int tracked_ = -1;
  double force_scale_ = 0.01;
  std::string scene_json_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::shared_ptr<const std::string> latest_;  ///< the newest frame's JSON
  int64_t latest_frame_ = 0;
  bool stopping_ = false;
  std::atomic<int64_t> frames_{0}, requests_{0};
  std::string buf_;  ///< render thread's encoding buffer
};

}  // namespace gs::view
