// Per-step records of a simulation run and the files and tables made from them.
#pragma once

#include <fstream>
#include <ostream>
#include <string>
#include <vector>

#include "core/world.h"

namespace gs::app {

struct StepRecord {
  double time = 0;
  StepProfile profile;
  int stick = 0, slide = 0, separate = 0;
  double normal_force = 0;    ///< sum of normal forces (N)
  double max_penetration = 0; ///< largest -gap (m)
};

/// Reads the contact state of the last step into a record.
StepRecord RecordStep(const World& w);

/// Writes timings.csv (one line per step) and summary.json into `dir`, creating
/// it (StepFiles writes the rest). False with a message on error.
bool WriteRunOutputs(const std::string& dir, const std::string& scene_name, const std::vector<StepRecord>& steps,
                     const std::string& summary_json, std::string* error);

/// trajectory.csv of run and replay: `step,t_s`, then each free body's position
/// (`NAME_x_m`, `NAME_y_m`, `NAME_z_m`) and orientation quaternion (`NAME_qw`,
/// `NAME_qx`, `NAME_qy`, `NAME_qz`), numbers as %.17g (exact).
void WriteTrajectoryHeader(std::ostream& o, const World& w);
void WriteTrajectoryRow(std::ostream& o, const World& w);

/// Normal gap of a contact after the last step's solve (m; negative: penetration):
/// q + W r, read through the bodies as the solver does, less the overlap held back.
double PostSolveGap(const World& w, const ContactRow& row);

/// What rejected the last step, for a log line: the pass-through names the bodies.
std::string RejectText(const World& w);
/// World::last_pass_through in words: the bodies, the step, how close the centres came.
std::string PassThroughText(const World& w);

/// The per-step files of `run --out DIR`, written as the run goes: trajectory.csv
/// and contacts.csv (one line per step and touching body pair: contacts, stick,
/// slip, separating, normal and tangential force, penetration before and after
/// the solve; no line for a rejected step), each every `every` steps.
class StepFiles {
 public:
  bool Open(const std::string& dir, const World& w, int every, std::string* error);
  void AfterStep(const World& w);
  bool Close(std::string* error);

 private:
  std::string dir_;
  std::ofstream trajectory_, contacts_;
  int every_ = 1;
};

/// FNV-1a over the bits of the world's state (poses, velocities, control-point
/// displacements, finger joints, contact forces): equal hashes mean bit-identical
/// runs. Written to summary.json as state_hash by run and replay.
uint64_t StateHash(const World& w);
std::string StateHashHex(const World& w);

/// Prints the paper's Figure 6 and Figure 7 tables: medians and maxima of the
/// steps with contacts, beside the paper's numbers (its deepest grasp, step 3).
void PrintPaperTables(const std::vector<StepRecord>& steps);

}  // namespace gs::app
