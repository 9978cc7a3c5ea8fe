// `graspsim bench solver [--json] [--quick]`: our solver (auto: SolveFcMethod,
// core/fc_fallback.h) side by side with three Siconos Numerics solvers, NSGS,
// NSN-AC (semi-smooth Newton on Alart-Curnier) and PROX, on the same problems:
// random rigid-body stacks, the two real FCLIB samples of tests/data/fclib/, the
// paper grasp's own contact problem (full run only), and generated families hard for
// Gauss-Seidel (core/fc_families.h: one body gripped by many contacts, stacks
// with mass ratios up to 1,000, piles of bodies with friction 0.3-1, near-
// degenerate cones). Each solver starts from zero forces and must reach the
// Siconos error 1e-6 (SOLVER-REFERENCE's measure, recomputed by us from the
// returned forces).
//
// Per problem: every solver first runs once (Siconos in a child process, so an
// assert inside it fails that solver, not the benchmark), which decides whether it
// solves the problem, with which Siconos tolerance (their own stopping tests are
// not our error: the tolerance is tightened until the forces reach 1e-6) and why
// it stopped when it does not. That run also warms the caches. Then the solvers
// that solved it are timed in interleaved rounds (ours, NSGS, NSN-AC, PROX, ours,
// ...), the same number of rounds in --quick as in the full run (quick means fewer
// and smaller problems); a solve shorter than 2 ms is repeated back to back within
// its round so that each sample is at least 2 ms. The time is the median of the
// rounds in processor time of the process (a machine shared with other work
// preempts a wall-clock sample, not its processor time; the wall-clock median is
// reported beside it). The ratio is ours against the fastest Siconos solver that
// solved it.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "bench/bench.h"
#include "scene/paths.h"
#include "scene/scene_file.h"
#include "bench/siconos_ref.h"
#include "core/fc_fallback.h"
#include "core/fc_families.h"
#include "core/world.h"
#include "session/console.h"
#ifdef GRASPSIM_HAVE_FCLIB
#include "fclib/fclib_io.h"
#endif

namespace gs::app {
namespace {

constexpr double kTarget = 1e-6;
constexpr int kOurSweepCap = 20000;
constexpr double kMinSampleS = 2e-3;  ///< a timed sample repeats short solves up to this
constexpr int kMaxBatch = 100;

struct Problem {
  std::string name;
  std::string family;
  FcProblem p;
};

enum Solver { kOurs, kNsgs, kNsnAc, kProx, kSolvers };

struct SolverInfo {
  const char* key;    ///< JSON prefix
  const char* label;  ///< human name
  ESiconosSolver which;
  int cap;  ///< iterations (ours: sweeps)
};

const SolverInfo kInfo[kSolvers] = {
    {"ours", "ours", ESiconosSolver::Nsgs, kOurSweepCap},
    {"nsgs", "Siconos NSGS", ESiconosSolver::Nsgs, 10000},
    {"nsn_ac", "Siconos NSN-AC", ESiconosSolver::NsnAc, 200},
    {"prox", "Siconos PROX", ESiconosSolver::Prox, 200},
};

/// One solver on one problem: the deciding run, then the timed rounds.
struct Outcome {
  bool ran = false;
  bool solved = false;
  int iterations = 0;
  double error = NAN;
  double tolerance = 0.0;  ///< Siconos: the tolerance handed to it
  double first_s = 0.0;    ///< the deciding run's time
  std::string stop;        ///< why it stopped, when it did not solve
  int batch = 1;           ///< solves per timed sample
  std::vector<double> ms;       ///< one sample per round: processor ms per solve
  std::vector<double> wall_ms;  ///< the same samples in wall-clock ms
};

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t k = static_cast<size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, k == 0 ? 0 : k - 1)];
}
double Median(const std::vector<double>& v) { return Quantile(v, 0.5); }

bool InCi() {
  const char* ci = std::getenv("CI");
  return ci && *ci && std::strcmp(ci, "0") != 0 && std::strcmp(ci, "false") != 0;
}

// ours is what `graspsim solve` runs by default: auto (NSGS, then Newton when it stalls)
FcMethodParams OurParams() {
  FcMethodParams params;
  params.tolerance = kTarget;
  params.max_sweeps = kOurSweepCap;
  return params;
}

std::string Printf(const char* fmt, double x) {
  char b[96];
  std::snprintf(b, sizeof b, fmt, x);
  return b;
}

Outcome DecideOurs(const FcProblem& p) {
  Outcome o;
  o.ran = true;
  Eigen::VectorXd r;
  const FcMethodResult res = SolveFcMethod(p, EFcMethod::Auto, OurParams(), &r);
  o.iterations = res.nsgs.iterations + res.newton.iterations;
  o.error = FcError(p, r);
  o.first_s = res.seconds;
  o.solved = o.error <= kTarget;
  if (!o.solved) o.stop = res.Summary();
  return o;
}

// Siconos' own stopping tests are not our error: from 1e-6, the tolerance is
// tightened tenfold until the forces reach it, down to 1e-9.
Outcome DecideSiconos(const FcProblem& p, const SolverInfo& s) {
  Outcome o;
  if (!SiconosAvailable()) return o;
  o.ran = true;
  for (double tol = kTarget; tol >= kTarget * 0.9e-3; tol *= 0.1) {
    Eigen::VectorXd r;
    const SiconosRun run = SolveWithSiconosIsolated(p, s.which, tol, s.cap, &r);
    o.tolerance = tol;
    o.iterations = run.iterations;
    o.first_s = run.seconds;
    if (run.signal != 0) {
      o.error = NAN;
      o.stop = "aborted by signal " + std::to_string(run.signal) + " (" + strsignal(run.signal) + ")";
      return o;
    }
    o.error = r.size() == 3 * p.contacts ? FcError(p, r) : NAN;
    if (o.error <= kTarget) {
      o.solved = true;
      return o;
    }
    if (!std::isfinite(o.error)) {
      o.stop = "returned no finite forces (info " + std::to_string(run.info) + ")";
      return o;
    }
    if (run.iterations >= s.cap) {
      o.stop = "iteration cap " + std::to_string(s.cap) + Printf(" at tolerance %.0e", tol);
      return o;
    }
  }
  o.stop = "met its own test at every tolerance down to" + Printf(" %.0e", o.tolerance);
  return o;
}

double CpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double WallSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// One timed sample: `batch` solves from zero forces, each from the problem as we
// hold it (W, q, mu) to the forces: ours builds its block operator, Siconos its
// sparse-block matrix and problem. Processor time of the whole process (every
// thread, OpenBLAS's included) per solve in ms, and wall time alongside.
void TimeSample(const FcProblem& p, Solver s, Outcome* o) {
  const double cpu0 = CpuSeconds(), wall0 = WallSeconds();
  for (int k = 0; k < o->batch; ++k) {
    if (s == kOurs) {
      Eigen::VectorXd r;
      SolveFcMethod(p, EFcMethod::Auto, OurParams(), &r);
    } else {
      SolveWithSiconos(p, kInfo[s].which, o->tolerance, kInfo[s].cap);
    }
  }
  o->ms.push_back(1e3 * (CpuSeconds() - cpu0) / o->batch);
  o->wall_ms.push_back(1e3 * (WallSeconds() - wall0) / o->batch);
}

/// Rounds of interleaved timing: 7, or fewer when one round of all solvers is long
/// (5 past 3 s, 3 past 15 s of wall time): the same rule in --quick and the full run.
int Rounds(double round_s) { return round_s <= 3.0 ? 7 : round_s <= 15.0 ? 5 : 3; }

int TimeInterleaved(const FcProblem& p, Outcome out[kSolvers]) {
  double round_s = 0.0;
  for (int s = 0; s < kSolvers; ++s) {
    if (!out[s].solved) continue;
    const double first = std::max(out[s].first_s, 1e-6);
    out[s].batch = std::clamp(static_cast<int>(std::ceil(kMinSampleS / first)), 1, kMaxBatch);
    round_s += out[s].batch * first;
  }
  const int rounds = Rounds(round_s);
  for (int k = 0; k < rounds; ++k)
    for (int s = 0; s < kSolvers; ++s)
      if (out[s].solved) TimeSample(p, static_cast<Solver>(s), &out[s]);
  return rounds;
}

bool PaperGraspProblem(Problem* out, std::string* error) {
  auto built = std::make_unique<BuiltScene>();
  if (!LoadAndBuildScene(ResolveResource("config/paper_box_grasp.yaml"), built.get(), error)) return false;
  World& w = built->world;
  while (w.time < 1.0 - 0.5 * w.params.dt) {  // into the hold phase, the deepest grasp
    built->script.Apply(w, w.time + w.params.dt);
    w.Step();
  }
  out->name = "paper_grasp_t1.0";
  out->family = "paper_grasp";
  AssembleContactProblem(w, &out->p);
  return out->p.contacts > 0;
}

// The generated families. --quick keeps one small member of each (and no problem
// on which a Siconos solver takes more than ~0.1 s on a quiet core), so that its
// rounds stay short; the full run adds the large ones.
void AddFamilies(bool quick, std::vector<Problem>* out) {
  auto add = [out](std::string name, const char* family, FcProblem p) {
    out->push_back({std::move(name), family, std::move(p)});
  };
  using Ints = std::vector<int>;
  using Doubles = std::vector<double>;
  for (int n : quick ? Ints{50} : Ints{50, 150, 500, 2000})
    add("random_rigid_" + std::to_string(n), "random_rigid", RandomRigidProblem(n, 4, 7));
  for (int n : quick ? Ints{24} : Ints{24, 48, 200})
    add("gripped_" + std::to_string(n), "gripped", GrippedBodyProblem(n, 1));
  add("stack_4_ratio1000", "mass_ratio_stack", MassRatioStackProblem(4, 1000, 1));
  for (double ratio : quick ? Doubles{} : Doubles{10, 100, 1000})
    add("stack_10" + Printf("_ratio%g", ratio), "mass_ratio_stack", MassRatioStackProblem(10, ratio, 1));
  for (int n : quick ? Ints{12} : Ints{100, 400})
    add("pile_" + std::to_string(n), "pile", PileProblem(n, 0.3, 1.0, 1));
  for (double mu : quick ? Doubles{1e-3, 10} : Doubles{0.0, 1e-3, 10})
    add(Printf("cone_mu%g", mu), "cone", ConeProblem(mu, 1));
}

bool AddRealProblems(std::vector<Problem>* out, std::string* error) {
#ifdef GRASPSIM_HAVE_FCLIB
  for (const char* f : {"Capsules-i125-1213.hdf5", "LMGC_100_PR_PerioBox-i00361-60-03000.hdf5"}) {
    Problem pr;
    pr.name = f;
    pr.name.resize(pr.name.size() - 5);
    pr.family = "fclib";
    if (!ReadFclibLocal(ResolveResource(std::string("tests/data/fclib/") + f), &pr.p, error)) return false;
    out->push_back(std::move(pr));
  }
#else
  (void)out;
  (void)error;
#endif
  return true;
}

bool FclibAvailable() {
#ifdef GRASPSIM_HAVE_FCLIB
  return true;
#else
  return false;
#endif
}

/// One problem's outcome for every solver, and the ratios drawn from it.
struct Row {
  const Problem* pr = nullptr;
  Outcome out[kSolvers];
  int rounds = 0;
  int best = -1;  ///< the fastest Siconos solver that solved it
  double ratio_best = NAN, ratio_nsgs = NAN;
};

Row RunProblem(const Problem& pr) {
  Row row;
  row.pr = &pr;
  row.out[kOurs] = DecideOurs(pr.p);
  for (int s = kNsgs; s < kSolvers; ++s) row.out[s] = DecideSiconos(pr.p, kInfo[s]);
  row.rounds = TimeInterleaved(pr.p, row.out);
  for (int s = kNsgs; s < kSolvers; ++s)
    if (row.out[s].solved && (row.best < 0 || Median(row.out[s].ms) < Median(row.out[row.best].ms))) row.best = s;
  const double ours = row.out[kOurs].solved ? Median(row.out[kOurs].ms) : NAN;
  if (row.best >= 0) row.ratio_best = ours / Median(row.out[row.best].ms);
  if (row.out[kNsgs].solved) row.ratio_nsgs = ours / Median(row.out[kNsgs].ms);
  return row;
}

bool AllFailed(const Row& row) {
  for (const Outcome& o : row.out)
    if (o.solved) return false;
  return true;
}

std::string Num(double x) {
  if (!std::isfinite(x)) return "null";
  return Printf("%.6g", x);
}

std::string Short(double x) { return std::isfinite(x) ? Printf("%.3g", x) : "-"; }

std::string Quote(const std::string& s) {
  std::string q = "\"";
  for (char c : s) q += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  return q + "\"";
}

void PrintJsonRow(const Row& row) {
  std::string line = "{\"problem\":" + Quote(row.pr->name) + ",\"family\":" + Quote(row.pr->family) +
                     ",\"contacts\":" + std::to_string(row.pr->p.contacts) + ",\"rounds\":" + std::to_string(row.rounds);
  for (int s = 0; s < kSolvers; ++s) {
    const Outcome& o = row.out[s];
    const std::string k = std::string(",\"") + kInfo[s].key;
    line += k + "_solved\":" + (o.solved ? "true" : "false") + k + "_ms\":" + Num(Median(o.ms)) + k +
            "_ms_min\":" + Num(Quantile(o.ms, 0.0)) + k + "_ms_max\":" + Num(Quantile(o.ms, 1.0)) + k + "_wall_ms\":" + Num(Median(o.wall_ms)) + k +
            "_samples\":" + std::to_string(o.ms.size()) + k + "_batch\":" + std::to_string(o.batch) + k +
            "_iterations\":" + std::to_string(o.iterations) + k + "_error\":" + Num(o.error);
    if (s != kOurs) line += k + "_tolerance\":" + Num(o.tolerance);
    if (!o.solved) line += k + "_stop\":" + Quote(o.ran ? o.stop : "not built in");
  }
  line += ",\"best_siconos\":" + (row.best < 0 ? std::string("null") : Quote(kInfo[row.best].key)) +
          ",\"all_failed\":" + (AllFailed(row) ? "true" : "false") +
          ",\"time_ratio_vs_best_siconos\":" + Num(row.ratio_best) + ",\"time_ratio_vs_nsgs\":" + Num(row.ratio_nsgs) +
          "}";
  std::puts(line.c_str());
}

// One line per solver that did not solve the problem, with its error and the cap it hit.
void PrintJsonFailures(const Row& row) {
  for (int s = 0; s < kSolvers; ++s) {
    const Outcome& o = row.out[s];
    if (!o.ran || o.solved) continue;
    std::printf("{\"not_solved_by\":\"%s\",\"problem\":%s,\"family\":%s,\"error\":%s,\"iterations\":%d,\"stop\":%s}\n",
                kInfo[s].key, Quote(row.pr->name).c_str(), Quote(row.pr->family).c_str(), Num(o.error).c_str(),
                o.iterations, Quote(o.stop).c_str());
  }
  if (AllFailed(row))
    std::printf("{\"not_solved_by\":\"all\",\"problem\":%s,\"family\":%s}\n", Quote(row.pr->name).c_str(),
                Quote(row.pr->family).c_str());
}

std::string Cell(const Outcome& o) {
  if (!o.ran) return "-";
  if (!o.solved) return "x " + Printf("%.1e", o.error);
  return Printf("%.3g", Median(o.ms)) + " / " + std::to_string(o.iterations);
}

void PrintHumanHeader() {
  std::printf("%-36s %-16s %5s |", "problem", "family", "n");
  for (const SolverInfo& s : kInfo) std::printf(" %16s", (std::string(s.label) + " ms/it").c_str());
  std::printf(" | %-6s %6s %6s\n", "best", "/best", "/NSGS");
}

void PrintHumanRow(const Row& row) {
  std::printf("%-36s %-16s %5d |", row.pr->name.c_str(), row.pr->family.c_str(), row.pr->p.contacts);
  for (const Outcome& o : row.out) std::printf(" %16s", Cell(o).c_str());
  std::printf(" | %-6s %6s %6s\n", row.best < 0 ? "-" : kInfo[row.best].key,
              std::isfinite(row.ratio_best) ? Printf("%.3g", row.ratio_best).c_str() : "-",
              std::isfinite(row.ratio_nsgs) ? Printf("%.3g", row.ratio_nsgs).c_str() : "-");
}

void PrintHumanFailures(const std::vector<Row>& rows) {
  std::printf("\nNot solved to %.0e (final error, why it stopped):\n", kTarget);
  int n = 0;
  for (const Row& row : rows) {
    for (int s = 0; s < kSolvers; ++s) {
      const Outcome& o = row.out[s];
      if (!o.ran || o.solved) continue;
      std::printf("  %-36s %-15s %9s  %s\n", row.pr->name.c_str(), kInfo[s].label, Printf("%.2e", o.error).c_str(),
                  o.stop.c_str());
      ++n;
    }
    if (AllFailed(row)) std::printf("  %-36s NO SOLVER solved it\n", row.pr->name.c_str());
  }
  if (n == 0) std::printf("  (none)\n");
}

/// The headline's figures over all rows.
struct Summary {
  std::vector<double> ratio_best, ratio_nsgs;
  int unsolved = 0, nsgs_unsolved = 0, all_failed = 0, stall_wins = 0, no_siconos_wins = 0, siconos_only = 0;
  int min_rounds = 0;
};

Summary Summarise(const std::vector<Row>& rows) {
  Summary s;
  s.min_rounds = rows.empty() ? 0 : rows.front().rounds;
  for (const Row& row : rows) {
    const bool ours = row.out[kOurs].solved;
    s.unsolved += ours ? 0 : 1;
    s.all_failed += AllFailed(row) ? 1 : 0;
    if (row.out[kNsgs].ran && !row.out[kNsgs].solved) {
      ++s.nsgs_unsolved;
      s.stall_wins += ours ? 1 : 0;
    }
    if (ours && row.best < 0 && row.out[kNsgs].ran) ++s.no_siconos_wins;
    if (!ours && row.best >= 0) ++s.siconos_only;
    if (std::isfinite(row.ratio_best)) s.ratio_best.push_back(row.ratio_best);
    if (std::isfinite(row.ratio_nsgs)) s.ratio_nsgs.push_back(row.ratio_nsgs);
    if (row.rounds > 0) s.min_rounds = std::min(s.min_rounds == 0 ? row.rounds : s.min_rounds, row.rounds);
  }
  return s;
}

void PrintJsonHeadline(const Summary& s, size_t problems) {
  std::printf(
      "{\"bench\":\"solver\",\"siconos\":%s,\"fclib\":%s,\"problems\":%zu,\"target_error\":%.0e,\"min_rounds\":%d,"
      "\"time_ratio_vs_best_siconos_median\":%s,\"time_ratio_vs_best_siconos_p90\":%s,"
      "\"worst_time_ratio_vs_best_siconos\":%s,\"time_ratio_vs_nsgs_median\":%s,\"worst_time_ratio_vs_nsgs\":%s,"
      "\"target_ratio\":0.5,\"nsgs_unsolved\":%d,\"solved_where_nsgs_stalls\":%d,"
      "\"solved_where_no_siconos_solves\":%d,\"siconos_solves_where_we_fail\":%d,\"all_failed\":%d,\"unsolved\":%d,"
      "\"interrupted\":%s}\n",
      SiconosAvailable() ? "true" : "false", FclibAvailable() ? "true" : "false", problems, kTarget, s.min_rounds,
      Num(Median(s.ratio_best)).c_str(), Num(Quantile(s.ratio_best, 0.9)).c_str(),
      Num(Quantile(s.ratio_best, 1.0)).c_str(), Num(Median(s.ratio_nsgs)).c_str(),
      Num(Quantile(s.ratio_nsgs, 1.0)).c_str(), s.nsgs_unsolved, s.stall_wins, s.no_siconos_wins, s.siconos_only,
      s.all_failed, s.unsolved, StopRequested() ? "true" : "false");
}

void PrintHumanHeadline(const Summary& s) {
  if (StopRequested()) std::printf("\ninterrupted: the figures below cover the problems measured before the stop\n");
  std::printf("\nours / fastest Siconos solver that solved it, over %zu problems: median %s, 90th percentile %s, "
              "worst %s\n",
              s.ratio_best.size(), Short(Median(s.ratio_best)).c_str(), Short(Quantile(s.ratio_best, 0.9)).c_str(),
              Short(Quantile(s.ratio_best, 1.0)).c_str());
  std::printf("ours / Siconos NSGS, over %zu problems: median %s, worst %s (target <= 0.5)\n", s.ratio_nsgs.size(),
              Short(Median(s.ratio_nsgs)).c_str(), Short(Quantile(s.ratio_nsgs, 1.0)).c_str());
  std::printf("ours unsolved %d (of which some Siconos solver solves %d); NSGS unsolved %d, of which we solve %d; "
              "solved by no Siconos solver but ours %d; solved by none %d\n",
              s.unsolved, s.siconos_only, s.nsgs_unsolved, s.stall_wins, s.no_siconos_wins, s.all_failed);
}

/// Says which peer is missing; true when that must fail the run (CI=true).
bool ReportMissingPeers() {
  bool missing = false;
  if (!SiconosAvailable()) {
    std::fprintf(stderr, "graspsim bench solver: Siconos Numerics is not built in (install libsiconos-numerics-dev "
                         "and reconfigure): ours runs alone, no ratio is measured\n");
    missing = true;
  }
  if (!FclibAvailable()) {
    std::fprintf(stderr, "graspsim bench solver: FCLIB is not built in (install libfclib-dev and reconfigure): the "
                         "real FCLIB problems are left out\n");
    missing = true;
  }
  if (missing && InCi()) std::fprintf(stderr, "graspsim bench solver: CI is set: a missing peer fails the run\n");
  return missing && InCi();
}

// --only: keeps the problems whose name contains one of the words; false when none is left
bool KeepOnly(const std::vector<std::string>& words, std::vector<Problem>* problems) {
  if (words.empty()) return true;
  std::vector<Problem> kept;
  for (Problem& pr : *problems)
    for (const std::string& w : words)
      if (pr.name.find(w) != std::string::npos) {
        kept.push_back(std::move(pr));
        break;
      }
  *problems = std::move(kept);
  return !problems->empty();
}

}  // namespace

int RunBenchSolver(const BenchOptions& opt) {
  const bool fail_missing = ReportMissingPeers();
  std::vector<Problem> problems;
  std::string error;
  if (!AddRealProblems(&problems, &error)) {
    std::fprintf(stderr, "graspsim bench solver: %s\n", error.c_str());
    return 3;
  }
  Problem grasp;
  if (!opt.quick && !PaperGraspProblem(&grasp, &error)) {
    std::fprintf(stderr, "graspsim bench solver: the paper grasp: %s\n", error.empty() ? "no contacts" : error.c_str());
    return 3;
  }
  if (!opt.quick) problems.push_back(std::move(grasp));
  AddFamilies(opt.quick, &problems);
  if (!KeepOnly(opt.only, &problems)) {
    std::fprintf(stderr, "graspsim bench solver: --only: no problem's name contains any of the words given\n");
    return 2;
  }

  if (!opt.json) {
    std::printf("graspsim bench solver: time to reach the Siconos error %.0e from zero forces (median of interleaved "
                "rounds, one core; x: not solved, final error)\n",
                kTarget);
    PrintHumanHeader();
  }
  std::vector<Row> rows;
  for (const Problem& pr : problems) {
    Row row = RunProblem(pr);
    if (StopRequested()) break;  // Ctrl-C also reached the solves' child processes: this row is not measured
    rows.push_back(std::move(row));
    if (opt.json) {
      PrintJsonRow(rows.back());
      PrintJsonFailures(rows.back());
    } else {
      PrintHumanRow(rows.back());
    }
    std::fflush(stdout);
  }
  const Summary summary = Summarise(rows);
  if (opt.json) {
    PrintJsonHeadline(summary, rows.size());
  } else {
    PrintHumanFailures(rows);
    PrintHumanHeadline(summary);
  }
  if (fail_missing) return 2;
  return summary.unsolved == 0 ? 0 : 1;
}

}  // namespace gs::app
