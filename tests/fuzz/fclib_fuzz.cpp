// libFuzzer target for FCLIB local problems. HDF5's own file parser is upstream's
// to fuzz; what graspsim adds is the layout and consistency checks before and
// after libfclib reads (libfclib exits the process on a missing dataset and
// trusts every size). So the input describes an HDF5 file: which of FCLIB's
// groups and datasets exist, their sizes and their values, consistent or not;
// the file is written with HDF5 and read back with ReadFclibLocal, which must
// accept a well-formed problem or refuse with a message naming the file.
#include <hdf5.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "fclib/fclib_io.h"

namespace {

struct Bytes {
  const uint8_t* p;
  size_t n;
  uint8_t Next() {
    if (!n) return 0;
    --n;
    return *p++;
  }
  int SmallInt() { return static_cast<int8_t>(Next()); }
  double Value() {
    const uint8_t b = Next();
    switch (b) {
      case 255: return std::numeric_limits<double>::quiet_NaN();
      case 254: return std::numeric_limits<double>::infinity();
      case 253: return -1e308;
      default: return (static_cast<int>(b) - 100) / 16.0;
    }
  }
};

void Ints(hid_t f, const char* path, const std::vector<int>& v) {
  const hsize_t dim = v.size();
  const hid_t s = H5Screate_simple(1, &dim, nullptr);
  const hid_t d = H5Dcreate2(f, path, H5T_NATIVE_INT, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (d >= 0 && !v.empty()) H5Dwrite(d, H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
  if (d >= 0) H5Dclose(d);
  H5Sclose(s);
}

void Doubles(hid_t f, const char* path, const std::vector<double>& v) {
  const hsize_t dim = v.size();
  const hid_t s = H5Screate_simple(1, &dim, nullptr);
  const hid_t d = H5Dcreate2(f, path, H5T_NATIVE_DOUBLE, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (d >= 0 && !v.empty()) H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
  if (d >= 0) H5Dclose(d);
  H5Sclose(s);
}

void Group(hid_t f, const char* path) {
  const hid_t g = H5Gcreate2(f, path, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (g >= 0) H5Gclose(g);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static bool quiet = (H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr), true);
  (void)quiet;
  Bytes in{data, size};
  const uint16_t flags = static_cast<uint16_t>(in.Next() | (in.Next() << 8));
  const std::string path = "/tmp/graspsim_fclib_fuzz_" + std::to_string(getpid()) + ".hdf5";
  const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (f < 0) std::abort();
  auto ints = [&](int count) {
    std::vector<int> v(static_cast<size_t>(std::max(0, count)));
    for (int& x : v) x = in.SmallInt();
    return v;
  };
  auto doubles = [&](int count) {
    std::vector<double> v(static_cast<size_t>(std::max(0, count)));
    for (double& x : v) x = in.Value();
    return v;
  };
  if (flags & 1) {
    Group(f, "/fclib_local");
    if (flags & 2) Ints(f, "/fclib_local/spacedim", {flags & 4 ? in.SmallInt() : 3});
    if (flags & 8) Group(f, "/fclib_local/V");
    if (flags & 16) {
      Group(f, "/fclib_local/W");
      // sizes near a consistent compressed-column 3n x 3n matrix, or anything
      const int n3 = 3 * (1 + in.Next() % 4);
      const int nzmax = in.Next() % 40;
      const int m = flags & 32 ? in.SmallInt() : n3, n = flags & 64 ? in.SmallInt() : n3;
      const int nz = flags & 128 ? in.SmallInt() : -1;
      for (auto [name, v] : {std::pair<const char*, int>{"nzmax", nzmax}, {"m", m}, {"n", n}, {"nz", nz}})
        if (!(flags & 256) || in.Next() % 8) Ints(f, (std::string("/fclib_local/W/") + name).c_str(), {v});
      const int np = flags & 512 ? in.Next() % 16 : (nz >= 0 ? nz : n + 1);
      const int ni = flags & 1024 ? in.Next() % 48 : (nz >= 0 ? nz : nzmax);
      Ints(f, "/fclib_local/W/p", ints(np));
      Ints(f, "/fclib_local/W/i", ints(ni));
      Doubles(f, "/fclib_local/W/x", doubles(ni));
      Group(f, "/fclib_local/vectors");
      const int nq = flags & 2048 ? in.Next() % 16 : m;
      Doubles(f, "/fclib_local/vectors/q", doubles(nq));
      Doubles(f, "/fclib_local/vectors/mu", doubles(flags & 4096 ? in.Next() % 8 : nq / 3));
      if (flags & 8192) Doubles(f, "/fclib_local/vectors/s", doubles(nq));
    }
  } else if (flags & 2) {
    Group(f, "/fclib_global");
  }
  H5Fclose(f);
  gs::FcProblem p;
  std::string error;
  const bool ok = gs::app::ReadFclibLocal(path, &p, &error);
  std::remove(path.c_str());
  if (!ok && error.find(path) != 0) {
    std::fprintf(stderr, "fclib_fuzz: refused without naming the file: %s\n", error.c_str());
    std::abort();
  }
  if (ok && (p.contacts <= 0 || p.W.rows() != 3 * p.contacts || p.q.size() != 3 * p.contacts ||
             p.mu.size() != p.contacts || !p.q.allFinite() || !p.mu.allFinite() || (p.mu.array() < 0).any())) {
    std::fprintf(stderr, "fclib_fuzz: accepted an inconsistent problem\n");
    std::abort();
  }
  return 0;
}
