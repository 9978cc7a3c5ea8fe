// ReadResultFolder: the files of a run or replay folder (README "Output files")
// into figures. Columns are found by their header names, so extra columns and
// extra summary members are ignored.
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <set>

#include "plot/csv_table.h"
#include "plot/result_plots.h"
#include "plot/summary_json.h"

namespace gs::plot {
namespace {

namespace fs = std::filesystem;

bool EndsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

struct Folder {
  std::string dir;
  bool has_summary = false;
  Summary summary;
  std::unique_ptr<CsvTable> trajectory, contacts, timings, fingertips;
  bool has_tracker = false;  ///< tracker.csv: replay's datagram log (not plotted)

  std::string Path(const char* name) const { return (fs::path(dir) / name).string(); }
  std::string Text(const char* key) const {
    auto it = summary.strings.find(key);
    return it == summary.strings.end() ? std::string() : it->second;
  }
  bool Replay() const { return fingertips || has_tracker || !Text("log").empty(); }
};

// ---- reading the files ----

bool ReadTable(const Folder& f, const char* name, const std::function<bool(const std::string&)>& keep,
               std::unique_ptr<CsvTable>* table, std::string* error) {
  std::error_code ec;
  const std::string path = f.Path(name);
  if (!fs::exists(path, ec)) return true;
  if (!fs::is_regular_file(path, ec)) {
    *error = path + ": not a regular file";
    return false;
  }
  *table = std::make_unique<CsvTable>();
  return (*table)->Read(path, keep, error);
}

bool OneOf(const std::string& name, std::initializer_list<const char*> names) {
  for (const char* n : names)
    if (name == n) return true;
  return false;
}

bool LoadFolder(const std::string& dir, Folder* f, std::string* error) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) {
    *error = dir + ": no such folder";
    return false;
  }
  if (!fs::is_directory(dir, ec)) {
    *error = dir + ": not a folder (give the folder of `graspsim run --out DIR` or `graspsim replay ... --out DIR`)";
    return false;
  }
  f->dir = dir;
  f->has_tracker = fs::is_regular_file(f->Path("tracker.csv"), ec);
  f->has_summary = fs::exists(f->Path("summary.json"), ec);
  // a FIFO or a folder under a file's name would block or mislead the reader
  if (f->has_summary && !fs::is_regular_file(f->Path("summary.json"), ec)) {
    *error = f->Path("summary.json") + ": not a regular file";
    return false;
  }
  if (f->has_summary && !ReadSummary(f->Path("summary.json"), &f->summary, error)) return false;
  return ReadTable(*f, "trajectory.csv",
                   [](const std::string& c) { return OneOf(c, {"step", "t_s"}) || EndsWith(c, "_z_m"); },
                   &f->trajectory, error) &&
         ReadTable(*f, "contacts.csv",
                   [](const std::string& c) {
                     return OneOf(c, {"step", "t_s", "body_a", "body_b", "contacts", "stick", "slip", "fn_N"});
                   },
                   &f->contacts, error) &&
         ReadTable(*f, "timings.csv",
                   [](const std::string& c) { return OneOf(c, {"step", "t_s", "time_s", "total_ms"}); }, &f->timings,
                   error) &&
         ReadTable(*f, "fingertips.csv",
                   [](const std::string& c) {
                     return OneOf(c, {"t_s", "time_s"}) || EndsWith(c, "_force_x_N") || EndsWith(c, "_force_y_N") ||
                            EndsWith(c, "_force_z_N");
                   },
                   &f->fingertips, error);
}

// the kept column `name`, or an error naming the file and the header
bool Need(const CsvTable& t, const std::string& name, int* column, std::string* error) {
  *column = t.Column(name);
  if (*column < 0) *error = t.MissingColumn(name);
  return *column >= 0;
}

// the simulated-time column: `t_s` (trajectory, contacts) or `time_s` (timings, fingertips)
bool NeedTime(const CsvTable& t, int* column, std::string* error) {
  *column = t.AnyColumn({"t_s", "time_s"});
  if (*column < 0) *error = t.MissingColumn("t_s");
  return *column >= 0;
}

std::string Subject(const Folder& f) {
  const std::string scene = f.Text("scene");
  return (scene.empty() ? std::string() : scene + " ") + (f.Replay() ? "replay" : "run");
}

// ---- height ----

bool AddHeight(const Folder& f, ResultPlots* plots, std::string* error) {
  if (!f.trajectory) {
    plots->missing.push_back({kHeightPng, "no trajectory.csv in " + f.dir});
    return true;
  }
  const CsvTable& t = *f.trajectory;
  Figure fig{kHeightPng, "", "simulated time (s)", "height of its centre, z (mm)", {}, {}, NAN, ""};
  int tc;
  if (!NeedTime(t, &tc, error) || !t.Numbers(tc, &fig.x, error)) return false;
  std::vector<std::string> bodies;
  const std::string tracked = f.Text("tracked_body");
  if (!tracked.empty()) {
    if (t.Column(tracked + "_z_m") < 0) {
      plots->missing.push_back({kHeightPng, t.path() + " has no column " + tracked + "_z_m (the tracked body '" +
                                                tracked + "' of summary.json is not a free body)"});
      return true;
    }
    bodies.push_back(tracked);
  } else {
    // no tracked body named (no summary.json): every free body's height
    for (const std::string& c : t.header())
      if (EndsWith(c, "_z_m")) bodies.push_back(c.substr(0, c.size() - 4));
    plots->notes.push_back(std::string(kHeightPng) + ": no tracked_body in summary.json, so every free body's height");
  }
  if (bodies.empty() || t.rows() == 0) {
    plots->missing.push_back({kHeightPng, t.path() + (bodies.empty() ? " has no NAME_z_m column (no free body)"
                                                                      : " has no data lines")});
    return true;
  }
  for (const std::string& b : bodies) {
    Series s{b, {}};
    if (!t.Numbers(t.Column(b + "_z_m"), &s.y, error)) return false;
    for (double& z : s.y) z *= 1e3;
    fig.series.push_back(std::move(s));
  }
  fig.title = Subject(f) + ": height of " + (tracked.empty() ? std::string("the free bodies") : tracked);
  plots->figures.push_back(std::move(fig));
  return true;
}

// ---- contacts.csv: per step totals and per pair normal force ----

struct ContactSteps {
  std::map<long long, double> time;  ///< every step written (trajectory.csv and contacts.csv): its time
  std::map<long long, std::vector<double>> totals;       ///< step -> contacts, stick, slip
  std::vector<std::string> pairs;                        ///< pairs touching the object, first seen first
  std::map<std::string, std::map<long long, double>> fn;  ///< pair -> step -> normal force (N)
};

bool StepNumber(const CsvTable& t, size_t row, int column, long long* step, std::string* error) {
  double v;
  if (!t.Number(row, column, &v, error)) return false;
  *step = std::llround(v);
  return true;
}

// the steps written to trajectory.csv: the time grid, so a step without contacts counts zero
bool TrajectorySteps(const Folder& f, ContactSteps* cs, std::string* error) {
  if (!f.trajectory || f.trajectory->Column("step") < 0) return true;
  const CsvTable& t = *f.trajectory;
  int tc;
  if (!NeedTime(t, &tc, error)) return false;
  for (size_t r = 0; r < t.rows(); ++r) {
    long long step;
    double time;
    if (!StepNumber(t, r, t.Column("step"), &step, error) || !t.Number(r, tc, &time, error)) return false;
    cs->time[step] = time;
  }
  return true;
}

bool ReadContactRow(const CsvTable& t, size_t r, const std::vector<int>& col, const std::string& object,
                    ContactSteps* cs, std::string* error) {
  long long step;
  double time, fn;
  if (!StepNumber(t, r, col[0], &step, error) || !t.Number(r, col[1], &time, error)) return false;
  cs->time.emplace(step, time);
  std::vector<double>& sum = cs->totals[step];
  sum.resize(3, 0.0);
  for (int k = 0; k < 3; ++k) {
    double v;
    if (!t.Number(r, col[4 + k], &v, error)) return false;
    sum[k] += v;
  }
  if (!t.Number(r, col[7], &fn, error)) return false;
  const std::string& a = t.Text(r, col[2]);
  const std::string& b = t.Text(r, col[3]);
  if (!object.empty() && a != object && b != object) return true;
  // the legend names the other body (a finger, the table) when the object is known
  const std::string name = object.empty() ? a + " - " + b : (a == object ? b : a);
  if (!cs->fn.count(name)) cs->pairs.push_back(name);
  cs->fn[name][step] += fn;
  return true;
}

bool ReadContacts(const Folder& f, ContactSteps* cs, std::string* error) {
  if (!TrajectorySteps(f, cs, error)) return false;
  const CsvTable& t = *f.contacts;
  std::vector<int> col;
  for (const char* name : {"step", "t_s", "body_a", "body_b", "contacts", "stick", "slip", "fn_N"}) {
    col.push_back(0);
    if (!Need(t, name, &col.back(), error)) return false;
  }
  const std::string object = f.Text("tracked_body");
  for (size_t r = 0; r < t.rows(); ++r)
    if (!ReadContactRow(t, r, col, object, cs, error)) return false;
  return true;
}

// a series over every step of the grid, zero where the step has no line
std::vector<double> OnGrid(const ContactSteps& cs, const std::map<long long, double>& values) {
  std::vector<double> y;
  for (const auto& [step, time] : cs.time) {
    auto it = values.find(step);
    y.push_back(it == values.end() ? 0.0 : it->second);
  }
  return y;
}

std::vector<double> Grid(const ContactSteps& cs) {
  std::vector<double> x;
  for (const auto& [step, time] : cs.time) x.push_back(time);
  return x;
}

void AddGripFromContacts(const Folder& f, const ContactSteps& cs, ResultPlots* plots) {
  const std::string object = f.Text("tracked_body");
  if (cs.pairs.empty()) {
    plots->missing.push_back({kGripForcePng, f.contacts->path() + ": " +
                                                 (object.empty() ? std::string("no contact at all")
                                                                 : "nothing touched " + object)});
    return;
  }
  Figure fig{kGripForcePng, "", "simulated time (s)", "normal force (N)", Grid(cs), {}, NAN, ""};
  fig.title = Subject(f) + ": normal force " +
              (object.empty() ? std::string("per body pair") : "on " + object + " from each body touching it");
  for (const std::string& p : cs.pairs) fig.series.push_back({p, OnGrid(cs, cs.fn.at(p))});
  plots->figures.push_back(std::move(fig));
}

void AddCountFigures(const Folder& f, const ContactSteps& cs, ResultPlots* plots) {
  std::map<long long, double> per_kind[3];
  for (const auto& [step, sum] : cs.totals)
    for (int k = 0; k < 3; ++k) per_kind[k][step] = sum[k];
  Figure count{kContactsPng, Subject(f) + ": number of contacts", "simulated time (s)", "contacts (count)",
               Grid(cs), {{"contacts", OnGrid(cs, per_kind[0])}}, NAN, ""};
  Figure states{kStickSlipPng, Subject(f) + ": sticking and slipping contacts", "simulated time (s)",
                "contacts (count)", Grid(cs), {}, NAN, ""};
  // separating contacts (the rest of the count, force-free) would dwarf the two: left to contacts.png
  states.series.push_back({"stick", OnGrid(cs, per_kind[1])});
  states.series.push_back({"slip", OnGrid(cs, per_kind[2])});
  plots->figures.push_back(std::move(count));
  plots->figures.push_back(std::move(states));
}

// ---- replay: the fingertips' coupling force ----

bool AddGripFromFingertips(const Folder& f, ResultPlots* plots, std::string* error) {
  const CsvTable& t = *f.fingertips;
  Figure fig{kGripForcePng, Subject(f) + ": force of each fingertip (coupling spring, magnitude)",
             "simulated time (s)", "force |F| (N)", {}, {}, NAN, ""};
  int tc;
  if (!NeedTime(t, &tc, error) || !t.Numbers(tc, &fig.x, error)) return false;
  for (const std::string& c : t.header()) {
    if (!EndsWith(c, "_force_x_N")) continue;
    const std::string tip = c.substr(0, c.size() - 10);
    std::vector<double> xyz[3];
    int k = 0;
    for (const char* axis : {"_force_x_N", "_force_y_N", "_force_z_N"}) {
      int col;
      if (!Need(t, tip + axis, &col, error) || !t.Numbers(col, &xyz[k++], error)) return false;
    }
    Series s{tip, std::vector<double>(t.rows())};
    for (size_t r = 0; r < t.rows(); ++r) s.y[r] = std::hypot(xyz[0][r], xyz[1][r], xyz[2][r]);
    fig.series.push_back(std::move(s));
  }
  if (fig.series.empty() || t.rows() == 0) {
    plots->missing.push_back({kGripForcePng, t.path() + (fig.series.empty() ? " has no NAME_force_x_N column"
                                                                             : " has no data lines")});
    return true;
  }
  plots->figures.push_back(std::move(fig));
  return true;
}

// ---- what contacts.csv or fingertips.csv give ----

bool AddContactFigures(const Folder& f, ResultPlots* plots, std::string* error) {
  if (f.contacts) {
    ContactSteps cs;
    if (!ReadContacts(f, &cs, error)) return false;
    if (cs.time.empty()) {
      for (const char* png : {kGripForcePng, kContactsPng, kStickSlipPng})
        plots->missing.push_back({png, f.contacts->path() + " has no data lines and there is no trajectory.csv"});
      return true;
    }
    AddGripFromContacts(f, cs, plots);
    AddCountFigures(f, cs, plots);
    return true;
  }
  const std::string why = "no contacts.csv in " + f.dir;
  if (f.fingertips) {
    if (!AddGripFromFingertips(f, plots, error)) return false;
  } else {
    plots->missing.push_back({kGripForcePng, f.Replay() ? "no fingertips.csv in " + f.dir : why});
  }
  plots->missing.push_back({kContactsPng, why});
  plots->missing.push_back({kStickSlipPng, why});
  return true;
}

// ---- step time against the time step ----

bool AddStepTime(const Folder& f, ResultPlots* plots, std::string* error) {
  if (!f.timings) {
    plots->missing.push_back({kStepTimePng, f.Replay() ? "a replay folder has no timings.csv (replay writes no "
                                                         "wall-clock times, so that its outputs are bit-identical)"
                                                       : "no timings.csv in " + f.dir});
    return true;
  }
  const CsvTable& t = *f.timings;
  Figure fig{kStepTimePng, Subject(f) + ": step time against the time step", "simulated time (s)",
             "step time (ms)", {}, {{"step time", {}}}, NAN, ""};
  int tc, total;
  if (!NeedTime(t, &tc, error) || !Need(t, "total_ms", &total, error) || !t.Numbers(tc, &fig.x, error) ||
      !t.Numbers(total, &fig.series[0].y, error))
    return false;
  if (t.rows() == 0) {
    plots->missing.push_back({kStepTimePng, t.path() + " has no data lines"});
    return true;
  }
  auto dt = f.summary.numbers.find("dt_s");
  if (dt != f.summary.numbers.end() && dt->second > 0) {
    fig.line_y = 1e3 * dt->second;
    char title[64];
    std::snprintf(title, sizeof title, "budget: time step %.4g ms", fig.line_y);
    fig.line_title = title;
  } else {
    plots->notes.push_back(std::string(kStepTimePng) + ": no budget line (" +
                           (f.has_summary ? "summary.json has no dt_s" : "no summary.json") + ")");
  }
  plots->figures.push_back(std::move(fig));
  return true;
}

}  // namespace

bool ReadResultFolder(const std::string& dir, ResultPlots* plots, std::string* error) {
  Folder f;
  if (!LoadFolder(dir, &f, error)) return false;
  if (!f.trajectory && !f.contacts && !f.timings && !f.fingertips) {
    *error = dir + ": not a run or replay folder: none of trajectory.csv, contacts.csv, timings.csv, fingertips.csv "
                   "(`graspsim run --out DIR` and `graspsim replay ... --out DIR` write them)";
    return false;
  }
  *plots = ResultPlots();
  plots->dir = dir;
  plots->replay = f.Replay();
  return AddHeight(f, plots, error) && AddContactFigures(f, plots, error) && AddStepTime(f, plots, error);
}

}  // namespace gs::plot
