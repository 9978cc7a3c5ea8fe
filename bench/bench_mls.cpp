// `graspsim bench mls`: accuracy and cost of the MLS projection (paper 3.2) on
// a sphere and an ellipsoid sampled at the paper's density, plane-only MLS (the
// paper's f) against the quadric projection of its reference [7], for several
// bandwidths. Errors are against the analytic surface, in % of the spacing.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "bench/bench.h"
#include "core/mls.h"
#include "core/point_grid.h"
#include "core/sampling.h"

namespace gs::app {

MlsAccuracy MeasureMlsAccuracy(const ShapeDesc& shape, int points, double bandwidth_factor, bool quadric, int queries,
                               uint64_t seed) {
  MlsAccuracy a;
  PointCloud cloud;
  if (!SampleShape(shape, points, seed, &cloud)) return a;
  a.spacing = MeanSpacing(cloud);
  MlsParams p = RecommendedMlsParams(a.spacing);
  p.bandwidth = bandwidth_factor * a.spacing;
  p.quadric = quadric;
  PointGrid grid;
  grid.Build(cloud.positions, p.support * p.bandwidth);
  std::mt19937_64 rng(seed + 17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> err, ang;
  std::vector<int> nbrs;
  double seconds = 0.0;
  for (int k = 0; k < queries; ++k) {
    // a sample point pushed off the surface by up to one spacing, in a random direction
    const Vec3& s = cloud.positions[static_cast<size_t>(k * 7919) % cloud.size()];
    const Vec3 x = s + a.spacing * Vec3(u(rng), u(rng), u(rng));
    nbrs.clear();
    grid.Query(x, p.support * p.bandwidth + 2.0 * a.spacing, &nbrs);
    MlsProjection proj;
    const auto t0 = std::chrono::steady_clock::now();
    const bool ok = MlsProject(cloud.positions.data(), cloud.normals.data(), nbrs.data(),
                               static_cast<int>(nbrs.size()), x, p, &proj);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!ok) {
      ++a.failed;
      continue;
    }
    Vec3 n;
    err.push_back(std::abs(AnalyticDistance(shape, proj.point, &n)) / a.spacing);
    ang.push_back(std::acos(std::clamp(n.dot(proj.normal), -1.0, 1.0)) * 180.0 / M_PI);
  }
  if (err.empty()) return a;
  std::sort(err.begin(), err.end());
  std::sort(ang.begin(), ang.end());
  a.max_err = err.back();
  a.median_err = err[err.size() / 2];
  a.max_deg = ang.back();
  a.median_deg = ang[ang.size() / 2];
  a.ns_per_projection = 1e9 * seconds / static_cast<double>(err.size() + a.failed);
  return a;
}

int RunBenchMls(const BenchOptions& opt) {
  ShapeDesc sphere;
  sphere.type = EShape::Sphere;
  sphere.radius = 0.008;
  ShapeDesc ellipsoid;
  ellipsoid.type = EShape::Ellipsoid;
  ellipsoid.semi_axes = Vec3(0.008, 0.008, 0.011);
  const int queries = opt.quick ? 2000 : 20000;
  struct Shape {
    const char* name;
    ShapeDesc desc;
  } shapes[2] = {{"sphere", sphere}, {"ellipsoid", ellipsoid}};
  if (!opt.json) {
    std::printf("MLS projection of points up to one spacing off the surface, 2,400 points (the paper's fingertip),\n");
    std::printf("%d queries each; errors against the analytic surface.\n\n", queries);
    std::printf("%-10s %-8s %6s %14s %14s %12s %12s %10s\n", "shape", "method", "h/s", "max err %s", "median %s",
                "max deg", "median deg", "ns/proj");
  }
  MlsAccuracy headline[2];
  for (int si = 0; si < 2; ++si) {
    for (int quadric = 0; quadric < 2; ++quadric) {
      for (double f : {1.0, 1.25, 1.5, 2.0, 3.0}) {
        const MlsAccuracy a = MeasureMlsAccuracy(shapes[si].desc, 2400, f, quadric != 0, queries, 5);
        if (quadric && f == 1.5) headline[si] = a;
        if (opt.json) {
          std::printf("{\"bench\":\"mls\",\"shape\":\"%s\",\"method\":\"%s\",\"bandwidth_spacings\":%.1f,"
                      "\"max_err_pct_spacing\":%.4f,\"median_err_pct_spacing\":%.4f,\"max_normal_err_deg\":%.4f,"
                      "\"median_normal_err_deg\":%.4f,\"ns_per_projection\":%.0f,\"failed\":%d}\n",
                      shapes[si].name, quadric ? "quadric" : "plane", f, 100 * a.max_err, 100 * a.median_err,
                      a.max_deg, a.median_deg, a.ns_per_projection, a.failed);
        } else {
          std::printf("%-10s %-8s %6.1f %14.3f %14.3f %12.3f %12.3f %10.0f\n", shapes[si].name,
                      quadric ? "quadric" : "plane", f, 100 * a.max_err, 100 * a.median_err, a.max_deg, a.median_deg,
                      a.ns_per_projection);
        }
      }
    }
  }
  if (opt.json) {
    std::printf("{\"bench\":\"mls\",\"sphere_max_err_pct_spacing\":%.4f,\"ellipsoid_max_err_pct_spacing\":%.4f,"
                "\"max_normal_err_deg\":%.4f,\"ns_per_projection\":%.0f}\n",
                100 * headline[0].max_err, 100 * headline[1].max_err, std::max(headline[0].max_deg, headline[1].max_deg),
                0.5 * (headline[0].ns_per_projection + headline[1].ns_per_projection));
  } else {
    std::printf("\nDefaults (quadric, h = 1.5 spacings): sphere max %.3f%%, ellipsoid max %.3f%% of the spacing; "
                "normals within %.3f degrees (targets: 1%%, 1 degree)\n",
                100 * headline[0].max_err, 100 * headline[1].max_err,
                std::max(headline[0].max_deg, headline[1].max_deg));
  }
  return 0;
}

}  // namespace gs::app
