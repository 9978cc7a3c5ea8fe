#include "fclib/fclib_io.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

#ifdef GRASPSIM_HAVE_FCLIB
#include <hdf5.h>
extern "C" {
#include <fclib.h>
}
#endif

namespace gs::app {

#ifndef GRASPSIM_HAVE_FCLIB

bool FclibAvailable() { return false; }

bool ReadFclibLocal(const std::string& path, FcProblem*, std::string* error) {
  *error = path + ": graspsim was built without FCLIB (install libfclib-dev and rebuild)";
  return false;
}

bool WriteFclibLocal(const std::string& path, const FcProblem&, const std::string&, const std::string&,
                     const Eigen::VectorXd*, std::string* error) {
  *error = path + ": graspsim was built without FCLIB (install libfclib-dev and rebuild)";
  return false;
}

#else

namespace {

// HDF5 prints its error stack on stderr by default: we report our own messages
struct QuietHdf5 {
  H5E_auto2_t func = nullptr;
  void* data = nullptr;
  QuietHdf5() {
    H5Eget_auto2(H5E_DEFAULT, &func, &data);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietHdf5() { H5Eset_auto2(H5E_DEFAULT, func, data); }
};

bool Exists(hid_t file, const char* path) {
  // every prefix must exist before H5Lexists may be asked about the next level
  std::string prefix;
  const std::string p(path);
  size_t pos = 1;
  while (pos <= p.size()) {
    const size_t next = p.find('/', pos);
    prefix = p.substr(0, next == std::string::npos ? p.size() : next);
    if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (next == std::string::npos) break;
    pos = next + 1;
  }
  return true;
}

// number of elements of a dataset, -1 when it is not a readable dataset
long long DatasetSize(hid_t file, const char* path) {
  if (!Exists(file, path)) return -1;
  const hid_t d = H5Dopen2(file, path, H5P_DEFAULT);
  if (d < 0) return -1;
  const hid_t s = H5Dget_space(d);
  long long n = -1;
  if (s >= 0) {
    n = static_cast<long long>(H5Sget_simple_extent_npoints(s));
    H5Sclose(s);
  }
  H5Dclose(d);
  return n;
}

bool ReadInt(hid_t file, const char* path, int* v) {
  if (DatasetSize(file, path) != 1) return false;
  const hid_t d = H5Dopen2(file, path, H5P_DEFAULT);
  if (d < 0) return false;
  const herr_t e = H5Dread(d, H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, v);
  H5Dclose(d);
  return e >= 0;
}

// checks everything fclib_read_local will read; empty string when all is there
std::string CheckLayout(hid_t f) {
  if (!Exists(f, "/fclib_local")) {
    if (Exists(f, "/fclib_global")) return "holds an FCLIB global problem; only local problems are supported";
    return "is not an FCLIB local problem (no /fclib_local group)";
  }
  int spacedim = 0;
  if (!ReadInt(f, "/fclib_local/spacedim", &spacedim)) return "has no readable /fclib_local/spacedim";
  if (spacedim != 3) return "has spacedim " + std::to_string(spacedim) + "; only 3-D friction is supported";
  if (Exists(f, "/fclib_local/V") || Exists(f, "/fclib_local/R"))
    return "is a mixed problem (V, R); only pure local problems are supported";
  const char* members[] = {"nzmax", "m", "n", "nz"};
  int v[4];
  for (int k = 0; k < 4; ++k) {
    const std::string p = std::string("/fclib_local/W/") + members[k];
    if (!ReadInt(f, p.c_str(), &v[k])) return "has no readable " + p;
  }
  const int nzmax = v[0], m = v[1], n = v[2], nz = v[3];
  if (m <= 0 || m != n || m % 3 != 0)
    return "has W of size " + std::to_string(m) + " x " + std::to_string(n) + " (expected 3n x 3n)";
  if (nzmax < 0 || nz < -2) return "has a W with a negative nzmax or an unknown storage code nz";
  const long long np = DatasetSize(f, "/fclib_local/W/p"), ni = DatasetSize(f, "/fclib_local/W/i"),
                  nx = DatasetSize(f, "/fclib_local/W/x");
  long long want_p = nz == -1 ? n + 1 : nz == -2 ? m + 1 : nz;
  long long want_i = nz >= 0 ? nz : nzmax;
  if (np != want_p) return "has W/p of " + std::to_string(np) + " entries, expected " + std::to_string(want_p);
  if (ni != want_i) return "has W/i of " + std::to_string(ni) + " entries, expected " + std::to_string(want_i);
  if (nx != want_i) return "has W/x of " + std::to_string(nx) + " entries, expected " + std::to_string(want_i);
  if (nz >= 0 && nz > nzmax) return "has a triplet W with nz > nzmax";
  if (Exists(f, "/fclib_local/W/info")) {
    for (const char* s : {"comment", "conditioning", "determinant", "rank"}) {
      const std::string p = std::string("/fclib_local/W/info/") + s;
      if (!Exists(f, p.c_str())) return "has W/info without " + std::string(s);
    }
  }
  if (DatasetSize(f, "/fclib_local/vectors/q") != m) return "has no q of 3n entries in /fclib_local/vectors";
  if (DatasetSize(f, "/fclib_local/vectors/mu") != m / 3) return "has no mu of n entries in /fclib_local/vectors";
  if (Exists(f, "/fclib_local/vectors/s")) return "has an s vector (mixed problem); not supported";
  if (Exists(f, "/fclib_local/info")) {
    for (const char* s : {"title", "description", "math_info"}) {
      const std::string p = std::string("/fclib_local/info/") + s;
      if (!Exists(f, p.c_str())) return "has /fclib_local/info without " + std::string(s);
    }
  }
  return "";
}

}  // namespace

bool FclibAvailable() { return true; }

bool ReadFclibLocal(const std::string& path, FcProblem* out, std::string* error) {
  QuietHdf5 quiet;
  if (FILE* fp = std::fopen(path.c_str(), "rb")) {
    std::fclose(fp);
  } else {
    *error = path + ": cannot open (" + std::strerror(errno) + ")";
    return false;
  }
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    *error = path + ": not an HDF5 file";
    return false;
  }
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) {
    *error = path + ": HDF5 cannot open it";
    return false;
  }
  const std::string layout = CheckLayout(f);
  H5Fclose(f);
  if (!layout.empty()) {
    *error = path + ": " + layout;
    return false;
  }
  fclib_local* lp = fclib_read_local(path.c_str());
  if (!lp || !lp->W || !lp->q || !lp->mu) {
    if (lp) fclib_delete_local(lp);
    *error = path + ": FCLIB could not read the local problem";
    return false;
  }
  const fclib_matrix& M = *lp->W;
  const int m = M.m, n = m / 3;
  std::vector<Eigen::Triplet<double>> trip;
  std::string bad;
  auto add = [&](long long row, long long col, double x) {
    if (row < 0 || row >= m || col < 0 || col >= m) {
      bad = "W has an index out of range";
      return;
    }
    trip.emplace_back(static_cast<int>(row), static_cast<int>(col), x);
  };
  if (M.nz >= 0) {
    // triplets as in CSparse: row i[k], column p[k]
    for (int k = 0; k < M.nz && bad.empty(); ++k) add(M.i[k], M.p[k], M.x[k]);
  } else {
    const int outer = M.nz == -1 ? M.n : M.m;
    for (int o = 0; o < outer && bad.empty(); ++o) {
      if (M.p[o] < 0 || M.p[o + 1] < M.p[o] || M.p[o + 1] > M.nzmax) {
        bad = "W has inconsistent compressed pointers";
        break;
      }
      for (int k = M.p[o]; k < M.p[o + 1] && bad.empty(); ++k) {
        if (M.nz == -1) add(M.i[k], o, M.x[k]);
        else add(o, M.i[k], M.x[k]);
      }
    }
  }
  if (bad.empty()) {
    out->contacts = n;
    out->W.resize(m, m);
    out->W.setFromTriplets(trip.begin(), trip.end());
    out->W.makeCompressed();
    out->q = Eigen::Map<const Eigen::VectorXd>(lp->q, m);
    out->mu = Eigen::Map<const Eigen::VectorXd>(lp->mu, n);
    bad = CheckFcProblem(*out);
  }
  fclib_delete_local(lp);
  if (!bad.empty()) {
    *error = path + ": " + bad;
    return false;
  }
  return true;
}

bool WriteFclibLocal(const std::string& path, const FcProblem& p, const std::string& title,
                     const std::string& description, const Eigen::VectorXd* solution, std::string* error) {
  QuietHdf5 quiet;
  const int m = 3 * p.contacts;
  // compressed columns (W is symmetric: the row-major arrays are its transpose's columns; write true CSC)
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> csc = p.W;
  csc.makeCompressed();
  std::vector<int> colptr(csc.outerIndexPtr(), csc.outerIndexPtr() + m + 1);
  std::vector<int> rowidx(csc.innerIndexPtr(), csc.innerIndexPtr() + csc.nonZeros());
  std::vector<double> vals(csc.valuePtr(), csc.valuePtr() + csc.nonZeros());
  std::vector<double> q(p.q.data(), p.q.data() + m), mu(p.mu.data(), p.mu.data() + p.contacts);
  fclib_matrix W{};
  W.nzmax = static_cast<int>(vals.size());
  W.m = W.n = m;
  W.p = colptr.data();
  W.i = rowidx.data();
  W.x = vals.data();
  W.nz = -1;
  W.info = nullptr;
  std::string t = title, d = description, mi = "exported by graspsim";
  fclib_info info{&t[0], &d[0], &mi[0]};
  fclib_local lp{};
  lp.W = &W;
  lp.V = nullptr;
  lp.R = nullptr;
  lp.mu = mu.data();
  lp.q = q.data();
  lp.s = nullptr;
  lp.spacedim = 3;
  lp.info = &info;
  std::remove(path.c_str());  // fclib refuses a file that already holds a problem
  if (!fclib_write_local(&lp, path.c_str())) {
    *error = path + ": FCLIB could not write the problem";
    return false;
  }
  if (solution && solution->size() == m) {
    std::vector<double> r(solution->data(), solution->data() + m), u(m);
    Eigen::Map<Eigen::VectorXd>(u.data(), m) = p.W * *solution + p.q;
    fclib_solution sol{nullptr, u.data(), r.data(), nullptr};
    if (!fclib_write_solution(&sol, path.c_str())) {
      *error = path + ": FCLIB could not write the solution";
      return false;
    }
  }
  return true;
}

#endif

}  // namespace gs::app
