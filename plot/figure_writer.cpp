// WriteFigures: one gnuplot script for every figure, drawn in a scratch folder
// inside OUT and moved into OUT only when gnuplot made every PNG, so that a
// failure leaves nothing half-written behind.
#include <stdlib.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "plot/gnuplot.h"
#include "plot/result_plots.h"

namespace gs::plot {
namespace {

namespace fs = std::filesystem;

// the folders create_directories(out) will make, outermost first (removed again on failure)
std::vector<fs::path> FoldersToCreate(const fs::path& out) {
  std::vector<fs::path> missing;
  std::error_code ec;
  for (fs::path p = fs::absolute(out, ec).lexically_normal(); !p.empty() && !fs::exists(p, ec);
       p = p.parent_path()) {
    missing.insert(missing.begin(), p);
    if (p == p.parent_path()) break;
  }
  return missing;
}

// OUT as a folder we can write a scratch folder into; *scratch is that folder
bool PrepareOut(const std::string& out, std::vector<fs::path>* created, std::string* scratch, std::string* error) {
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_directory(out, ec)) {
    *error = "--out " + out + ": exists and is not a folder";
    return false;
  }
  *created = FoldersToCreate(out);
  fs::create_directories(out, ec);
  if (ec) {
    *error = "--out " + out + ": cannot create the folder: " + ec.message();
    return false;
  }
  std::string tmpl = (fs::path(out) / ".graspsim-plot-XXXXXX").string();
  if (!mkdtemp(tmpl.data())) {
    *error = "--out " + out + ": cannot write into the folder: " + std::strerror(errno);
    return false;
  }
  *scratch = tmpl;
  return true;
}

// the figure's data: x, then one column per series, %.9g
bool WriteData(const Figure& fig, const std::string& path) {
  std::ofstream d(path, std::ios::binary);
  char cell[32];
  for (size_t i = 0; i < fig.x.size(); ++i) {
    std::snprintf(cell, sizeof cell, "%.9g", fig.x[i]);
    d << cell;
    for (const Series& s : fig.series) {
      std::snprintf(cell, sizeof cell, " %.9g", s.y[i]);
      d << cell;
    }
    d << "\n";
  }
  return static_cast<bool>(d);
}

void WriteFigureScript(std::ostream& gp, const Figure& fig, const std::string& dat, const std::string& png) {
  gp << "set output " << GpFileName(png) << "\nset autoscale\n"
     << "set title " << GpText(fig.title) << "\nset xlabel " << GpText(fig.xlabel) << "\nset ylabel "
     << GpText(fig.ylabel) << "\n";
  // step times and counts start at zero: the budget line and a fall to zero stay in view
  if (fig.file != kHeightPng) gp << "set yrange [0:*]\n";
  const char* style = fig.x.size() > 1 ? "with lines lw 2" : "with points pt 7 ps 1.5";
  gp << "plot ";
  for (size_t k = 0; k < fig.series.size(); ++k)
    gp << (k ? ", " : "") << GpFileName(dat) << " using 1:" << k + 2 << " " << style << " title "
       << GpText(fig.series[k].title);
  if (std::isfinite(fig.line_y))
    gp << ", " << fig.line_y << " with lines dt 2 lw 2 lc rgb '#d62728' title " << GpText(fig.line_title);
  gp << "\n";
}

bool WriteScript(const std::vector<Figure>& figures, const std::string& scratch, int width, int height,
                 std::string* error) {
  std::ofstream gp(scratch + "/plots.gp", std::ios::binary);
  gp << "set terminal pngcairo size " << width << "," << height << " noenhanced font ',11'\n"
     << "set grid\nset key top right box opaque\n";
  for (const Figure& fig : figures) {
    const std::string dat = scratch + "/" + fig.file + ".dat";
    if (!WriteData(fig, dat)) {
      *error = "cannot write " + dat;
      return false;
    }
    WriteFigureScript(gp, fig, dat, scratch + "/" + fig.file);
  }
  if (!gp) *error = "cannot write " + scratch + "/plots.gp";
  return static_cast<bool>(gp);
}

// every PNG drawn and non-empty, then moved into OUT
bool MoveFigures(const std::vector<Figure>& figures, const std::string& scratch, const std::string& out,
                 std::vector<std::string>* written, std::string* error) {
  std::error_code ec;
  for (const Figure& fig : figures) {
    const auto bytes = fs::file_size(scratch + "/" + fig.file, ec);
    if (ec || bytes == 0) {
      *error = "gnuplot wrote no " + fig.file;
      return false;
    }
  }
  for (const Figure& fig : figures) {
    const std::string dest = (fs::path(out) / fig.file).string();
    fs::rename(scratch + "/" + fig.file, dest, ec);
    if (ec) {
      *error = "cannot move " + fig.file + " into " + out + ": " + ec.message();
      return false;
    }
    written->push_back(dest);
  }
  return true;
}

// undoes PrepareOut: the scratch folder, and the folders it created if they are empty
void CleanUp(const std::string& scratch, const std::vector<fs::path>& created, bool failed) {
  std::error_code ec;
  if (!scratch.empty()) fs::remove_all(scratch, ec);
  if (!failed) return;
  for (auto it = created.rbegin(); it != created.rend(); ++it) fs::remove(*it, ec);
}

}  // namespace

EWriteResult WriteFigures(const ResultPlots& plots, const std::string& out, int width, int height,
                          std::vector<std::string>* written, std::string* error) {
  if (!GnuplotFound()) {
    *error = std::string(kGnuplotMissing) + ", so no figures";
    return EWriteResult::NoGnuplot;
  }
  std::vector<fs::path> created;
  std::string scratch;
  if (!PrepareOut(out, &created, &scratch, error)) {
    CleanUp("", created, true);
    return EWriteResult::BadOut;
  }
  EWriteResult result = EWriteResult::Ok;
  if (!WriteScript(plots.figures, scratch, width, height, error))
    result = EWriteResult::BadOut;
  else if (!RunGnuplot(scratch + "/plots.gp", error) || !MoveFigures(plots.figures, scratch, out, written, error))
    result = EWriteResult::GnuplotFailed;
  CleanUp(scratch, created, result != EWriteResult::Ok);
  return result;
}

}  // namespace gs::plot
