// Per-step records of a simulation run and the files and tables made from them.
#pragma once

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

/// Writes timings.csv (one line per step), contacts.csv (one line per contact
/// pair per step) and summary.json into `dir`, creating it. False with a message on error.
bool WriteRunOutputs(const std::string& dir, const std::string& scene_name, const std::vector<StepRecord>& steps,
                     const std::string& summary_json, std::string* error);

/// FNV-1a over the bits of the world's state (poses, velocities, control-point
/// displacements, finger joints, contact forces): equal hashes mean bit-identical
/// runs. Written to summary.json as state_hash by run and replay.
uint64_t StateHash(const World& w);
std::string StateHashHex(const World& w);

/// Prints the paper's Figure 6 and Figure 7 tables: medians and maxima of the
/// steps with contacts, beside the paper's numbers (its deepest grasp, step 3).
void PrintPaperTables(const std::vector<StepRecord>& steps);

}  // namespace gs::app
