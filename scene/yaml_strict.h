// Strict reading of YAML scene files: every key must be known, every value of
// the right type and range, and every error names file, line and column.
// Errors are collected, so that a file reports all its problems at once.
#pragma once

#include <yaml-cpp/yaml.h>

#include <functional>
#include <string>
#include <vector>

#include "core/types.h"

namespace gs::app {

struct SceneError {
  std::string file;
  int line = 0, column = 0;  ///< 1-based; 0 when unknown
  std::string message;
  std::string Format() const;
};

/// A mapping being read: take keys with the typed getters, then Finish() reports
/// any key that was not taken.
class MapReader {
 public:
  MapReader(const YAML::Node& node, const std::string& file, const std::string& where, std::vector<SceneError>* errors);

  bool ok() const { return ok_; }
  bool Has(const std::string& key) const;
  YAML::Node Raw(const std::string& key);  ///< marks the key as taken

  /// Required (no default) or optional (with a documented default) values.
  bool Number(const std::string& key, double* out, double lo, double hi, bool required, bool lo_open = false,
              bool hi_open = false);
  bool Integer(const std::string& key, int64_t* out, int64_t lo, int64_t hi, bool required);
  bool Text(const std::string& key, std::string* out, bool required);
  bool Flag(const std::string& key, bool* out, bool required);
  bool Choice(const std::string& key, std::string* out, const std::vector<std::string>& allowed, bool required);
  bool Vector3(const std::string& key, Vec3* out, double lo, double hi, bool required);

  /// Reports unknown keys (and duplicates); call once all keys were read.
  void Finish();
  void Error(const YAML::Node& at, const std::string& message);
  void Error(const std::string& message);  ///< at the mapping itself
  const std::string& file() const { return file_; }
  std::vector<SceneError>* errors() { return errors_; }

 private:
  bool Scalar(const std::string& key, bool required, YAML::Node* out);
  YAML::Node node_;
  std::string file_, where_;
  std::vector<SceneError>* errors_;
  std::vector<std::string> taken_;
  bool ok_ = true;
};

/// Parses a number the strict way: C locale, finite, the whole text consumed.
bool ParseNumber(const std::string& text, double* out);

/// Location of a node as an error.
SceneError ErrorAt(const std::string& file, const YAML::Node& at, const std::string& message);

}  // namespace gs::app
