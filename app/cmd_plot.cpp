// `graspsim plot DIR [--out PLOTDIR] [--size WxH] [--quiet]`: PNG figures of a
// `run --out DIR` or `replay ... --out DIR` folder through gnuplot (README
// "Plotting a result"). The figures the folder cannot give are named with the
// reason; a folder that is no result, or a malformed file in it, is refused.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "app/cli_help.h"
#include "app/commands.h"
#include "plot/result_plots.h"

namespace gs::app {
namespace {

constexpr int kExitGnuplot = kExitMissingTool;  // gnuplot missing or failing, as for `bench tradeoff --plot`

struct PlotOptions {
  std::string dir;
  std::string out;  ///< default DIR/plots
  std::string size = "1000x600";
  bool quiet = false;
};

bool ParseSize(const std::string& s, int* w, int* h) {
  char tail = 0;
  return std::sscanf(s.c_str(), "%dx%d%c", w, h, &tail) == 2 && *w >= 200 && *h >= 150 && *w <= 8000 &&
         *h <= 8000;
}

void Report(const plot::ResultPlots& plots, const std::string& out, const std::vector<std::string>& written,
            bool quiet) {
  if (!quiet) {
    std::printf("graspsim plot: %zu figure%s of the %s folder %s in %s:\n", written.size(),
                written.size() == 1 ? "" : "s", plots.replay ? "replay" : "run", plots.dir.c_str(), out.c_str());
    for (const std::string& png : written) std::printf("  %s\n", png.c_str());
  }
  // what could not be drawn is said even with --quiet: a missing figure is never silent
  for (const plot::MissingFigure& m : plots.missing)
    std::fprintf(stderr, "graspsim plot: no %s: %s\n", m.file.c_str(), m.reason.c_str());
  for (const std::string& n : plots.notes) std::fprintf(stderr, "graspsim plot: note: %s\n", n.c_str());
}

int Plot(const PlotOptions& opt) {
  int width = 0, height = 0;
  if (!ParseSize(opt.size, &width, &height)) {
    std::fprintf(stderr, "graspsim plot: --size %s: expected WxH, width 200 to 8000 and height 150 to 8000 pixels\n",
                 opt.size.c_str());
    return kExitUsage;
  }
  plot::ResultPlots plots;
  std::string error;
  if (!plot::ReadResultFolder(opt.dir, &plots, &error)) {
    std::fprintf(stderr, "graspsim plot: %s\n", error.c_str());
    return kExitBadInput;
  }
  if (plots.figures.empty()) {
    std::fprintf(stderr, "graspsim plot: nothing to plot in %s\n", opt.dir.c_str());
    Report(plots, "", {}, true);
    return kExitBadInput;
  }
  const std::string out = opt.out.empty() ? (std::filesystem::path(opt.dir) / "plots").string() : opt.out;
  std::vector<std::string> written;
  switch (plot::WriteFigures(plots, out, width, height, &written, &error)) {
    case plot::EWriteResult::Ok:
      Report(plots, out, written, opt.quiet);
      return kExitOk;
    case plot::EWriteResult::BadOut:
      std::fprintf(stderr, "graspsim plot: %s\n", error.c_str());
      return kExitUsage;
    case plot::EWriteResult::NoGnuplot:
    case plot::EWriteResult::GnuplotFailed:
      break;
  }
  std::fprintf(stderr, "graspsim plot: %s\n", error.c_str());
  return kExitGnuplot;
}

}  // namespace

void AddPlotCommand(CLI::App& app, int* exit_code) {
  auto opt = std::make_shared<PlotOptions>();
  CLI::App* cmd = app.add_subcommand(
      "plot", "PNG figures of a `run --out DIR` or `replay ... --out DIR` folder through gnuplot: height, grip "
              "force, contacts, stick/slip, step time");
  cmd->add_option("dir", opt->dir, "the output folder of graspsim run or replay")->required()->type_name("DIR");
  cmd->add_option("--out", opt->out, "folder for the PNGs (default: DIR/plots)")->type_name("PLOTDIR");
  cmd->add_option("--size", opt->size, "figure size in pixels")->type_name("WxH")->capture_default_str();
  cmd->add_flag("--quiet", opt->quiet, "no list of the figures written (figures that cannot be made are still named)");
  SetHelpFooter(cmd,
                {{"graspsim plot out/", "the figures of `graspsim run --out out/`, written to out/plots/"},
                 {"graspsim plot replay_out/ --out figures/ --size 1600x900", "a replay folder's figures, larger"}},
                {{kExitOk, "the figures were written (the ones the folder cannot give are named)"},
                 {kExitUsage, "bad command line: --out cannot be made or written, a bad --size"},
                 {kExitBadInput, "DIR is not a run or replay folder, or one of its files is malformed (file:line)"},
                 {kExitMissingTool, "gnuplot is missing or failed (scripts/setup.sh installs it)"}});
  cmd->callback([opt, exit_code]() { *exit_code = Plot(*opt); });
}

}  // namespace gs::app
