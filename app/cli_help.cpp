// Help formatting, validators with units and the unknown-command message (see cli_help.h).
#include "app/cli_help.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace gs::app {
namespace {

class HelpFormatter : public CLI::Formatter {
 public:
  HelpFormatter() { column_width(32); }

  // "Usage: graspsim run [SCENE.yaml] [OPTIONS]": the positionals by their metavars,
  // then the command a command takes, then the options
  std::string make_usage(const CLI::App* app, std::string name) const override {
    std::ostringstream out;
    out << "Usage: " << name;
    for (const CLI::Option* opt : app->get_options([](const CLI::Option* o) { return o->get_positional(); }))
      out << " " << make_option_usage(opt);
    const auto subs = app->get_subcommands([](const CLI::App* s) { return !s->get_disabled() && !s->get_name().empty(); });
    if (!subs.empty()) {
      const std::string what = app->get_parent() != nullptr && app->get_name() == "bench" ? "BENCHMARK" : "COMMAND";
      out << " " << (app->get_require_subcommand_min() == 0 ? "[" + what + "]" : what);
    }
    if (!app->get_options([](const CLI::Option* o) { return o->nonpositional(); }).empty()) out << " [OPTIONS]";
    out << "\n";
    return out.str();
  }

  std::string make_option_name(const CLI::Option* opt, bool is_positional) const override {
    if (!is_positional) return CLI::Formatter::make_option_name(opt, false);
    return Metavar(opt) + (opt->get_expected_max() >= CLI::detail::expected_max_vector_size ? "..." : "");
  }

  // a positional's metavar is its name in the list; its default goes to the description
  std::string make_option_opts(const CLI::Option* opt) const override {
    return opt->get_positional() ? std::string() : CLI::Formatter::make_option_opts(opt);
  }

  std::string make_option_desc(const CLI::Option* opt) const override {
    std::string d = opt->get_description();
    if (opt->get_positional() && !opt->get_default_str().empty()) d += " (default " + opt->get_default_str() + ")";
    return d;
  }

  std::string make_option_usage(const CLI::Option* opt) const override {
    std::string s = Metavar(opt);
    if (opt->get_expected_max() >= CLI::detail::expected_max_vector_size) s += "...";
    return opt->get_required() ? s : "[" + s + "]";
  }

 private:
  static std::string Metavar(const CLI::Option* opt) {
    std::string m = opt->get_type_name();
    if (m.empty()) {
      m = opt->get_name(true, false);
      std::transform(m.begin(), m.end(), m.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
    }
    return m;
  }
};

std::string Num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.15g", v);
  return buf;
}

// a number as CLI11 reads it (the option's own conversion), else an error message
bool ReadNumber(const std::string& s, double* v, std::string* error) {
  if (!CLI::detail::lexical_cast(s, *v)) {
    *error = "'" + s + "' is not a number";
    return false;
  }
  if (!std::isfinite(*v)) {
    *error = s + " is not a finite number";
    return false;
  }
  return true;
}

bool ReadWhole(const std::string& s, long long* v, std::string* error) {
  if (!CLI::detail::lexical_cast(s, *v)) {
    *error = "'" + s + "' is not a whole number";
    return false;
  }
  return true;
}

// text wrapped at 100 columns, every line indented by `indent` spaces
std::string Wrap(const std::string& text, size_t indent) {
  std::string out, line;
  std::istringstream words(text);
  for (std::string w; words >> w;) {
    if (!line.empty() && indent + line.size() + 1 + w.size() > 100) {
      out += std::string(indent, ' ') + line + "\n";
      line.clear();
    }
    line += (line.empty() ? "" : " ") + w;
  }
  return out + std::string(indent, ' ') + line + "\n";
}

CLI::Validator Make(std::function<std::string(std::string&)> check, const std::string& name) {
  CLI::Validator v(std::move(check), std::string(), name);
  return v;
}

}  // namespace

std::shared_ptr<CLI::Formatter> MakeHelpFormatter() { return std::make_shared<HelpFormatter>(); }

void SetHelpFooter(CLI::App* cmd, std::initializer_list<HelpExample> examples,
                   std::initializer_list<std::pair<int, std::string>> exit_codes) {
  std::ostringstream out;
  out << "Examples (from the checkout root):\n";
  for (const HelpExample& e : examples) out << "  " << e.command << "\n" << Wrap(e.what, 6);
  out << "\nExit codes:\n";
  for (const auto& [code, what] : exit_codes) {
    char num[8];
    std::snprintf(num, sizeof num, "%-5d", code);
    out << "  " << num << Wrap(what, 7).substr(7);
  }
  std::string s = out.str();
  s.pop_back();  // the formatter ends the footer with its own newline
  cmd->footer(s);
}

CLI::Validator Positive(const std::string& what) {
  return Make(
      [what](std::string& s) {
        double v = 0.0;
        std::string error;
        if (!ReadNumber(s, &v, &error)) return error + " (a positive " + what + ")";
        return v > 0.0 ? std::string() : s + " is not a positive " + what;
      },
      "POSITIVE");
}

CLI::Validator PositiveInt(const std::string& what) {
  return Make(
      [what](std::string& s) {
        long long v = 0;
        std::string error;
        if (!ReadWhole(s, &v, &error)) return error + " (a positive whole " + what + ")";
        return v >= 1 ? std::string() : s + " is not a positive whole " + what;
      },
      "POSITIVE_INT");
}

CLI::Validator NonNegativeInt(const std::string& what) {
  return Make(
      [what](std::string& s) {
        long long v = 0;
        std::string error;
        if (!ReadWhole(s, &v, &error)) return error + " (a whole " + what + ", 0 or more)";
        return v >= 0 ? std::string() : s + " is not a whole " + what + ", 0 or more";
      },
      "NON_NEGATIVE_INT");
}

CLI::Validator InRange(double lo, double hi, const std::string& what) {
  return Make(
      [lo, hi, what](std::string& s) {
        double v = 0.0;
        std::string error;
        const std::string range = what + " from " + Num(lo) + " to " + Num(hi);
        if (!ReadNumber(s, &v, &error)) return error + " (" + range + ")";
        return v >= lo && v <= hi ? std::string() : s + " is not " + range;
      },
      "RANGE");
}

void AddThreadsOption(CLI::App* cmd, int* threads) {
  cmd->add_option("--threads", *threads,
                  "threads for the step's collision detection, this one's included (default: 2 where the machine has "
                  "2 cores or more; 1: one thread); the results are the same")
      ->check(IntInRange(1, 64, "a thread count"));
}

CLI::Validator IntInRange(long long lo, long long hi, const std::string& what) {
  return Make(
      [lo, hi, what](std::string& s) {
        long long v = 0;
        std::string error;
        const std::string range = what + " from " + std::to_string(lo) + " to " + std::to_string(hi);
        if (!ReadWhole(s, &v, &error)) return error + " (" + range + ")";
        return v >= lo && v <= hi ? std::string() : s + " is not " + range;
      },
      "INT_RANGE");
}

CLI::Validator OneOf(std::vector<std::string> names, const std::string& what) {
  return Make(
      [names, what](std::string& s) {
        if (std::find(names.begin(), names.end(), s) != names.end()) return std::string();
        std::string list;
        for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
        return "'" + s + "' is not " + what + ": one of " + list;
      },
      "ONE_OF");
}

std::string UnknownCommandMessage(const CLI::App& app) {
  const CLI::App* cur = &app;
  std::string path = app.get_name();
  for (std::vector<CLI::App*> subs = cur->get_subcommands(); !subs.empty(); subs = cur->get_subcommands()) {
    cur = subs.front();
    path += " " + cur->get_name();
  }
  if (cur->get_require_subcommand_min() == 0) return std::string();
  std::vector<std::string> names;
  for (const CLI::App* s : cur->get_subcommands([](const CLI::App* s) { return !s->get_name().empty(); }))
    names.push_back(s->get_name());
  std::sort(names.begin(), names.end());
  std::string list;
  for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
  const std::string noun = cur != &app && cur->get_name() == "bench" ? "benchmark" : "command";
  std::string unknown;
  for (const std::string& a : app.remaining(true))
    if (!a.empty() && a[0] != '-') {
      unknown = a;
      break;
    }
  std::string msg = unknown.empty() ? path + ": name a " + noun + "; one of: " + list
                                    : path + ": unknown " + noun + " '" + unknown + "'; one of: " + list;
  return msg + "\nRun '" + path + " --help' for what each one does.";
}

}  // namespace gs::app
