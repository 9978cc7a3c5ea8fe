// The command line teaches (README "Using it"): every command's --help, found
// by walking `graspsim --help` rather than from a list, has examples and exit
// codes and names what each option takes (no CLI11 `TEXT`, no `args(1x)`);
// the examples name files that exist and run; a number out of range is refused
// with the option, the value and the range in its unit; an unknown command or
// benchmark is answered with the list of the known ones.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

struct Result {
  int code = -1;  ///< exit status, or 128 + signal
  std::string out, err;
};

std::string Slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// runs `sh -c CMD` with stdout and stderr kept apart
Result Sh(const std::string& cmd) {
  static int n = 0;
  const fs::path base = fs::temp_directory_path() / ("graspsim_help_" + std::to_string(getpid()) + "_" +
                                                     std::to_string(n++));
  const std::string full = "(" + cmd + ") > " + base.string() + ".out 2> " + base.string() + ".err";
  const int status = std::system(full.c_str());
  Result r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = Slurp(base.string() + ".out");
  r.err = Slurp(base.string() + ".err");
  fs::remove(base.string() + ".out");
  fs::remove(base.string() + ".err");
  return r;
}

std::string Bin() { return GRASPSIM_BINARY; }
std::string Src() { return GRASPSIM_SOURCE_DIR; }

// the names listed under a "HEADING:" section of a help text ("  name   description")
std::vector<std::string> Section(const std::string& help, const std::string& heading) {
  std::vector<std::string> names;
  std::istringstream in(help);
  bool inside = false;
  for (std::string line; std::getline(in, line);) {
    if (line == heading + ":") {
      inside = true;
      continue;
    }
    if (!inside) continue;
    if (line.size() < 3 || line[0] != ' ' || line[1] != ' ') break;
    if (line[2] == ' ') continue;  // a wrapped description
    names.push_back(line.substr(2, line.find(' ', 2) - 2));
  }
  return names;
}

// the example commands of a help text: the lines "  graspsim ..." under "Examples"
std::vector<std::string> Examples(const std::string& help) {
  std::vector<std::string> cmds;
  std::istringstream in(help);
  bool inside = false;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Examples", 0) == 0) {
      inside = true;
      continue;
    }
    if (inside && line.empty()) break;
    if (inside && line.rfind("  graspsim ", 0) == 0) cmds.push_back(line.substr(2));
  }
  return cmds;
}

bool HasLongNumber(const std::string& s) { return std::regex_search(s, std::regex("[0-9]{20,}")); }

// every command path ("run", "bench step", ...) reachable from `graspsim --help`
std::vector<std::string> AllCommands() {
  std::vector<std::string> all, todo{""};
  while (!todo.empty()) {
    const std::string path = todo.back();
    todo.pop_back();
    const Result r = Sh(Bin() + " " + path + " --help");
    for (const char* heading : {"Commands", "Benchmarks"})
      for (const std::string& name : Section(r.out, heading)) {
        const std::string sub = path.empty() ? name : path + " " + name;
        all.push_back(sub);
        todo.push_back(sub);
      }
  }
  return all;
}

TEST(HelpText, EveryCommandHasExamplesExitCodesAndNamedMetavars) {
  const std::vector<std::string> commands = AllCommands();
  // the commands of README's table, and the benchmarks and scene tools under them
  for (const char* c : {"run", "scene", "scene check", "validate", "solve", "record", "send", "replay", "live",
                        "stress", "bench", "bench step", "bench realtime", "bench tradeoff"})
    EXPECT_NE(std::find(commands.begin(), commands.end(), c), commands.end()) << c << " is not listed by --help";
  EXPECT_GE(commands.size(), 22u);
  for (const std::string& c : commands) {
    SCOPED_TRACE(c);
    const Result r = Sh(Bin() + " " + c + " --help");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("Usage: graspsim " + c), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("Examples"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("Exit codes:"), std::string::npos) << r.out;
    EXPECT_FALSE(Examples(r.out).empty()) << r.out;
    // every example is a command of this one (or below it)
    for (const std::string& e : Examples(r.out)) EXPECT_EQ(e.rfind("graspsim " + c, 0), 0u) << e;
    EXPECT_NE(r.out.find("\n  2    bad command line"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("TEXT"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("args("), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("(1x)"), std::string::npos) << r.out;
    EXPECT_FALSE(std::regex_search(r.out, std::regex("[Ii]ssue [0-9]"))) << r.out;
    EXPECT_FALSE(HasLongNumber(r.out)) << r.out;
  }
}

TEST(HelpText, TopLevelListsCommandsWithExamplesAndPointsToReadme) {
  const Result r = Sh(Bin() + " --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("Usage: graspsim COMMAND"), std::string::npos) << r.out;
  EXPECT_GE(Section(r.out, "Commands").size(), 10u) << r.out;
  EXPECT_GE(Examples(r.out).size(), 2u) << r.out;
  EXPECT_NE(r.out.find("README.md"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("130  interrupted"), std::string::npos) << r.out;
}

TEST(HelpText, UsageLinesShowWhatPositionalsTake) {
  EXPECT_NE(Sh(Bin() + " run --help").out.find("Usage: graspsim run [SCENE.yaml] [OPTIONS]\n"), std::string::npos);
  EXPECT_NE(Sh(Bin() + " replay --help").out.find("Usage: graspsim replay [SCENE.yaml] FILE.lcmlog [OPTIONS]\n"),
            std::string::npos);
  EXPECT_NE(Sh(Bin() + " scene check --help").out.find("Usage: graspsim scene check SCENE.yaml... [OPTIONS]\n"),
            std::string::npos);
  EXPECT_NE(Sh(Bin() + " solve --help").out.find("Usage: graspsim solve FILE.hdf5 [OPTIONS]\n"), std::string::npos);
  EXPECT_NE(Sh(Bin() + " bench --help").out.find("Usage: graspsim bench BENCHMARK"), std::string::npos);
  const std::string run = Sh(Bin() + " run --help").out;
  for (const char* m : {"--duration SECONDS", "--out DIR", "--video FILE.mp4", "--size WxH", "--every N",
                        "--force-scale M/N"})
    EXPECT_NE(run.find(m), std::string::npos) << m << "\n" << run;
}

// files named in the examples (config/, tests/data/, assets/) ship with the checkout
TEST(HelpText, ExamplesNameFilesThatExist) {
  int named = 0;
  for (const std::string& c : AllCommands()) {
    for (const std::string& e : Examples(Sh(Bin() + " " + c + " --help").out)) {
      std::istringstream words(e);
      for (std::string w; words >> w;) {
        if (w.find('*') != std::string::npos) continue;
        if (w.rfind("config/", 0) == 0 || w.rfind("tests/data/", 0) == 0 || w.rfind("assets/", 0) == 0) {
          ++named;
          EXPECT_TRUE(fs::exists(Src() + "/" + w)) << w << " in the example of " << c << ": " << e;
        }
      }
    }
  }
  EXPECT_GE(named, 8);
}

TEST(HelpText, NegativeDurationNamesOptionValueAndRange) {
  const Result r = Sh(Bin() + " run --duration -1");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--duration"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("-1 is not a positive number of seconds"), std::string::npos) << r.err;
  EXPECT_FALSE(HasLongNumber(r.err)) << r.err;
  EXPECT_EQ(r.out, "");  // refused before anything ran
}

// a value out of range on any command: exit 2, the option, the value, the range or unit, no 309-digit bound
TEST(HelpText, OutOfRangeNumbersAreRefusedWithTheirUnits) {
  struct Case {
    std::string args, option, value, words;
  };
  const std::vector<Case> cases = {
      {"run --every 0", "--every", "0", "steps"},
      {"run --every 1.5", "--every", "1.5", "whole"},
      {"run --duration abc", "--duration", "abc", "seconds"},
      {"run --duration inf", "--duration", "inf", "finite"},
      {"run --fps 0", "--fps", "0", "from 1 to 240"},
      {"run --force-scale -2", "--force-scale", "-2", "m per N"},
      {"run --arrows big", "--arrows", "big", "pair, contact, none"},
      {"run --export-every -3", "--export-every", "-3", "steps"},
      {"replay x.lcmlog --tail -1", "--tail", "-1", "seconds"},
      {"replay x.lcmlog --duration 0", "--duration", "0", "seconds"},
      {"solve x.hdf5 --over-relaxation 3", "--over-relaxation", "3", "from 0.01 to 1.99"},
      {"solve x.hdf5 --tolerance -1e-6", "--tolerance", "-1e-6", "positive"},
      {"solve x.hdf5 --max-iterations 0", "--max-iterations", "0", "sweeps"},
      {"solve x.hdf5 --extrapolate-every -1", "--extrapolate-every", "-1", "0 or more"},
      {"solve x.hdf5 --solver fast", "--solver", "fast", "nsgs, newton, auto"},
      {"send --synthetic --port 70000", "--port", "70000", "from 1 to 65535"},
      {"send --synthetic --port 5000 --rate 0", "--rate", "0", "datagrams per second"},
      {"send --synthetic --port 5000 --delay 61", "--delay", "61", "from 0 to 60"},
      {"send --synthetic --port 5000 --fingers 4", "--fingers", "4", "3, 5"},
      {"record --port 5000 -o x.lcmlog --rcvbuf 10", "--rcvbuf", "10", "bytes"},
      {"record --port 5000 -o x.lcmlog --duration -5", "--duration", "-5", "seconds"},
      {"live --rt-priority 120", "--rt-priority", "120", "from 0 to 99"},
      {"live --publish-rate -1", "--publish-rate", "-1", "per second"},
      {"live --step-budget 11", "--step-budget", "11", "fraction of the timestep"},
      {"bench realtime --seconds 0", "--seconds", "0", "from 0.1 to 3600"},
      {"bench realtime --spin-us 2000", "--spin-us", "2000", "microseconds"},
      {"bench realtime --cpu -2", "--cpu", "-2", "from -1 to 1023"},
      {"bench tradeoff --knob speed", "--knob", "speed", "dt"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.args);
    const Result r = Sh(Bin() + " " + c.args);
    EXPECT_EQ(r.code, 2) << r.out << r.err;
    EXPECT_NE(r.err.find(c.option + ": "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.value), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.words), std::string::npos) << r.err;
    EXPECT_FALSE(HasLongNumber(r.err)) << r.err;
  }
  // the bounds themselves are accepted (no side effect: --help after them)
  for (const char* ok : {"run --fps 1 --every 1 --duration 1e-3", "send --port 65535 --delay 60 --fingers 5",
                         "live --rt-priority 0 --cpu -1 --step-budget 0", "bench realtime --seconds 0.1"}) {
    const Result r = Sh(Bin() + " " + ok + " --help");
    EXPECT_EQ(r.code, 0) << ok << ": " << r.err;
  }
}

TEST(HelpText, UnknownBenchmarkListsTheBenchmarks) {
  const Result r = Sh(Bin() + " bench nosuch");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("unknown benchmark 'nosuch'"), std::string::npos) << r.err;
  for (const char* b : {"collision", "mls", "step", "realtime", "tradeoff"})
    EXPECT_NE(r.err.find(b), std::string::npos) << b << ": " << r.err;
  EXPECT_EQ(r.err.find("A subcommand is required"), std::string::npos) << r.err;
  // no benchmark at all: the same list
  const Result none = Sh(Bin() + " bench");
  EXPECT_EQ(none.code, 2);
  EXPECT_NE(none.err.find("step"), std::string::npos) << none.err;
  EXPECT_NE(none.err.find("benchmark"), std::string::npos) << none.err;
}

TEST(HelpText, UnknownCommandsListTheCommands) {
  const Result top = Sh(Bin() + " nosuch");
  EXPECT_EQ(top.code, 2);
  EXPECT_NE(top.err.find("unknown command 'nosuch'"), std::string::npos) << top.err;
  for (const char* c : {"run", "replay", "bench", "scene", "validate"})
    EXPECT_NE(top.err.find(c), std::string::npos) << c << ": " << top.err;
  const Result scene = Sh(Bin() + " scene nosuch");
  EXPECT_EQ(scene.code, 2);
  EXPECT_NE(scene.err.find("unknown command 'nosuch'; one of: check"), std::string::npos) << scene.err;
  const Result none = Sh(Bin());
  EXPECT_EQ(none.code, 2);
  EXPECT_NE(none.err.find("run"), std::string::npos) << none.err;
  // a bad option of a known command is still CLI11's message, not the command list
  const Result opt = Sh(Bin() + " run --nosuch");
  EXPECT_EQ(opt.code, 2);
  EXPECT_NE(opt.err.find("--nosuch"), std::string::npos) << opt.err;
  EXPECT_EQ(opt.err.find("one of:"), std::string::npos) << opt.err;
}

// a folder that looks like the checkout root (config/, tests/, assets/) where examples may write
std::string ExampleRoot(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("graspsim_help_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const char* d : {"config", "tests", "assets"}) fs::create_directory_symlink(Src() + "/" + d, dir / d);
  return dir.string();
}

// the first example of run's help runs as printed (shortened to 20 ms) and writes what it says
TEST(HelpText, RunExampleRuns) {
  const std::vector<std::string> examples = Examples(Sh(Bin() + " run --help").out);
  ASSERT_FALSE(examples.empty());
  const std::string& e = examples.front();
  const bool video = e.find("--video") != std::string::npos;
  // skipped without ffmpeg: this example writes a video (scripts/setup.sh installs ffmpeg; CI has it)
  if (video && Sh("command -v ffmpeg").code != 0) GTEST_SKIP() << "no ffmpeg: " << e;
  const std::string dir = ExampleRoot("run");
  const std::string cmd = "cd " + dir + " && " + Bin() + e.substr(std::string("graspsim").size()) +
                          " --duration 0.02 --quiet";
  const Result r = Sh(cmd);
  EXPECT_EQ(r.code, 0) << cmd << "\n" << r.out << r.err;
  if (e.find("--out out/") != std::string::npos) {
    EXPECT_TRUE(fs::exists(dir + "/out/summary.json")) << cmd;
  }
  if (video) {
    EXPECT_GT(fs::file_size(dir + "/grasp.mp4"), 0u) << cmd;
  }
  fs::remove_all(dir);
}

// scene check's examples: the shipped scenes pass, the refused one says where and exits 3
TEST(HelpText, SceneCheckExamplesRun) {
  const std::vector<std::string> examples = Examples(Sh(Bin() + " scene check --help").out);
  ASSERT_EQ(examples.size(), 2u);
  const std::string dir = ExampleRoot("scene");
  const Result ok = Sh("cd " + dir + " && " + Bin() + examples[0].substr(std::string("graspsim").size()));
  EXPECT_EQ(ok.code, 0) << examples[0] << "\n" << ok.out << ok.err;
  EXPECT_NE(ok.out.find("config/paper_box_grasp.yaml: ok"), std::string::npos) << ok.out;
  const Result bad = Sh("cd " + dir + " && " + Bin() + examples[1].substr(std::string("graspsim").size()));
  EXPECT_EQ(bad.code, 3) << examples[1] << "\n" << bad.out << bad.err;
  EXPECT_TRUE(std::regex_search(bad.err, std::regex("\\.yaml:[0-9]+:[0-9]+: "))) << bad.err;
  fs::remove_all(dir);
}

}  // namespace
