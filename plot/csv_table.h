// A comma-separated file with a header line, as run and replay write them
// (README "Output files"): columns found by their header name, every line
// checked against the header's field count, numbers read strictly. Errors name
// the file and line, so a truncated or edited file is refused, never half-read.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace gs::plot {

class CsvTable {
 public:
  /// Reads `path`, keeping the columns whose header name `keep` accepts (all
  /// lines are checked either way; keeping few columns keeps a long run small).
  /// False with "PATH:LINE: what is wrong" in *error.
  bool Read(const std::string& path, const std::function<bool(const std::string&)>& keep, std::string* error);

  const std::string& path() const { return path_; }
  const std::vector<std::string>& header() const { return header_; }
  size_t rows() const { return rows_; }
  /// The kept column of this header name; -1 when absent or not kept.
  int Column(const std::string& name) const;
  /// The first of `names` that is a kept column; -1 when none is.
  int AnyColumn(const std::vector<std::string>& names) const;
  const std::string& Text(size_t row, int column) const { return cells_[column][row]; }
  /// The cell as a finite number; false with "PATH:LINE: column NAME: 'x' is not a number".
  bool Number(size_t row, int column, double* v, std::string* error) const;
  /// A whole column as numbers (the first bad cell is the error).
  bool Numbers(int column, std::vector<double>* v, std::string* error) const;
  /// "PATH:1: no column 'NAME' (header: ...)", for a column the caller needs.
  std::string MissingColumn(const std::string& name) const;

 private:
  std::string path_;
  std::vector<std::string> header_;
  std::vector<std::string> kept_names_;
  std::vector<int> kept_fields_;                  ///< field index of each kept column
  std::vector<std::vector<std::string>> cells_;  ///< [kept column][row]
  std::vector<size_t> line_;                      ///< file line of each row
  size_t rows_ = 0;
};

}  // namespace gs::plot
