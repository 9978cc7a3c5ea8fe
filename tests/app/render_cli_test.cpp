// Rendering from the commands (docs/render.md): run and replay write one frame
// per 1/fps simulated seconds, two replays of a log write identical frames, a
// replay frame matches its golden, and bad render options (odd size, missing
// ffmpeg, folders that cannot be written, an encoder that quits) end with a
// message naming the problem instead of a crash or a SIGPIPE death.
// GRASPSIM_UPDATE_GOLDEN=1 rewrites the golden (look at it before committing).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#define STB_IMAGE_IMPLEMENTATION
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#include <stb/stb_image.h>
#pragma GCC diagnostic pop

#include "../shell.h"

namespace {

using Result = gs::test::ShellResult;
using gs::test::Sh;

std::string Bin() { return GRASPSIM_BINARY; }
std::string Src(const std::string& rel) { return std::string(GRASPSIM_SOURCE_DIR) + "/" + rel; }
std::string Data(const std::string& rel) { return std::string(GRASPSIM_TEST_DATA) + "/" + rel; }
const std::string kScene = Data("tracking/tracked_hand_light.yaml");

std::string TempDir(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() / ("graspsim_render_cli_" + name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

// FNV-1a of a file's bytes
uint64_t HashFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream ss;
  ss << f.rdbuf();
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : ss.str()) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::map<std::string, uint64_t> HashFolder(const std::string& dir) {
  std::map<std::string, uint64_t> out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) out[e.path().filename().string()] = HashFile(e.path());
  return out;
}

std::string Replay(const std::string& frames, const std::string& size = "160x120") {
  return Bin() + " replay " + kScene + " " + Src("assets/demo_session.lcmlog") + " --duration 0.6 --quiet --size " +
         size + " --frames " + frames;
}

TEST(RenderCli, TwoReplaysRenderIdenticalFramesAtFixedSimulatedTimes) {
  const std::string dir = TempDir("replay");
  std::map<std::string, uint64_t> hashes[2];
  for (int run = 0; run < 2; ++run) {
    const std::string frames = dir + "/frames" + std::to_string(run);
    const Result r = Sh(Replay(frames));
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("rendered 19 frames at 160x120"), std::string::npos) << r.output;
    hashes[run] = HashFolder(frames);
  }
  // frames k = 0..18 at k / 30 s up to 0.6 s
  ASSERT_EQ(hashes[0].size(), 19u);
  EXPECT_TRUE(hashes[0].count("frame_000018.png"));
  EXPECT_EQ(hashes[0], hashes[1]) << "two replays of the same log rendered different frames";
  // the frames change as the fingertips move: not one picture repeated
  EXPECT_NE(hashes[0]["frame_000001.png"], hashes[0]["frame_000018.png"]);
}

// compares a frame with a golden in tests/data/render: at most 1% of the pixels
// may differ by more than 48 in a channel (GRASPSIM_UPDATE_GOLDEN=1 rewrites it)
void ExpectMatchesGolden(const std::string& frame, const std::string& name) {
  const std::string golden = Data("render/" + name);
  if (std::getenv("GRASPSIM_UPDATE_GOLDEN")) {
    std::filesystem::copy_file(frame, golden, std::filesystem::copy_options::overwrite_existing);
    return;
  }
  int w = 0, h = 0, n = 0, gw = 0, gh = 0;
  unsigned char* a = stbi_load(frame.c_str(), &w, &h, &n, 3);
  unsigned char* b = stbi_load(golden.c_str(), &gw, &gh, &n, 3);
  ASSERT_NE(a, nullptr) << "cannot read " << frame;
  ASSERT_NE(b, nullptr) << "no golden " << golden << " (GRASPSIM_UPDATE_GOLDEN=1 writes it)";
  ASSERT_EQ(w, gw);
  ASSERT_EQ(h, gh);
  int bad = 0;
  for (int i = 0; i < w * h; ++i) {
    int d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int(a[3 * i + c]) - int(b[3 * i + c])));
    bad += d > 48;
  }
  stbi_image_free(a);
  stbi_image_free(b);
  EXPECT_LE(bad, w * h / 100) << bad << " pixels differ from " << golden
                              << "; if the change is intended, rerun with GRASPSIM_UPDATE_GOLDEN=1 and look at it";
}

TEST(RenderCli, ReplayFrameMatchesItsGolden) {
  const std::string dir = TempDir("golden");
  const Result r = Sh(Replay(dir + "/frames"));
  ASSERT_EQ(r.code, 0) << r.output;
  ExpectMatchesGolden(dir + "/frames/frame_000018.png", "replay_tracked_hand_light_t0.6_160x120.png");
}

// the paper's grasp as `graspsim run` frames it by default: box, three fingers,
// table with shadows, HUD and legend (frame 0: no simulation needed)
TEST(RenderCli, PaperSceneFirstFrameMatchesItsGolden) {
  const std::string dir = TempDir("paper");
  const Result r = Sh(Bin() + " run " + Src("config/paper_box_grasp.yaml") +
                      " --duration 0.001 --quiet --size 320x240 --frames " + dir + "/frames");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("rendered 1 frames at 320x240"), std::string::npos) << r.output;
  ExpectMatchesGolden(dir + "/frames/frame_000000.png", "paper_box_grasp_t0_320x240.png");
}

TEST(RenderCli, RunWritesAFramePerFrameTimeAndAVideo) {
  const std::string dir = TempDir("run");
  const bool ffmpeg = Sh("command -v ffmpeg").code == 0;
  const Result r = Sh(Bin() + " run " + kScene + " --duration 0.2 --quiet --size 64x48 --frames " + dir +
                       "/frames" + (ffmpeg ? " --video " + dir + "/clip.mp4" : std::string()));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(HashFolder(dir + "/frames").size(), 7u) << r.output;  // 0 .. 0.2 s at 30 fps
  if (ffmpeg) {
    EXPECT_GT(std::filesystem::file_size(dir + "/clip.mp4"), 500u);
  }
}

TEST(RenderCli, BadRenderOptionsAreRefusedWithAMessage) {
  const std::string dir = TempDir("bad");
  const std::string run = Bin() + " run " + kScene + " --duration 0.05 --quiet ";
  // odd size with a video
  Result r = Sh(run + "--size 161x120 --video " + dir + "/a.mp4");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("odd side"), std::string::npos) << r.output;
  // a size that is no size
  r = Sh(run + "--size 640by480 --frames " + dir + "/f");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--size '640by480'"), std::string::npos) << r.output;
  // no ffmpeg on PATH
  r = Sh("env -u GRASPSIM_FFMPEG PATH=" + dir + " " + run + "--video " + dir + "/b.mp4");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("ffmpeg was not found on PATH"), std::string::npos) << r.output;
  // a video into a folder that does not exist
  r = Sh(run + "--video " + dir + "/no/such/folder/c.mp4");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("does not exist"), std::string::npos) << r.output;
  // frames into a folder that cannot be made (under a file; /proc refuses even root)
  std::ofstream(dir + "/plain_file") << "x";
  r = Sh(run + "--frames " + dir + "/plain_file/frames");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--frames " + dir + "/plain_file/frames: cannot create the folder"), std::string::npos)
      << r.output;
  r = Sh(run + "--frames /proc/graspsim_frames");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("/proc/graspsim_frames"), std::string::npos) << r.output;
  // the same checks hold for replay
  r = Sh(Replay(dir + "/g", "160x121") + " --video " + dir + "/d.mp4");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("odd side"), std::string::npos) << r.output;
}

TEST(RenderCli, AnEncoderThatQuitsEndsTheRunWithAnErrorNotASigpipe) {
  const std::string dir = TempDir("quit");
  // an "ffmpeg" that exits before reading a frame
  const std::string fake = dir + "/ffmpeg";
  std::ofstream(fake) << "#!/bin/sh\nexit 1\n";
  std::filesystem::permissions(fake, std::filesystem::perms::owner_all);
  const Result r = Sh("GRASPSIM_FFMPEG=" + fake + " " + Bin() + " run " + kScene +
                      " --duration 0.5 --quiet --size 64x48 --video " + dir + "/clip.mp4");
  EXPECT_EQ(r.code, 1) << r.output;  // not 128 + SIGPIPE
  EXPECT_NE(r.output.find("--video: ffmpeg"), std::string::npos) << r.output;
}

}  // namespace
