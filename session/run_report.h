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

/// timings.csv: one line per step, the stages' wall times in ms.
void WriteTimingsHeader(std::ostream& o);
void WriteTimingsRow(std::ostream& o, const World& w);

/// Writes DIR/summary.json whole (through a temporary file and a rename), so that
/// an interrupted or failed write never leaves half a summary.
bool WriteSummaryJson(const std::string& dir, const std::string& summary_json, std::string* error);

/// trajectory.csv of run and replay: `step,t_s`, then each free body's position
/// (`NAME_x_m`, `NAME_y_m`, `NAME_z_m`) and orientation quaternion (`NAME_qw`,
/// `NAME_qx`, `NAME_qy`, `NAME_qz`), numbers as %.17g (exact).
void WriteTrajectoryHeader(std::ostream& o, const World& w);
void WriteTrajectoryRow(std::ostream& o, const World& w);

/// contacts.csv of run and replay: one line per step and touching body pair
/// (contacts, stick, slip, separating, normal and tangential force in N,
/// penetration before and after the solve in m); no line for a rejected step.
void WriteContactsHeader(std::ostream& o);
void WriteContactsRows(std::ostream& o, const World& w);

/// Normal gap of a contact after the last step's solve (m; negative: penetration):
/// q + W r, read through the bodies as the solver does, less the overlap held back.
double PostSolveGap(const World& w, const ContactRow& row);

/// What rejected the last step, for a log line: the pass-through names the bodies.
std::string RejectText(const World& w);
/// World::last_pass_through in words: the bodies, the step, how close the centres came.
std::string PassThroughText(const World& w);

/// The per-step files of `run --out DIR`, written as the run goes (so that an
/// interrupted run keeps every step it made): trajectory.csv and contacts.csv (one
/// line per step and touching body pair: contacts, stick, slip, separating, normal
/// and tangential force, penetration before and after the solve; no line for a
/// rejected step), each every `every` steps, and timings.csv, every step.
class StepFiles {
 public:
  bool Open(const std::string& dir, const World& w, int every, std::string* error);
  void AfterStep(const World& w);
  /// Hands the rows written so far to the OS (a reader sees them; a crash keeps them).
  void Flush();
  bool Close(std::string* error);

 private:
  std::string dir_;
  std::ofstream trajectory_, contacts_, timings_;
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
