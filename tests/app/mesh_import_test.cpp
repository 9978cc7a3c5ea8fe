#include "scene/mesh_import.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <algorithm>
#include <set>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <ostream>
#include <string>

namespace gs::app {
namespace {

std::string MeshPath(const std::string& name) { return std::string(GRASPSIM_TEST_DATA) + "/meshes/" + name; }

// signed volume and area computed here, independently of the library
double Volume(const TriangleMesh& m) {
  double six_v = 0;
  for (const auto& t : m.triangles) six_v += m.vertices[t[0]].dot(m.vertices[t[1]].cross(m.vertices[t[2]]));
  return six_v / 6;
}

bool Contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

struct Expected {
  const char* file;
  double scale;
  double volume;  // m^3
  size_t vertices, triangles;
  Vec3 centre;
};

void PrintTo(const Expected& e, std::ostream* os) { *os << e.file; }

class GoodMeshes : public ::testing::TestWithParam<Expected> {};

TEST_P(GoodMeshes, LoadClosedWithTheRightVolumeAndSample) {
  const Expected& want = GetParam();
  TriangleMesh m;
  std::string error = "unchanged";
  ASSERT_TRUE(ImportMesh(MeshPath(want.file), want.scale, &m, &error)) << error;
  EXPECT_EQ(error, "");
  // welded: shared corners are single vertices
  EXPECT_EQ(m.vertices.size(), want.vertices);
  EXPECT_EQ(m.triangles.size(), want.triangles);
  // outward and the right size
  EXPECT_NEAR(Volume(m), want.volume, 1e-6 * want.volume);
  Vec3 centre = Vec3::Zero();
  for (const Vec3& v : m.vertices) centre += v;
  centre /= static_cast<double>(m.vertices.size());
  EXPECT_LT((centre - want.centre).norm(), 1e-6 * std::cbrt(want.volume)) << centre.transpose();
  // already valid: a second check changes nothing
  TriangleMesh copy = m;
  MeshCheckReport report;
  EXPECT_EQ(ValidateAndOrientMesh(&copy, &report), EMeshError::None);
  EXPECT_FALSE(report.flipped);
  // samples fine, with normals pointing away from the (convex) shape's centre
  PointCloud cloud;
  ASSERT_TRUE(SampleMesh(m, 1000, 1, &cloud));
  ASSERT_EQ(cloud.size(), 1000u);
  for (size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_GT(cloud.normals[i].dot(cloud.positions[i] - want.centre), 0) << i;
    ASSERT_NEAR(cloud.normals[i].norm(), 1.0, 1e-12);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Formats, GoodMeshes,
    ::testing::Values(Expected{"cube.obj", 0.01, 8e-6, 8, 12, Vec3::Zero()},
                      Expected{"cube_ulp.obj", 1.0, 8.0, 8, 12, Vec3::Zero()},
                      Expected{"cube_inward_ascii.stl", 0.5, 1.0, 8, 12, Vec3(0.5, 0.5, 0.5)},
                      Expected{"octahedron_binary.stl", 2.0, 8 * 4.0 / 3.0, 6, 8, Vec3::Zero()},
                      Expected{"octahedron_ascii.ply", 1.0, 27 * 4.0 / 3.0, 6, 8, Vec3::Zero()},
                      Expected{"cube_nodes.gltf", 0.001, 64e-9, 8, 12, Vec3(0.01, 0, 0)}),
    [](const ::testing::TestParamInfo<Expected>& info) {
      std::string name = info.param.file;
      for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return name;
    });

// loads `file` expecting failure; returns the message
std::string Failure(const std::string& file, double scale = 1.0) {
  TriangleMesh m;
  m.vertices.assign(3, Vec3::Ones());  // must come back empty
  m.triangles.assign(1, Eigen::Vector3i(0, 1, 2));
  std::string error;
  EXPECT_FALSE(ImportMesh(MeshPath(file), scale, &m, &error)) << file;
  EXPECT_TRUE(m.vertices.empty() && m.triangles.empty()) << file;
  EXPECT_TRUE(Contains(error, "mesh '" + MeshPath(file) + "': ")) << error;
  return error;
}

TEST(ImportMesh, OpenMeshNamesItsBoundaryEdges) {
  const std::string e = Failure("open_box.obj");
  EXPECT_TRUE(Contains(e, "open surface: 4 boundary edges (a closed surface is required)")) << e;
}

TEST(ImportMesh, NonManifoldMesh) {
  const std::string e = Failure("nonmanifold.obj");
  EXPECT_TRUE(Contains(e, "non-manifold: 1 edge is shared by more than two triangles")) << e;
}

TEST(ImportMesh, InconsistentWinding) {
  const std::string e = Failure("inconsistent.obj");
  EXPECT_TRUE(Contains(e, "inconsistent winding: 4 edges are used twice in the same direction")) << e;
}

TEST(ImportMesh, EmptyFile) {
  const std::string e = Failure("empty.obj");
  EXPECT_TRUE(Contains(e, "empty file")) << e;
}

TEST(ImportMesh, NoFaces) {
  const std::string e = Failure("points_only.obj");
  EXPECT_TRUE(Contains(e, "no triangles")) << e;
}

TEST(ImportMesh, GarbageFilesDoNotCrash) {
  for (const char* file : {"garbage.ply", "garbage.stl"}) {
    const std::string e = Failure(file);
    EXPECT_TRUE(Contains(e, "cannot read: ") || Contains(e, "no triangles")) << e;
    std::printf("%s\n", e.c_str());
  }
  // the PLY header is wrong: assimp itself refuses it
  EXPECT_TRUE(Contains(Failure("garbage.ply"), "cannot read: "));
}

TEST(ImportMesh, MissingFileAndDirectory) {
  std::string e = Failure("no_such_mesh.obj");
  EXPECT_TRUE(Contains(e, "file not found")) << e;
  TriangleMesh m;
  EXPECT_FALSE(ImportMesh(std::string(GRASPSIM_TEST_DATA) + "/meshes", 1.0, &m, &e));
  EXPECT_TRUE(Contains(e, "not a regular file")) << e;
}

TEST(ImportMesh, BadScale) {
  for (double scale : {0.0, -1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    const std::string e = Failure("cube.obj", scale);
    EXPECT_TRUE(Contains(e, "scale must be positive and finite")) << e;
  }
}

TEST(ImportMesh, RefusesTooManyTriangles) {
  TriangleMesh m;
  std::string e;
  EXPECT_FALSE(ImportMesh(MeshPath("cube.obj"), 1.0, &m, &e, 11));
  EXPECT_TRUE(Contains(e, "too many triangles: 12 (at most 11)")) << e;
  EXPECT_TRUE(ImportMesh(MeshPath("cube.obj"), 1.0, &m, &e, 12)) << e;
  EXPECT_EQ(kMaxImportTriangles, 5000000u);
}

TEST(ImportMesh, NullOutputsAreTolerated) {
  EXPECT_TRUE(ImportMesh(MeshPath("cube.obj"), 1.0, nullptr, nullptr));
  EXPECT_FALSE(ImportMesh(MeshPath("open_box.obj"), 1.0, nullptr, nullptr));
}

}  // namespace
}  // namespace gs::app

namespace gs::app {
namespace {

// found by the mesh fuzz target: assimp's PLY reader loops forever on this
// truncated header; the import runs assimp in a child process and gives up in time
TEST(ImportMesh, ImporterThatHangsIsStoppedAndNamed) {
  const std::string path = std::string(GRASPSIM_TEST_DATA) + "/meshes/hang_truncated.ply";
  TriangleMesh mesh;
  std::string error;
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(ImportMesh(path, 1.0, &mesh, &error, kMaxImportTriangles, 1.0));
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_NE(error.find("hang_truncated.ply': the importer did not finish within 1 s"), std::string::npos) << error;
  EXPECT_LT(took, 30.0);  // not a timing figure: only that it came back
  EXPECT_TRUE(mesh.triangles.empty());
}

}  // namespace
}  // namespace gs::app

namespace gs::app {
namespace {

// Debian's assimp-testmodels: assimp's own test files (hundreds of models in
// forty formats, some deliberately broken). Every one either loads as a closed
// surface or is refused with a message naming it, within the time limit; the
// process survives them all (assimp runs in a child process).
TEST(ImportMesh, SurvivesEveryAssimpTestModel) {
  const std::filesystem::path root = "/usr/share/assimp/models";
  // skipped only where Debian's assimp-testmodels is absent (scripts/setup.sh installs it)
  if (!std::filesystem::is_directory(root)) GTEST_SKIP() << "assimp-testmodels is not installed";
#ifdef GRASPSIM_SANITIZED
  // one fork per file of a sanitized process costs seconds each; the release run and the
  // mesh fuzz target cover this
  GTEST_SKIP() << "release-only: 440 forked imports";
#endif
  // textures, buffers, shaders and notes that sit beside the models
  const std::set<std::string> not_models = {".png", ".jpg", ".jpeg", ".tga", ".bmp", ".dds", ".txt", ".md", ".bin",
                                            ".mtl", ".glsl", ".xml", ".skin", ".mat", ".shader", ".gif", ".pcx"};
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::recursive_directory_iterator(root)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (e.is_regular_file() && !not_models.count(ext)) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  ASSERT_GT(files.size(), 300u);
  int loaded = 0, refused = 0, timed_out = 0, crashed = 0;
  for (const auto& f : files) {
    TriangleMesh mesh;
    std::string error;
    if (ImportMesh(f.string(), 1.0, &mesh, &error, 2000000, 5.0)) {
      ++loaded;
      EXPECT_FALSE(mesh.triangles.empty()) << f;
    } else {
      ++refused;
      EXPECT_NE(error.find("mesh '" + f.string() + "': "), std::string::npos) << error;
      timed_out += error.find("did not finish") != std::string::npos;
      crashed += error.find("crashed") != std::string::npos;
    }
  }
  std::printf("assimp-testmodels: %zu files: %d loaded, %d refused (%d timed out, %d crashed the importer)\n",
              files.size(), loaded, refused, timed_out, crashed);
  EXPECT_GT(loaded, 10);  // closed models do load
}

}  // namespace
}  // namespace gs::app
