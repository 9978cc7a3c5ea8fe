#include "scene/yaml_strict.h"

#include <algorithm>
#include <cerrno>
#include <clocale>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace gs::app {

std::string SceneError::Format() const {
  std::ostringstream s;
  s << file;
  if (line > 0) s << ":" << line << ":" << column;
  s << ": " << message;
  return s.str();
}

SceneError ErrorAt(const std::string& file, const YAML::Node& at, const std::string& message) {
  SceneError e;
  e.file = file;
  const YAML::Mark m = at.Mark();
  if (m.line >= 0) {
    e.line = m.line + 1;
    e.column = m.column + 1;
  }
  e.message = message;
  return e;
}

bool ParseNumber(const std::string& text, double* out) {
  if (text.empty()) return false;
  // strtod_l with the C locale would be ideal; the process never changes LC_NUMERIC
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (end == begin || *end != '\0' || errno == ERANGE || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

MapReader::MapReader(const YAML::Node& node, const std::string& file, const std::string& where,
                     std::vector<SceneError>* errors)
    : node_(node), file_(file), where_(where), errors_(errors) {
  if (!node_.IsMap()) {
    Error(node_, where_ + " must be a mapping of keys to values");
    ok_ = false;
  }
}

bool MapReader::Has(const std::string& key) const { return ok_ && node_[key]; }

YAML::Node MapReader::Raw(const std::string& key) {
  taken_.push_back(key);
  if (!ok_) return YAML::Node();
  return node_[key];
}

void MapReader::Error(const YAML::Node& at, const std::string& message) {
  errors_->push_back(ErrorAt(file_, at, message));
}

void MapReader::Error(const std::string& message) { Error(node_, message); }

bool MapReader::Scalar(const std::string& key, bool required, YAML::Node* out) {
  *out = Raw(key);
  if (!ok_) return false;
  if (!*out) {
    if (required) Error(node_, "missing required key '" + key + "' in " + where_);
    return false;
  }
  if (!out->IsScalar()) {
    Error(*out, "'" + key + "' must be a single value");
    return false;
  }
  return true;
}

bool MapReader::Number(const std::string& key, double* out, double lo, double hi, bool required, bool lo_open,
                       bool hi_open) {
  YAML::Node n;
  if (!Scalar(key, required, &n)) return false;
  double v;
  if (!ParseNumber(n.Scalar(), &v)) {
    Error(n, "'" + key + "' must be a finite number, got '" + n.Scalar() + "'");
    return false;
  }
  const bool below = lo_open ? v <= lo : v < lo;
  const bool above = hi_open ? v >= hi : v > hi;
  if (below || above) {
    std::ostringstream s;
    s << "'" << key << "' = " << n.Scalar() << " is out of range: expected a number in " << (lo_open ? "(" : "[")
      << lo << ", ";
    if (hi >= 1e299) {
      s << "infinity)";
    } else {
      s << hi << (hi_open ? ")" : "]");
    }
    Error(n, s.str());
    return false;
  }
  *out = v;
  return true;
}

bool MapReader::Integer(const std::string& key, int64_t* out, int64_t lo, int64_t hi, bool required) {
  YAML::Node n;
  if (!Scalar(key, required, &n)) return false;
  const std::string& t = n.Scalar();
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(t.c_str(), &end, 10);
  if (t.empty() || *end != '\0' || errno == ERANGE) {
    Error(n, "'" + key + "' must be a whole number, got '" + t + "'");
    return false;
  }
  if (v < lo || v > hi) {
    std::ostringstream s;
    s << "'" << key << "' = " << v << " is out of range: expected a whole number in [" << lo << ", " << hi << "]";
    Error(n, s.str());
    return false;
  }
  *out = v;
  return true;
}

bool MapReader::Text(const std::string& key, std::string* out, bool required) {
  YAML::Node n;
  if (!Scalar(key, required, &n)) return false;
  *out = n.Scalar();
  return true;
}

bool MapReader::Flag(const std::string& key, bool* out, bool required) {
  YAML::Node n;
  if (!Scalar(key, required, &n)) return false;
  const std::string& t = n.Scalar();
  if (t == "true") {
    *out = true;
  } else if (t == "false") {
    *out = false;
  } else {
    Error(n, "'" + key + "' must be true or false, got '" + t + "'");
    return false;
  }
  return true;
}

bool MapReader::Choice(const std::string& key, std::string* out, const std::vector<std::string>& allowed,
                       bool required) {
  YAML::Node n;
  if (!Scalar(key, required, &n)) return false;
  if (std::find(allowed.begin(), allowed.end(), n.Scalar()) == allowed.end()) {
    std::string list;
    for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
    Error(n, "'" + key + "' = '" + n.Scalar() + "' is not one of: " + list);
    return false;
  }
  *out = n.Scalar();
  return true;
}

bool MapReader::Vector3(const std::string& key, Vec3* out, double lo, double hi, bool required) {
  YAML::Node n = Raw(key);
  if (!ok_) return false;
  if (!n) {
    if (required) Error(node_, "missing required key '" + key + "' in " + where_);
    return false;
  }
  if (!n.IsSequence() || n.size() != 3) {
    Error(n, "'" + key + "' must be a list of 3 numbers" +
                 (n.IsSequence() ? ", got " + std::to_string(n.size()) : std::string()));
    return false;
  }
  Vec3 v;
  for (int i = 0; i < 3; ++i) {
    double x;
    if (!n[i].IsScalar() || !ParseNumber(n[i].Scalar(), &x)) {
      Error(n[i], "'" + key + "' must hold finite numbers");
      return false;
    }
    if (x < lo || x > hi) {
      std::ostringstream s;
      s << "'" << key << "' component " << x << " is out of range [" << lo << ", " << hi << "]";
      Error(n[i], s.str());
      return false;
    }
    v[i] = x;
  }
  *out = v;
  return true;
}

void MapReader::Finish() {
  if (!ok_) return;
  std::vector<std::string> seen;
  std::string known;
  for (const std::string& k : taken_) known += (known.empty() ? "" : ", ") + k;
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    const std::string key = it->first.IsScalar() ? it->first.Scalar() : std::string("?");
    if (std::find(seen.begin(), seen.end(), key) != seen.end()) {
      Error(it->first, "duplicate key '" + key + "' in " + where_);
      continue;
    }
    seen.push_back(key);
    if (std::find(taken_.begin(), taken_.end(), key) == taken_.end())
      Error(it->first, "unknown key '" + key + "' in " + where_ + " (expected one of: " + known + ")");
  }
}

}  // namespace gs::app
