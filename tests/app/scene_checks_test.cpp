// One set of load-time checks for every command (BuildScene, scene/scene_checks.h):
// `scene check`, `run`, `replay` and `live` refuse the same scenes with the same
// FILE:LINE:COLUMN message and exit code 3; the two-box stack at a 0.1 s step is
// refused before its first step and the time step it suggests is accepted; a body
// that passes through another at run time is reported and fails the run; and
// `run --out` writes trajectory.csv and contacts.csv with units in their headers.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "../shell.h"

namespace {

using Result = gs::test::ShellResult;
using gs::test::Sh;

std::string Bin() { return GRASPSIM_BINARY; }
std::string Scene(const std::string& name) { return std::string(GRASPSIM_TEST_DATA) + "/scenes/" + name; }
std::string Log() { return std::string(GRASPSIM_TEST_DATA) + "/../../assets/demo_session.lcmlog"; }

std::string ReadFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream s(text);
  for (std::string line; std::getline(s, line);) out.push_back(line);
  return out;
}

// "FILE:LINE:COLUMN: " of `value` on the first line of the file that contains `line_text`
std::string Where(const std::string& file, const std::string& line_text, const std::string& value) {
  const std::vector<std::string> lines = Lines(ReadFile(file));
  for (size_t i = 0; i < lines.size(); ++i) {
    const size_t at = lines[i].find(line_text);
    if (at == std::string::npos) continue;
    return file + ":" + std::to_string(i + 1) + ":" + std::to_string(lines[i].find(value, at) + 1) + ": ";
  }
  ADD_FAILURE() << line_text << " not in " << file;
  return "";
}

// the output line that starts with `prefix` (empty when none)
std::string LineStarting(const std::string& output, const std::string& prefix) {
  for (const std::string& l : Lines(output))
    if (l.rfind(prefix, 0) == 0) return l;
  return "";
}

struct Refused {
  const char* scene;
  const char* line_text;  ///< locates the error: the line holding this text...
  const char* value;      ///< ...at this value
  const char* words;      ///< in the message
};

const Refused kRefused[] = {
    {"stack_dt_0.1.yaml", "timestep_s: 0.1", "0.1", "time step 0.1 s is too long: body 'bottom'"},
    {"thin_plate.yaml", "timestep_s: 0.01", "0.01", "more than body 'plate' reaches from its centre"},
    {"deep_overlap.yaml", "position_m: [0, 0, 0.02]", "[", "bodies 'low' and 'high' start overlapping by"},
    {"wide_bandwidth.yaml", "kernel_bandwidth_m: 0.05", "0.05", "body 'ball': 'kernel_bandwidth_m' = 0.05 m"},
    {"open_mesh.yaml", "file: ../meshes/open_box.obj", "../meshes", "body 'tray': "},
    {"unreachable_target.yaml", "fingertip_targets_m", "[1.0", "finger 'index' cannot reach its fingertip target"},
};

TEST(SceneChecks, EveryCommandRefusesTheSameSceneWithTheSameMessage) {
  for (const Refused& c : kRefused) {
    const std::string file = Scene(c.scene);
    const std::string where = Where(file, c.line_text, c.value);
    const Result check = Sh(Bin() + " scene check " + file);
    EXPECT_EQ(check.code, 3) << check.output;
    const std::string message = LineStarting(check.output, where);
    ASSERT_FALSE(message.empty()) << "expected a line starting " << where << " in:\n" << check.output;
    EXPECT_NE(message.find(c.words), std::string::npos) << message;
    EXPECT_EQ(check.output.find(": ok: scene"), std::string::npos) << check.output;
    const std::string port = std::to_string(20000 + getpid() % 20000);
    for (const std::string& cmd : {Bin() + " run " + file + " --quiet", Bin() + " replay " + file + " " + Log(),
                                   Bin() + " live " + file + " --port " + port}) {
      const Result r = Sh(cmd);
      EXPECT_EQ(r.code, 3) << cmd << "\n" << r.output;
      EXPECT_EQ(LineStarting(r.output, where), message) << cmd << "\n" << r.output;
      EXPECT_EQ(r.output.find("simulating"), std::string::npos) << cmd << "\n" << r.output;
    }
  }
}

TEST(SceneChecks, StackAtATenthOfASecondIsRefusedAndTheSuggestedStepAccepted) {
  const std::string file = Scene("stack_dt_0.1.yaml");
  const Result r = Sh(Bin() + " run " + file + " --quiet");
  EXPECT_EQ(r.code, 3) << r.output;
  const size_t use = r.output.find("Use timestep_s <= ");
  ASSERT_NE(use, std::string::npos) << r.output;
  const double suggested = std::strtod(r.output.c_str() + use + 18, nullptr);
  EXPECT_GT(suggested, 0.0) << r.output;
  EXPECT_LT(suggested, 0.05) << r.output;
  // the suggested step, as printed, passes
  const std::string dir = (std::filesystem::temp_directory_path() / ("graspsim_checks_" + std::to_string(getpid()))).string();
  std::filesystem::create_directories(dir);
  std::string text = ReadFile(file);
  text.replace(text.find("timestep_s: 0.1"), 15, "timestep_s: " + std::to_string(suggested));
  std::ofstream(dir + "/stack.yaml") << text;
  const Result ok = Sh(Bin() + " scene check " + dir + "/stack.yaml");
  EXPECT_EQ(ok.code, 0) << ok.output << text;
  std::filesystem::remove_all(dir);
}

TEST(SceneChecks, PassThroughAtRunTimeIsReportedAndFailsTheRun) {
  const std::string file = Scene("pass_through.yaml");
  const Result check = Sh(Bin() + " scene check " + file);
  EXPECT_EQ(check.code, 0) << check.output;  // nothing the load-time checks can see
  const Result r = Sh(Bin() + " run " + file + " --quiet");
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("step 1 (t = 0.0010 s) rejected, previous state kept: body 'hammer' passed through body "
                          "'anvil' at step 1"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("5 steps rejected because a body passed through another"), std::string::npos) << r.output;
}

std::vector<std::string> Cells(const std::string& line) {
  std::vector<std::string> cells;
  std::istringstream s(line);
  for (std::string c; std::getline(s, c, ',');) cells.push_back(c);
  return cells;
}

// two boxes dropped 0.2 mm onto a table and onto each other: they stand, no step is
// rejected (no false pass-through), and the files say so
TEST(SceneChecks, RunOutWritesTrajectoryAndContactsWithUnits) {
  const std::string dir = (std::filesystem::temp_directory_path() / ("graspsim_run_out_" + std::to_string(getpid()))).string();
  std::filesystem::remove_all(dir);
  const Result r = Sh(Bin() + " run " + Scene("stack.yaml") + " --quiet --out " + dir + " --every 10");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find(", 0 rejected"), std::string::npos) << r.output;

  const std::vector<std::string> traj = Lines(ReadFile(dir + "/trajectory.csv"));
  ASSERT_EQ(traj.size(), 1u + 11u) << ReadFile(dir + "/trajectory.csv");  // header, step 0, steps 10..100
  EXPECT_EQ(traj[0],
            "step,t_s,bottom_x_m,bottom_y_m,bottom_z_m,bottom_qw,bottom_qx,bottom_qy,bottom_qz,"
            "top_x_m,top_y_m,top_z_m,top_qw,top_qx,top_qy,top_qz");
  const std::vector<std::string> start = Cells(traj[1]);
  ASSERT_EQ(start.size(), 16u) << traj[1];
  EXPECT_EQ(start[0] + "," + start[1], "0,0");
  EXPECT_EQ(std::stod(start[4]), 0.0202) << traj[1];  // exact: %.17g
  EXPECT_EQ(std::stod(start[11]), 0.0606) << traj[1];
  const std::vector<std::string> last = Cells(traj.back());
  ASSERT_EQ(last.size(), 16u) << traj.back();
  EXPECT_EQ(last[0], "100");
  EXPECT_NEAR(std::stod(last[1]), 0.1, 1e-12);
  EXPECT_NEAR(std::stod(last[4]), 0.020, 5e-4) << traj.back();   // on the table
  EXPECT_NEAR(std::stod(last[11]), 0.060, 1e-3) << traj.back();  // on the bottom box

  const std::vector<std::string> contacts = Lines(ReadFile(dir + "/contacts.csv"));
  ASSERT_GE(contacts.size(), 2u);
  EXPECT_EQ(contacts[0],
            "step,t_s,body_a,body_b,contacts,stick,slip,separating,fn_N,ft_N,penetration_before_m,"
            "penetration_after_m");
  EXPECT_LE(contacts.size(), 1u + 10u * 2u);  // every 10th step, at most the two touching pairs
  int settled_rows = 0;
  double fn_table = 0.0, fn_bottom = 0.0;  // summed over the settled steps
  for (size_t i = 1; i < contacts.size(); ++i) {
    const std::vector<std::string> c = Cells(contacts[i]);
    ASSERT_EQ(c.size(), 12u) << contacts[i];
    const int step = std::stoi(c[0]);
    EXPECT_EQ(step % 10, 0) << contacts[i];
    const int n = std::stoi(c[4]);
    EXPECT_EQ(std::stoi(c[5]) + std::stoi(c[6]) + std::stoi(c[7]), n) << contacts[i];
    EXPECT_LT(std::stod(c[11]), 1e-4) << contacts[i];  // penetration after the solve
    if (step < 50) continue;
    ++settled_rows;
    (c[2] == "table" ? fn_table : fn_bottom) += std::stod(c[8]);
  }
  EXPECT_EQ(settled_rows, 6 * 2) << ReadFile(dir + "/contacts.csv");  // steps 50..100, both pairs
  // settled: on average each pair carries the weight above it (0.1 kg a box; the
  // top box rocks on its coarse surface, so one step's force varies by 20 %)
  EXPECT_NEAR(fn_table / 6, 0.2 * 9.81, 0.1 * 0.2 * 9.81) << ReadFile(dir + "/contacts.csv");
  EXPECT_NEAR(fn_bottom / 6, 0.1 * 9.81, 0.1 * 0.1 * 9.81) << ReadFile(dir + "/contacts.csv");
  const std::string summary = ReadFile(dir + "/summary.json");
  EXPECT_NE(summary.find("\"pass_through_steps\":0"), std::string::npos) << summary;
  std::filesystem::remove_all(dir);
}

}  // namespace
