// Benchmarks behind `graspsim bench NAME`. Each prints a human table, or with
// json one JSON object per line (the last one holds the headline figures).
#pragma once

namespace gs::app {

struct BenchOptions {
  bool json = false;
  bool quick = false;  ///< fewer repetitions (used by the tests)
};

int RunBenchCollision(const BenchOptions& opt);

}  // namespace gs::app
