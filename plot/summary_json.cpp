#include "plot/summary_json.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

namespace gs::plot {
namespace {

// A strict recursive-descent JSON reader that keeps the top level's scalars.
class Parser {
 public:
  Parser(const std::string& text, const std::string& path) : s_(text), path_(path) {}

  bool Document(Summary* out, std::string* error) {
    if (!Object(out, 0)) return Fail(error);
    Space();
    if (i_ != s_.size()) {
      why_ = "text after the closing '}'";
      return Fail(error);
    }
    return true;
  }

 private:
  static constexpr int kMaxDepth = 64;  // a deeper file is refused rather than recursed into

  bool Fail(std::string* error) const {
    size_t line = 1;
    for (size_t k = 0; k < i_ && k < s_.size(); ++k) line += s_[k] == '\n' ? 1 : 0;
    *error = path_ + ":" + std::to_string(line) + ": not valid JSON: " + why_;
    return false;
  }
  bool Expect(const char* what) {
    why_ = std::string("expected ") + what + (i_ < s_.size() ? "" : " but the file ends (truncated?)");
    return false;
  }
  void Space() {
    while (i_ < s_.size() && std::strchr(" \t\r\n", s_[i_])) ++i_;
  }
  bool Eat(char c) {
    Space();
    if (i_ < s_.size() && s_[i_] == c) {
      ++i_;
      return true;
    }
    return false;
  }

  // top level (out != nullptr) keeps its string and number members
  bool Object(Summary* out, int depth) {
    if (!Eat('{')) return Expect("'{'");
    if (Eat('}')) return true;
    do {
      std::string key, text;
      double number = NAN;
      Space();
      if (!String(&key)) return false;
      if (!Eat(':')) return Expect("':' after a member name");
      if (!Value(depth + 1, &text, &number)) return false;
      if (out && kind_ == 'n') out->numbers[key] = number;
      if (out && kind_ == 's') out->strings[key] = text;
    } while (Eat(','));
    return Eat('}') ? true : Expect("',' or '}'");
  }
  bool Array(int depth) {
    if (!Eat('[')) return Expect("'['");
    if (Eat(']')) return true;
    do {
      std::string text;
      double number;
      if (!Value(depth + 1, &text, &number)) return false;
    } while (Eat(','));
    return Eat(']') ? true : Expect("',' or ']'");
  }
  bool Value(int depth, std::string* text, double* number) {
    if (depth > kMaxDepth) {
      why_ = "nested more than " + std::to_string(kMaxDepth) + " deep";
      return false;
    }
    Space();
    if (i_ >= s_.size()) return Expect("a value");
    const char c = s_[i_];
    // set after the value: a nested value read on the way sets kind_ too
    const char kind = c == '"' ? 's' : c == '-' || (c >= '0' && c <= '9') ? 'n' : 'o';
    const bool ok = c == '{'   ? Object(nullptr, depth)
                    : c == '[' ? Array(depth)
                    : c == '"' ? String(text)
                               : Word() || Number(number);
    kind_ = kind;
    return ok;
  }
  bool Word() {
    for (const char* word : {"true", "false", "null"})
      if (s_.compare(i_, std::strlen(word), word) == 0) {
        i_ += std::strlen(word);
        return true;
      }
    return false;
  }
  bool String(std::string* out) {
    if (i_ >= s_.size() || s_[i_] != '"') return Expect("a string");
    for (++i_; i_ < s_.size(); ++i_) {
      const char c = s_[i_];
      if (c == '"') {
        ++i_;
        return true;
      }
      if (static_cast<unsigned char>(c) < 0x20) {
        why_ = "a control character inside a string";
        return false;
      }
      if (c == '\\') {
        if (++i_ >= s_.size()) break;
        const char e = s_[i_];
        const char* from = "\"\\/bfnrt";
        const char* to = "\"\\/\b\f\n\r\t";
        if (const char* p = std::strchr(from, e); p && e) {
          *out += to[p - from];
        } else if (e == 'u' && i_ + 4 < s_.size()) {
          *out += '?';  // plot never shows non-ASCII escapes: a placeholder is enough
          i_ += 4;
        } else {
          why_ = "a bad escape in a string";
          return false;
        }
        continue;
      }
      *out += c;
    }
    return Expect("the closing '\"' of a string");
  }
  bool Number(double* out) {
    const char* begin = s_.c_str() + i_;
    char* end = nullptr;
    const bool json_start = *begin == '-' || (*begin >= '0' && *begin <= '9');
    const double v = json_start ? std::strtod(begin, &end) : NAN;
    if (!json_start || end == begin || !std::isfinite(v)) return Expect("a value (object, array, string, number, "
                                                                        "true, false or null)");
    *out = v;
    i_ += static_cast<size_t>(end - begin);
    return true;
  }

  const std::string& s_;
  const std::string& path_;
  size_t i_ = 0;
  char kind_ = 'o';  ///< the last value read: 's' string, 'n' number, 'o' other
  std::string why_;
};

}  // namespace

bool ParseSummary(const std::string& text, const std::string& path, Summary* summary, std::string* error) {
  *summary = Summary();
  return Parser(text, path).Document(summary, error);
}

bool ReadSummary(const std::string& path, Summary* summary, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = path + ": cannot open: " + std::strerror(errno);
    return false;
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) {
    *error = path + ": read error";
    return false;
  }
  return ParseSummary(text.str(), path, summary, error);
}

}  // namespace gs::plot
