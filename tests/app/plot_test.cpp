// `graspsim plot` (README "Plotting a result"): the figures of a run and of a
// replay folder, checked as PNGs (signature, size, decoded content) and through
// the series they are drawn from; the figures a replay cannot give are named;
// bad folders, malformed files and bad options are refused with the file or
// option named, the documented exit code, and nothing left behind.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <algorithm>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#include <stb/stb_image.h>  // its implementation is compiled once, in render_cli_test.cpp
#pragma GCC diagnostic pop

#include "plot/result_plots.h"

#include "../shell.h"

namespace {

namespace fs = std::filesystem;

using Result = gs::test::ShellResult;
using gs::test::Sh;

std::string Bin() { return GRASPSIM_BINARY; }
std::string Src(const std::string& rel) { return std::string(GRASPSIM_SOURCE_DIR) + "/" + rel; }
bool HaveGnuplot() { return std::system("command -v gnuplot >/dev/null 2>&1") == 0; }

std::string Root() {
  static const std::string root = [] {
    const fs::path p = fs::temp_directory_path() / ("graspsim_plot_test_" + std::to_string(getpid()));
    fs::remove_all(p);
    fs::create_directories(p);
    return p.string();
  }();
  return root;
}

// the folders of this process go when it ends
class RemoveRoot : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(Root(), ec);
  }
};
[[maybe_unused]] ::testing::Environment* const kRemoveRoot = ::testing::AddGlobalTestEnvironment(new RemoveRoot);

// a 0.3 s run of the paper's grasp (the fingers touch the box from 0.26 s) and a
// 1.5 s replay of the shipped session (the fingertips touch the box from about 1.03 s),
// made once for every test
const std::string& RunFolder() {
  static const std::string dir = [] {
    const std::string d = Root() + "/run";
    const Result r = Sh(Bin() + " run " + Src("config/paper_box_grasp.yaml") + " --duration 0.3 --quiet --out " + d);
    EXPECT_EQ(r.code, 0) << r.output;
    return d;
  }();
  return dir;
}

const std::string& ReplayFolder() {
  static const std::string dir = [] {
    const std::string d = Root() + "/replay";
    const Result r =
        Sh(Bin() + " replay " + Src("assets/demo_session.lcmlog") + " --duration 1.5 --quiet --out " + d);
    EXPECT_EQ(r.code, 0) << r.output;
    return d;
  }();
  return dir;
}

// a copy of the run folder to spoil
std::string CopyOfRun(const std::string& name) {
  const std::string d = Root() + "/" + name;
  fs::remove_all(d);
  fs::copy(RunFolder(), d, fs::copy_options::recursive);
  fs::remove_all(d + "/plots");
  return d;
}

std::vector<std::string> Lines(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::vector<std::string> lines;
  for (std::string l; std::getline(f, l);) lines.push_back(l);
  return lines;
}

void WriteLines(const std::string& path, const std::vector<std::string>& lines) {
  std::ofstream f(path, std::ios::binary);
  for (const std::string& l : lines) f << l << "\n";
}

std::string ReadAll(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

uint32_t BigEndian32(const std::string& s, size_t at) {
  uint32_t v = 0;
  for (size_t i = 0; i < 4; ++i) v = v << 8 | static_cast<unsigned char>(s[at + i]);
  return v;
}

// a PNG of the asked size, decoded: the number of distinct colours and of
// pixels of the budget line's red (gnuplot's default series colours are violet,
// green, blue, orange: none of them is this red)
struct PngFacts {
  int colours = 0;
  int red_pixels = 0;
};

PngFacts CheckPng(const std::string& path, int width, int height) {
  PngFacts facts;
  const std::string bytes = ReadAll(path);
  EXPECT_GT(bytes.size(), 33u) << path;
  if (bytes.size() <= 33) return facts;
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << path;
  EXPECT_EQ(bytes.substr(12, 4), "IHDR") << path;
  EXPECT_EQ(BigEndian32(bytes, 16), static_cast<uint32_t>(width)) << path;
  EXPECT_EQ(BigEndian32(bytes, 20), static_cast<uint32_t>(height)) << path;
  int w = 0, h = 0, channels = 0;
  unsigned char* px = stbi_load(path.c_str(), &w, &h, &channels, 3);
  EXPECT_NE(px, nullptr) << path << ": " << stbi_failure_reason();
  if (!px) return facts;
  std::set<uint32_t> colours;
  for (int i = 0; i < w * h; ++i) {
    const unsigned char r = px[3 * i], g = px[3 * i + 1], b = px[3 * i + 2];
    colours.insert(static_cast<uint32_t>(r) << 16 | g << 8 | b);
    facts.red_pixels += r > 180 && g < 90 && b < 90 ? 1 : 0;
  }
  stbi_image_free(px);
  facts.colours = static_cast<int>(colours.size());
  return facts;
}

const char* const kRunFigures[] = {"height.png", "grip_force.png", "contacts.png", "stick_slip.png", "step_time.png"};

bool NoScratchLeft(const std::string& dir) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.path().filename().string().rfind(".graspsim-plot-", 0) == 0) return false;
  return true;
}

// ---- the command ----

TEST(PlotCli, RunFolderGivesEveryFigureAtTheAskedSize) {
  // skipped without gnuplot, which draws the figures (setup.sh installs gnuplot-nox; CI has it)
  if (!HaveGnuplot()) GTEST_SKIP() << "gnuplot is not installed (scripts/setup.sh installs gnuplot-nox)";
  const std::string out = Root() + "/run_plots";
  const Result r = Sh(Bin() + " plot " + RunFolder() + " --out " + out + " --size 640x480");
  ASSERT_EQ(r.code, 0) << r.output;
  std::set<std::string> bytes;
  for (const char* png : kRunFigures) {
    EXPECT_NE(r.output.find(out + "/" + png), std::string::npos) << r.output;
    const PngFacts f = CheckPng(out + "/" + png, 640, 480);
    EXPECT_GT(f.colours, 3) << png << " is blank";
    // only the step-time figure draws the budget line
    if (std::string(png) == "step_time.png") {
      EXPECT_GT(f.red_pixels, 100) << "no budget line in " << png;
    } else {
      EXPECT_EQ(f.red_pixels, 0) << png;
    }
    bytes.insert(ReadAll(out + "/" + png));
  }
  EXPECT_EQ(bytes.size(), 5u) << "two figures are the same picture";
  EXPECT_EQ(r.output.find("graspsim plot: no "), std::string::npos) << r.output;
  EXPECT_TRUE(NoScratchLeft(out));
}

TEST(PlotCli, DefaultOutIsPlotsInsideTheFolderAndQuietListsNothing) {
  // skipped without gnuplot, which draws the figures (setup.sh installs gnuplot-nox; CI has it)
  if (!HaveGnuplot()) GTEST_SKIP() << "gnuplot is not installed (scripts/setup.sh installs gnuplot-nox)";
  const std::string dir = CopyOfRun("default_out");
  const Result r = Sh(Bin() + " plot " + dir + " --quiet");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output, "");
  for (const char* png : kRunFigures) CheckPng(dir + "/plots/" + png, 1000, 600);
}

TEST(PlotCli, ReplayFolderGivesItsFiguresAndNamesTheOthers) {
  // skipped without gnuplot, which draws the figures (setup.sh installs gnuplot-nox; CI has it)
  if (!HaveGnuplot()) GTEST_SKIP() << "gnuplot is not installed (scripts/setup.sh installs gnuplot-nox)";
  const std::string out = Root() + "/replay_plots";
  const Result r = Sh(Bin() + " plot " + ReplayFolder() + " --out " + out);
  ASSERT_EQ(r.code, 0) << r.output;
  for (const char* png : {"height.png", "grip_force.png", "contacts.png", "stick_slip.png"})
    EXPECT_GT(CheckPng(out + "/" + png, 1000, 600).colours, 3) << png;
  EXPECT_FALSE(fs::exists(out + "/step_time.png"));
  EXPECT_NE(r.output.find("no step_time.png: a replay folder has no timings.csv"), std::string::npos) << r.output;
}

TEST(PlotCli, AMissingFolderOrAFolderOfNoResultIsBadInput) {
  const std::string missing = Root() + "/no_such_folder";
  Result r = Sh(Bin() + " plot " + missing);
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find(missing + ": no such folder"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(missing));

  const std::string empty = Root() + "/empty";
  fs::create_directories(empty);
  r = Sh(Bin() + " plot " + empty);
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("not a run or replay folder"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(empty + "/plots"));
}

// spoils one file of a copy of the run folder; plot must refuse it with exit 3,
// name the file and line, and write nothing
void ExpectRefused(const std::string& name, const std::string& file, int line,
                   void (*spoil)(std::vector<std::string>*), const std::string& what) {
  const std::string dir = CopyOfRun(name);
  std::vector<std::string> lines = Lines(dir + "/" + file);
  ASSERT_GT(lines.size(), static_cast<size_t>(line)) << file;
  spoil(&lines);
  WriteLines(dir + "/" + file, lines);
  const Result r = Sh(Bin() + " plot " + dir);
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find(dir + "/" + file + ":" + std::to_string(line) + ": " + what), std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(dir + "/plots")) << "something was written for a refused folder";
}

TEST(PlotCli, AMalformedCsvIsRefusedWithItsFileAndLine) {
  // a line cut to 6 of contacts.csv's 12 fields
  ExpectRefused("short_line", "contacts.csv", 57,
                [](std::vector<std::string>* l) { (*l)[56] = "56,0.056,table,box,800,9"; },
                "6 fields where the header (line 1) has 12");
  // a word where total_ms holds a number
  ExpectRefused("not_a_number", "timings.csv", 20, [](std::vector<std::string>* l) {
    (*l)[19] = (*l)[19].substr(0, (*l)[19].rfind(',')) + ",fast";
  }, "column total_ms: 'fast' is not a finite number");
  // trajectory.csv cut inside its last line: every field there, the last number cut
  const std::string dir = CopyOfRun("truncated");
  std::string text = ReadAll(dir + "/trajectory.csv");
  text.resize(text.size() - 3);
  std::ofstream(dir + "/trajectory.csv", std::ios::binary) << text;
  const Result r = Sh(Bin() + " plot " + dir);
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find(dir + "/trajectory.csv:" + std::to_string(Lines(dir + "/trajectory.csv").size()) +
                          ": the file ends inside this line (truncated?)"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(dir + "/plots"));
}

TEST(PlotCli, AMalformedSummaryIsRefusedWithItsFile) {
  const std::string dir = CopyOfRun("bad_summary");
  const std::string json = ReadAll(dir + "/summary.json");
  std::ofstream(dir + "/summary.json", std::ios::binary) << json.substr(0, json.size() / 2);
  const Result r = Sh(Bin() + " plot " + dir);
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find(dir + "/summary.json:1: not valid JSON"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir + "/plots"));
}

TEST(PlotCli, BadOptionsAreRefusedWithTheOptionNamed) {
  // skipped without gnuplot: plot checks --out only after finding gnuplot
  if (!HaveGnuplot()) GTEST_SKIP() << "gnuplot is not installed: --out is checked after it is found";
  const std::string file = RunFolder() + "/summary.json";
  Result r = Sh(Bin() + " plot " + RunFolder() + " --out " + file + "/plots");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--out " + file + "/plots: cannot create the folder"), std::string::npos) << r.output;
  r = Sh(Bin() + " plot " + RunFolder() + " --out " + file);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--out " + file + ": exists and is not a folder"), std::string::npos) << r.output;
  const std::string out = Root() + "/never_made";
  r = Sh(Bin() + " plot " + RunFolder() + " --out " + out + " --size 640");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--size 640: expected WxH"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));
}

TEST(PlotCli, AnUnwritableOutLeavesNothingBehind) {
  // skipped without gnuplot: plot checks --out only after finding gnuplot
  if (!HaveGnuplot()) GTEST_SKIP() << "gnuplot is not installed: --out is checked after it is found";
  // /proc takes no new folder, not even from root
  Result r = Sh(Bin() + " plot " + RunFolder() + " --out /proc/graspsim-no/such");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--out /proc/graspsim-no/such: cannot create the folder"), std::string::npos) << r.output;
  // skipped as root, who can write into a read-only folder; the /proc case above covers root
  if (geteuid() == 0) GTEST_SKIP() << "root writes into a read-only folder: the /proc case was checked";
  const std::string locked = Root() + "/locked";
  fs::create_directories(locked);
  fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
  r = Sh(Bin() + " plot " + RunFolder() + " --out " + locked + "/a/b");
  fs::permissions(locked, fs::perms::owner_all);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--out " + locked + "/a/b: cannot create the folder"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::is_empty(locked));
}

TEST(PlotCli, WithoutGnuplotAClearMessageAndNoFolder) {
  const std::string out = Root() + "/no_gnuplot";
  // no PATH: the shell finds no gnuplot
  const Result r = Sh("PATH=/nonexistent " + Bin() + " plot " + RunFolder() + " --out " + out);
  EXPECT_EQ(r.code, 4) << r.output;
  EXPECT_NE(r.output.find("gnuplot is not installed (Debian: apt-get install gnuplot-nox"), std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(out));
}

// a gnuplot that fails, or that exits 0 and draws nothing: exit 4, and the
// folders made for the figures are gone again
TEST(PlotCli, AFailingGnuplotLeavesNothingBehind) {
  const std::string bin = Root() + "/fake_bin";
  fs::create_directories(bin);
  for (const auto& [script, says] : {std::pair<const char*, const char*>{"echo boom >&2; exit 1", "failed on "},
                                     {"exit 0", "gnuplot wrote no height.png"}}) {
    std::ofstream(bin + "/gnuplot") << "#!/bin/sh\n" << script << "\n";
    fs::permissions(bin + "/gnuplot", fs::perms::owner_all);
    const std::string out = Root() + "/fake_out/a";
    const Result r = Sh("PATH=" + bin + ":$PATH " + Bin() + " plot " + RunFolder() + " --out " + out);
    EXPECT_EQ(r.code, 4) << r.output;
    EXPECT_NE(r.output.find(says), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(Root() + "/fake_out")) << r.output;
  }
}

TEST(PlotCli, AFifoInThePlaceOfAFileIsRefusedNotWaitedOn) {
  for (const char* file : {"summary.json", "contacts.csv"}) {
    const std::string dir = CopyOfRun(std::string("fifo_") + file);
    fs::remove(dir + "/" + file);
    ASSERT_EQ(mkfifo((dir + "/" + file).c_str(), 0600), 0);
    const Result r = Sh(Bin() + " plot " + dir);
    EXPECT_EQ(r.code, 3) << r.output;
    EXPECT_NE(r.output.find(dir + "/" + file + ": not a regular file"), std::string::npos) << r.output;
  }
}

// ---- the series behind the figures (plot/result_plots.h) ----

const gs::plot::Figure* Find(const gs::plot::ResultPlots& p, const std::string& file) {
  for (const gs::plot::Figure& f : p.figures)
    if (f.file == file) return &f;
  return nullptr;
}

TEST(PlotSeries, RunFiguresHoldWhatTheFilesSay) {
  gs::plot::ResultPlots p;
  std::string error;
  ASSERT_TRUE(gs::plot::ReadResultFolder(RunFolder(), &p, &error)) << error;
  EXPECT_FALSE(p.replay);
  ASSERT_EQ(p.figures.size(), 5u);
  EXPECT_TRUE(p.missing.empty());
  // the box starts on the table, its centre 30.2 mm up (config/paper_box_grasp.yaml)
  const gs::plot::Figure* height = Find(p, "height.png");
  ASSERT_NE(height, nullptr);
  ASSERT_EQ(height->series.size(), 1u);
  EXPECT_EQ(height->series[0].title, "box");
  EXPECT_NEAR(height->series[0].y.front(), 30.2, 1e-9);
  EXPECT_EQ(height->x.front(), 0.0);
  // the force on the box: the table's, then the three fingertips' from 0.26 s
  const gs::plot::Figure* grip = Find(p, "grip_force.png");
  ASSERT_NE(grip, nullptr);
  std::set<std::string> bodies;
  for (const auto& s : grip->series) bodies.insert(s.title);
  EXPECT_EQ(bodies, (std::set<std::string>{"table", "thumb_tip", "index_tip", "middle_tip"}));
  for (const auto& s : grip->series) {
    EXPECT_EQ(s.y.size(), grip->x.size());
    if (s.title == "table") continue;
    EXPECT_GT(s.y.back(), 0.5) << s.title << " does not press on the box";
    EXPECT_EQ(s.y.front(), 0.0) << s.title << " touches the box from the start";
  }
  // the contact count of every step is timings.csv's own (written apart from contacts.csv)
  const gs::plot::Figure* count = Find(p, "contacts.png");
  ASSERT_NE(count, nullptr);
  const std::vector<std::string> timings = Lines(RunFolder() + "/timings.csv");
  ASSERT_EQ(count->x.size(), timings.size());  // step 0 of trajectory.csv, then one per step
  for (size_t i = 1; i < timings.size(); ++i)
    ASSERT_EQ(count->series[0].y[i], std::stod(timings[i].substr(timings[i].find(',', timings[i].find(',') + 1) + 1)))
        << "step " << i;
  const gs::plot::Figure* step = Find(p, "step_time.png");
  ASSERT_NE(step, nullptr);
  EXPECT_EQ(step->line_y, 1.0);  // dt_s 0.001
  EXPECT_EQ(step->x.size(), timings.size() - 1);
}

TEST(PlotSeries, ExtraColumnsAndSummaryMembersAreIgnored) {
  const std::string dir = CopyOfRun("extra_columns");
  for (const char* file : {"contacts.csv", "timings.csv", "trajectory.csv"}) {
    std::vector<std::string> lines = Lines(dir + "/" + file);
    lines[0] = "note_text," + lines[0] + ",extra_N";
    for (size_t i = 1; i < lines.size(); ++i) lines[i] = "some words," + lines[i] + ",7";
    WriteLines(dir + "/" + file, lines);
  }
  std::string json = ReadAll(dir + "/summary.json");
  json.insert(1, "\"interrupted\":false,\"more\":{\"deep\":[1,{\"x\":\"y\"}]},");
  std::ofstream(dir + "/summary.json", std::ios::binary) << json;
  gs::plot::ResultPlots plain, extra;
  std::string error;
  ASSERT_TRUE(gs::plot::ReadResultFolder(RunFolder(), &plain, &error)) << error;
  ASSERT_TRUE(gs::plot::ReadResultFolder(dir, &extra, &error)) << error;
  ASSERT_EQ(extra.figures.size(), plain.figures.size());
  for (size_t i = 0; i < plain.figures.size(); ++i) {
    EXPECT_EQ(extra.figures[i].x, plain.figures[i].x) << plain.figures[i].file;
    ASSERT_EQ(extra.figures[i].series.size(), plain.figures[i].series.size()) << plain.figures[i].file;
    for (size_t k = 0; k < plain.figures[i].series.size(); ++k)
      EXPECT_EQ(extra.figures[i].series[k].y, plain.figures[i].series[k].y) << plain.figures[i].file;
  }
}

// replay writes contacts.csv: the grip is the normal force on the box from each
// fingertip (and the table), as for a run
TEST(PlotSeries, ReplayGivesHeightAndTheForceOfEachBodyOnTheBox) {
  gs::plot::ResultPlots p;
  std::string error;
  ASSERT_TRUE(gs::plot::ReadResultFolder(ReplayFolder(), &p, &error)) << error;
  EXPECT_TRUE(p.replay);
  ASSERT_EQ(p.figures.size(), 4u);
  EXPECT_EQ(p.figures[0].file, "height.png");
  EXPECT_EQ(p.figures[1].file, "grip_force.png");
  std::map<std::string, std::vector<double>> by;
  for (const auto& series : p.figures[1].series) by[series.title] = series.y;
  for (const char* tip : {"thumb_tip", "index_tip", "middle_tip"}) {
    ASSERT_TRUE(by.count(tip)) << tip;
    // the fingertips close on the box within the 1.5 s
    EXPECT_GT(*std::max_element(by[tip].begin(), by[tip].end()), 0.05) << tip;
  }
  std::set<std::string> missing;
  for (const auto& m : p.missing) missing.insert(m.file);
  EXPECT_EQ(missing, (std::set<std::string>{"step_time.png"}));
}

// a replay folder without contacts.csv (written before replay wrote one) draws the
// grip from the fingertips' coupling forces, and names the figures it cannot give
TEST(PlotSeries, AReplayFolderWithoutContactsGivesTheFingertipForces) {
  const std::string d = Root() + "/replay_without_contacts";
  fs::remove_all(d);
  fs::copy(ReplayFolder(), d, fs::copy_options::recursive);
  fs::remove(d + "/contacts.csv");
  gs::plot::ResultPlots p;
  std::string error;
  ASSERT_TRUE(gs::plot::ReadResultFolder(d, &p, &error)) << error;
  ASSERT_EQ(p.figures.size(), 2u);
  EXPECT_EQ(p.figures[1].file, "grip_force.png");
  ASSERT_EQ(p.figures[1].series.size(), 3u);
  EXPECT_EQ(p.figures[1].series[0].title, "thumb");
  EXPECT_GT(p.figures[1].series[0].y.back(), 0.05);
  std::set<std::string> missing;
  for (const auto& m : p.missing) missing.insert(m.file);
  EXPECT_EQ(missing, (std::set<std::string>{"contacts.png", "stick_slip.png", "step_time.png"}));
}

}  // namespace
