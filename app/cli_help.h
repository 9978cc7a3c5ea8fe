// Help that teaches: the help formatter of every graspsim command (usage lines
// with metavars, examples and exit codes in a footer), validators whose
// messages name the value, the accepted range and its unit, and the message for
// an unknown command or benchmark.
#pragma once

#include <initializer_list>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

namespace gs::app {

/// The formatter of `graspsim` and (inherited) of every subcommand: positionals
/// show their metavar (`graspsim run [SCENE.yaml] [OPTIONS]`), never `args(1x)`.
std::shared_ptr<CLI::Formatter> MakeHelpFormatter();

/// One command of a help footer's "Examples:": what to type from the checkout
/// root, and what it does.
struct HelpExample {
  std::string command;
  std::string what;
};

/// Sets cmd's footer: "Examples:" (each command, then what it does) and "Exit
/// codes:" (each code with what it means for this command).
void SetHelpFooter(CLI::App* cmd, std::initializer_list<HelpExample> examples,
                   std::initializer_list<std::pair<int, std::string>> exit_codes);

// Validators: each failure reads "--OPTION: VALUE is not ..." (CLI11 prefixes the
// option's name), with the range and the unit; none adds to the metavar.

/// A finite number > 0: "-1 is not a positive number of seconds" for what = "number of seconds".
CLI::Validator Positive(const std::string& what);
/// A whole number >= 1: "0 is not a positive whole number of steps" for what = "number of steps".
CLI::Validator PositiveInt(const std::string& what);
/// A whole number >= 0: "-1 is not a whole number of sweeps, 0 or more".
CLI::Validator NonNegativeInt(const std::string& what);
/// A finite number in [lo, hi]: "99999 is not a number of seconds from 0 to 60" for what = "a number of seconds".
CLI::Validator InRange(double lo, double hi, const std::string& what);
/// A whole number in [lo, hi]: "70000 is not a UDP port from 0 to 65535" for what = "a UDP port".
CLI::Validator IntInRange(long long lo, long long hi, const std::string& what);
/// `--threads N` on cmd: the threads a step's collision detection may use, the
/// stepping one's included (WorldParams::lanes_from_s says when they are used; the
/// results are the same bit for bit). *threads keeps 0 when not given
/// (WorkerPool::ThreadsFor gives the default).
void AddThreadsOption(CLI::App* cmd, int* threads);
/// One of the given words: "'fast' is not a sweep order: one of forward, alternating".
CLI::Validator OneOf(std::vector<std::string> names, const std::string& what);

/// After a parse error: when the deepest command on the line takes a command
/// of its own (graspsim, bench, scene) and got none or an unknown one, the
/// message naming it and the ones it takes ("graspsim bench: unknown benchmark
/// 'nosuch'; one of: collision, mls, ..."); empty otherwise.
std::string UnknownCommandMessage(const CLI::App& app);

}  // namespace gs::app
