// The figures of a `graspsim run --out DIR` or `graspsim replay ... --out DIR`
// folder (`graspsim plot`, README "Plotting a result"): what the folder's files
// hold, read by column name, turned into series over simulated time; the
// figures the folder cannot give are named with the reason.
#pragma once

#include <cmath>
#include <string>
#include <vector>

namespace gs::plot {

/// One PNG each, in this order.
constexpr const char* kHeightPng = "height.png";          ///< the tracked body's height
constexpr const char* kGripForcePng = "grip_force.png";   ///< force per finger on the object
constexpr const char* kContactsPng = "contacts.png";      ///< number of contacts
constexpr const char* kStickSlipPng = "stick_slip.png";   ///< stick, slip and separating contacts
constexpr const char* kStepTimePng = "step_time.png";     ///< step time against the time step

struct Series {
  std::string title;
  std::vector<double> y;  ///< one value per x of its figure
};

struct Figure {
  std::string file;  ///< kHeightPng, ...
  std::string title, xlabel, ylabel;
  std::vector<double> x;
  std::vector<Series> series;
  double line_y = NAN;     ///< a horizontal line here when finite (the step-time budget)
  std::string line_title;
};

struct MissingFigure {
  std::string file;
  std::string reason;
};

struct ResultPlots {
  std::string dir;
  bool replay = false;  ///< a replay folder (fingertips.csv, tracker.csv or a "log" in summary.json)
  std::vector<Figure> figures;
  std::vector<MissingFigure> missing;  ///< figures the folder cannot give, and why
  std::vector<std::string> notes;      ///< made, with something left out, and why
};

/// Reads the folder. False with *error naming the file (and line) when it is no
/// run or replay folder or one of its files is malformed; a figure the folder
/// has no data for is not an error (ResultPlots::missing).
bool ReadResultFolder(const std::string& dir, ResultPlots* plots, std::string* error);

enum class EWriteResult { Ok, BadOut, NoGnuplot, GnuplotFailed };

/// Draws every figure into OUT (created if needed) as width x height PNGs. The
/// figures are drawn in a scratch folder inside OUT and moved in only when all
/// were drawn, so a failure leaves OUT as it was (a folder it created removed).
EWriteResult WriteFigures(const ResultPlots& plots, const std::string& out, int width, int height,
                          std::vector<std::string>* written, std::string* error);

}  // namespace gs::plot
