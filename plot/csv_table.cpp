#include "plot/csv_table.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>

namespace gs::plot {
namespace {

std::vector<std::string> Split(const std::string& line) {
  std::vector<std::string> fields(1);
  for (char c : line) {
    if (c == ',')
      fields.emplace_back();
    else
      fields.back() += c;
  }
  return fields;
}

std::string At(const std::string& path, size_t line) { return path + ":" + std::to_string(line) + ": "; }

}  // namespace

bool CsvTable::Read(const std::string& path, const std::function<bool(const std::string&)>& keep,
                    std::string* error) {
  path_ = path;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = path + ": cannot open: " + std::strerror(errno);
    return false;
  }
  std::string line;
  if (!std::getline(in, line)) {
    *error = At(path, 1) + "empty file: no header line";
    return false;
  }
  if (!line.empty() && line.back() == '\r') line.pop_back();
  header_ = Split(line);
  for (size_t i = 0; i < header_.size(); ++i) {
    if (!keep(header_[i])) continue;
    kept_names_.push_back(header_[i]);
    kept_fields_.push_back(static_cast<int>(i));
  }
  cells_.assign(kept_fields_.size(), {});
  for (size_t n = 2; std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::vector<std::string> f = Split(line);
    if (f.size() != header_.size()) {
      *error = At(path, n) + std::to_string(f.size()) + " fields where the header (line 1) has " +
               std::to_string(header_.size()) + (in.eof() ? " (the file ends inside this line: truncated?)" : "");
      return false;
    }
    // run and replay end every line: a last line without its end was cut short, maybe inside a number
    if (in.eof()) {
      *error = At(path, n) + "the file ends inside this line (truncated?)";
      return false;
    }
    for (size_t k = 0; k < kept_fields_.size(); ++k) cells_[k].push_back(std::move(f[kept_fields_[k]]));
    line_.push_back(n);
    ++rows_;
  }
  if (in.bad()) {
    *error = path + ": read error";
    return false;
  }
  return true;
}

int CsvTable::Column(const std::string& name) const {
  for (size_t k = 0; k < kept_names_.size(); ++k)
    if (kept_names_[k] == name) return static_cast<int>(k);
  return -1;
}

int CsvTable::AnyColumn(const std::vector<std::string>& names) const {
  for (const std::string& n : names)
    if (Column(n) >= 0) return Column(n);
  return -1;
}

bool CsvTable::Number(size_t row, int column, double* v, std::string* error) const {
  const std::string& s = cells_[column][row];
  char* end = nullptr;
  *v = s.empty() ? NAN : std::strtod(s.c_str(), &end);
  // the whole cell, finite: "1.5x", "", "nan" and an overflow (inf) are refused alike
  if (!s.empty() && end == s.c_str() + s.size() && std::isfinite(*v)) return true;
  *error = At(path_, line_[row]) + "column " + kept_names_[column] + ": '" + s + "' is not a finite number";
  return false;
}

bool CsvTable::Numbers(int column, std::vector<double>* v, std::string* error) const {
  v->resize(rows_);
  for (size_t r = 0; r < rows_; ++r)
    if (!Number(r, column, &(*v)[r], error)) return false;
  return true;
}

std::string CsvTable::MissingColumn(const std::string& name) const {
  std::string h;
  for (const std::string& c : header_) h += (h.empty() ? "" : ",") + c;
  if (h.size() > 200) h = h.substr(0, 200) + "...";
  return At(path_, 1) + "no column '" + name + "' (header: " + h + ")";
}

}  // namespace gs::plot
