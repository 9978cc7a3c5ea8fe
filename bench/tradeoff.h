// `graspsim bench tradeoff`: run time against error for every knob that trades
// one for the other. Each row is one setting of one knob, with the time it
// costs and the error it affects:
//   surface_points   MLS projection error on a sphere          / step time of a ball resting on it
//   bandwidth        MLS projection error (plane and quadric)  / time per projection
//   control_points   Hertz contact radius and exponent error   / step time of the Hertz scene
//   gs_tolerance     solver residual on two fixed problems      / solve time (from zero forces)
//                    pinch-hold threshold error (in simulation) / step time of the pinch
//   gs_iterations    the same, with the sweep cap binding
//   dt               trajectory error against a dt = 1e-4 s run / wall time per simulated second
// Within a series (one knob, one error, one variant) a row is on the Pareto
// front when no other row is at least as fast and at least as accurate, and
// strictly better in one.
#pragma once

#include <string>
#include <vector>

namespace gs::app {

struct TradeoffRow {
  std::string knob;        ///< surface_points, bandwidth, control_points, gs_tolerance, gs_iterations, dt
  double value = 0.0;      ///< the knob's setting
  std::string variant;     ///< which scene or problem ("" when the knob has one)
  std::string error_name;  ///< mls_projection, hertz_radius, hertz_exponent, residual, pinch_threshold, trajectory
  double error = 0.0;
  std::string error_unit;
  double time_ms = 0.0;    ///< median
  std::string time_what;   ///< what time_ms is the time of
  bool pareto = false;
  std::string detail;
};

struct TradeoffOptions {
  bool quick = false;   ///< fewer, shorter settings (the tests)
  std::string only;     ///< run only the knob of this name (empty: all)
  bool pinch = true;    ///< false: leave out the pinch runs (the slowest; the tests under sanitizers)
};

/// The knob names, in the order they run.
std::vector<std::string> TradeoffKnobs();
/// Runs the sweeps; each row is printed through `progress` as soon as it is measured (may be null).
std::vector<TradeoffRow> RunTradeoff(const TradeoffOptions& opt, void (*progress)(const TradeoffRow&) = nullptr);
/// Sets `pareto` within each series (knob, variant, error_name).
void MarkPareto(std::vector<TradeoffRow>* rows);
/// Writes DIR/tradeoff.csv and, when gnuplot is found, one PNG per series
/// (DIR/tradeoff_<knob>[_<variant>]_<error>.png) and all of them in DIR/tradeoff_overview.png:
/// time against error, log-log,
/// each point labelled with its setting, the Pareto front drawn. False with
/// *error set when the directory cannot be written or gnuplot is missing or
/// fails (the CSV is written first in every case it can be). *pngs receives
/// the PNG paths written.
bool WriteTradeoffOutputs(const std::string& dir, const std::vector<TradeoffRow>& rows, std::vector<std::string>* pngs,
                          std::string* error);
std::string TradeoffJson(const TradeoffRow& r);

}  // namespace gs::app
