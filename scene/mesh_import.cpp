#include "scene/mesh_import.h"

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <system_error>
#include <utility>
#include <vector>

#include "core/point_grid.h"

namespace gs::app {
namespace {

using Mat4 = Eigen::Matrix4d;

// refuse files larger than this before parsing them (bytes)
constexpr uintmax_t kMaxFileBytes = uintmax_t{2} << 30;
// deepest node hierarchy followed
constexpr int kMaxNodeDepth = 1000;

Mat4 ToEigen(const aiMatrix4x4& m) {
  Mat4 r;
  r << m.a1, m.a2, m.a3, m.a4, m.b1, m.b2, m.b3, m.b4, m.c1, m.c2, m.c3, m.c4, m.d1, m.d2, m.d3, m.d4;
  return r;
}

// one mesh placed in the scene by a node
struct Instance {
  const aiMesh* mesh;
  Mat4 transform;
};

// depth-first walk of the node tree (explicit stack: files can nest deeply)
bool CollectInstances(const aiScene* scene, std::vector<Instance>* out, std::string* why) {
  std::vector<std::pair<const aiNode*, std::pair<Mat4, int>>> stack;
  if (scene->mRootNode) stack.push_back({scene->mRootNode, {Mat4::Identity(), 0}});
  while (!stack.empty()) {
    const aiNode* node = stack.back().first;
    const Mat4 parent = stack.back().second.first;
    const int depth = stack.back().second.second;
    stack.pop_back();
    if (depth > kMaxNodeDepth) {
      *why = "node hierarchy deeper than " + std::to_string(kMaxNodeDepth);
      return false;
    }
    const Mat4 global = parent * ToEigen(node->mTransformation);
    for (unsigned k = 0; k < node->mNumMeshes; ++k) {
      const unsigned m = node->mMeshes[k];
      if (m >= scene->mNumMeshes || !scene->mMeshes[m]) {
        *why = "node '" + std::string(node->mName.C_Str()) + "' refers to a missing mesh";
        return false;
      }
      out->push_back({scene->mMeshes[m], global});
    }
    // children pushed in reverse so that they are visited in file order
    for (unsigned c = node->mNumChildren; c-- > 0;)
      if (node->mChildren[c]) stack.push_back({node->mChildren[c], {global, depth + 1}});
  }
  return true;
}

// merges vertices closer than `tol`; each vertex maps to the lowest-numbered
// earlier vertex within reach, so the result does not depend on the grid's order
std::vector<int> Weld(const std::vector<Vec3>& v, double tol, std::vector<Vec3>* welded) {
  PointGrid grid;
  grid.Build(v, std::max(tol, 1e-300));
  std::vector<int> id(v.size(), -1);
  std::vector<int> buf;
  welded->clear();
  for (size_t i = 0; i < v.size(); ++i) {
    buf.clear();
    grid.Query(v[i], tol, &buf);
    int first = static_cast<int>(i);
    for (int j : buf)
      if (j < first) first = j;
    if (first == static_cast<int>(i)) {
      id[i] = static_cast<int>(welded->size());
      welded->push_back(v[i]);
    } else {
      id[i] = id[first];
    }
  }
  return id;
}

std::string Plural(int64_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

std::string Describe(EMeshError e, const MeshCheckReport& r) {
  switch (e) {
    case EMeshError::None:
      return "ok";
    case EMeshError::Empty:
      return "no triangles";
    case EMeshError::NotFinite:
      return "non-finite vertex coordinates (" + Plural(r.count, "vertex", "vertices") + ")";
    case EMeshError::IndexOutOfRange:
      return "vertex index out of range (" + Plural(r.count, "index", "indices") + ")";
    case EMeshError::Degenerate:
      if (r.count == 0) return "degenerate: the closed surface encloses no volume";
      return "degenerate: " + Plural(r.count, "zero-area triangle", "zero-area triangles") + " (first: triangle " +
             std::to_string(r.first) + " after merging)";
    case EMeshError::Open:
      return "open surface: " + Plural(r.count, "boundary edge", "boundary edges") +
             " (a closed surface is required)";
    case EMeshError::NonManifold:
      return "non-manifold: " + Plural(r.count, "edge is", "edges are") +
             " shared by more than two triangles (a closed surface is required)";
    case EMeshError::Inconsistent:
      return "inconsistent winding: " + Plural(r.count, "edge is", "edges are") +
             " used twice in the same direction (neighbouring triangles must be wound alike)";
  }
  return ToString(e);
}

// assimp's part: read the file, flatten every placed mesh into one triangle soup
bool Parse(const std::string& path, double scale, size_t max_triangles, std::vector<Vec3>* raw_out,
           std::vector<Eigen::Vector3i>* tris_out, std::string* why) {
  // parse
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices);
  if (!scene) {
    const std::string msg = importer.GetErrorString();
    *why = "cannot read: " + (msg.empty() ? std::string("unknown assimp error") : msg);
    return false;
  }
  std::vector<Instance> instances;
  if (!CollectInstances(scene, &instances, why)) return false;

  // size guard before copying anything
  size_t n_tris = 0, n_verts = 0;
  for (const Instance& in : instances) {
    if (!in.mesh->mFaces && in.mesh->mNumFaces) continue;
    for (unsigned f = 0; f < in.mesh->mNumFaces; ++f) n_tris += in.mesh->mFaces[f].mNumIndices == 3;
    n_verts += in.mesh->mNumVertices;
  }
  if (n_tris == 0) {
    *why = "no triangles";
    return false;
  }
  if (n_tris > max_triangles) {
    *why = "too many triangles: " + std::to_string(n_tris) + " (at most " + std::to_string(max_triangles) + ")";
    return false;
  }
  if (n_verts > 3 * max_triangles + 3) {
    *why = "too many vertices: " + std::to_string(n_verts);
    return false;
  }

  // merge all instances; a mirroring transform reverses the winding
  std::vector<Vec3>& raw = *raw_out;
  std::vector<Eigen::Vector3i>& tris = *tris_out;
  raw.reserve(n_verts);
  tris.reserve(n_tris);
  for (const Instance& in : instances) {
    const aiMesh* mesh = in.mesh;
    if (!mesh->mVertices || !mesh->mFaces) continue;
    const int base = static_cast<int>(raw.size());
    const Eigen::Matrix3d lin = in.transform.topLeftCorner<3, 3>();
    const Vec3 shift = in.transform.topRightCorner<3, 1>();
    for (unsigned i = 0; i < mesh->mNumVertices; ++i) {
      const aiVector3D& p = mesh->mVertices[i];
      raw.push_back(scale * (lin * Vec3(p.x, p.y, p.z) + shift));
    }
    const bool mirrored = lin.determinant() < 0;
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3 || !face.mIndices) continue;
      for (int k = 0; k < 3; ++k) {
        if (face.mIndices[k] >= mesh->mNumVertices) {
          *why = "face " + std::to_string(f) + " of mesh '" + mesh->mName.C_Str() + "' has a vertex index out of range";
          return false;
        }
      }
      Eigen::Vector3i t(base + static_cast<int>(face.mIndices[0]), base + static_cast<int>(face.mIndices[1]),
                        base + static_cast<int>(face.mIndices[2]));
      if (mirrored) std::swap(t[1], t[2]);
      tris.push_back(t);
    }
  }
  return true;
}

// Runs Parse in a child process: assimp hangs or crashes on some malformed files
// (its PLY reader can loop forever at the end of a truncated file), and a lab's
// program must refuse such a file with a message, not hang or die. The child
// sends the triangle soup back through a pipe; the parent waits at most `timeout_s`.
bool ParseIsolated(const std::string& path, double scale, size_t max_triangles, double timeout_s,
                   std::vector<Vec3>* raw, std::vector<Eigen::Vector3i>* tris, std::string* why) {
  int fds[2];
  if (pipe(fds) != 0) return Parse(path, scale, max_triangles, raw, tris, why);
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    return Parse(path, scale, max_triangles, raw, tris, why);
  }
  if (pid == 0) {
    // the child: parse, write [ok byte][error or counts and arrays], and leave without cleanup
    close(fds[0]);
    std::string msg;
    bool ok = false;
    try {
      ok = Parse(path, scale, max_triangles, raw, tris, &msg);
    } catch (const std::exception& ex) {
      msg = std::string("import failed: ") + ex.what();
    } catch (...) {
      msg = "import failed: unknown exception";
    }
    auto put = [&](const void* p, size_t n) {
      const char* c = static_cast<const char*>(p);
      while (n) {
        const ssize_t w = write(fds[1], c, n);
        if (w <= 0) _exit(3);
        c += w;
        n -= static_cast<size_t>(w);
      }
    };
    const uint8_t flag = ok ? 1 : 0;
    put(&flag, 1);
    if (!ok) {
      put(msg.data(), msg.size());
    } else {
      const uint64_t counts[2] = {raw->size(), tris->size()};
      put(counts, sizeof(counts));
      put(raw->data(), raw->size() * sizeof(Vec3));
      put(tris->data(), tris->size() * sizeof(Eigen::Vector3i));
    }
    _exit(0);
  }
  close(fds[1]);
  std::string data;
  char buf[1 << 16];
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  bool timed_out = false;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out = true;
      break;
    }
    pollfd pfd{fds[0], POLLIN, 0};
    const int r = poll(&pfd, 1, static_cast<int>(std::min<int64_t>(left.count(), 1000)));
    if (r < 0 && errno != EINTR) break;
    if (r <= 0) continue;
    const ssize_t n = read(fds[0], buf, sizeof(buf));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    data.append(buf, static_cast<size_t>(n));
  }
  close(fds[0]);
  if (timed_out) kill(pid, SIGKILL);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timed_out) {
    char t[64];
    std::snprintf(t, sizeof(t), "%g", timeout_s);
    *why = std::string("the importer did not finish within ") + t + " s (malformed file?)";
    return false;
  }
  if (WIFSIGNALED(status)) {
    *why = "the importer crashed on this file (signal " + std::to_string(WTERMSIG(status)) + ")";
    return false;
  }
  if (data.empty() || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    *why = "the importer failed (exit status " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")";
    return false;
  }
  if (data[0] != 1) {
    *why = data.substr(1);
    return false;
  }
  uint64_t counts[2] = {0, 0};
  if (data.size() < 1 + sizeof(counts)) {
    *why = "the importer's answer was cut short";
    return false;
  }
  std::memcpy(counts, data.data() + 1, sizeof(counts));
  const size_t need = 1 + sizeof(counts) + counts[0] * sizeof(Vec3) + counts[1] * sizeof(Eigen::Vector3i);
  if (counts[0] > 3 * max_triangles + 3 || counts[1] > max_triangles || data.size() != need) {
    *why = "the importer's answer was inconsistent";
    return false;
  }
  raw->resize(counts[0]);
  tris->resize(counts[1]);
  const char* at = data.data() + 1 + sizeof(counts);
  std::memcpy(static_cast<void*>(raw->data()), at, counts[0] * sizeof(Vec3));
  std::memcpy(static_cast<void*>(tris->data()), at + counts[0] * sizeof(Vec3), counts[1] * sizeof(Eigen::Vector3i));
  return true;
}

bool Import(const std::string& path, double scale, TriangleMesh* out, std::string* why, size_t max_triangles,
            double timeout_s) {
  if (!std::isfinite(scale) || !(scale > 0)) {
    *why = "scale must be positive and finite (got " + std::to_string(scale) + ")";
    return false;
  }

  // the file itself
  std::error_code ec;
  const std::filesystem::path fs_path(path);
  if (!std::filesystem::exists(fs_path, ec)) {
    *why = "file not found";
    return false;
  }
  if (!std::filesystem::is_regular_file(fs_path, ec)) {
    *why = "not a regular file";
    return false;
  }
  const uintmax_t bytes = std::filesystem::file_size(fs_path, ec);
  if (ec) {
    *why = "cannot read: " + ec.message();
    return false;
  }
  if (bytes == 0) {
    *why = "empty file (0 bytes)";
    return false;
  }
  if (bytes > kMaxFileBytes) {
    *why = "file too large (" + std::to_string(bytes) + " bytes; at most " + std::to_string(kMaxFileBytes) + ")";
    return false;
  }

  std::vector<Vec3> raw;
  std::vector<Eigen::Vector3i> tris;
  if (!ParseIsolated(path, scale, max_triangles, timeout_s, &raw, &tris, why)) return false;
  size_t bad = 0;
  for (const Vec3& p : raw) bad += !p.allFinite();
  if (bad) {
    *why = "non-finite vertex coordinates (" + Plural(static_cast<int64_t>(bad), "vertex", "vertices") + ")";
    return false;
  }

  // weld by position: STL and split meshes repeat shared corners
  Vec3 lo = raw[0], hi = raw[0];
  for (const Vec3& p : raw) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double largest = std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff());
  const double tol = std::max(1e-9 * (hi - lo).norm(), 0x1.0p-22 * largest);
  TriangleMesh mesh;
  const std::vector<int> id = Weld(raw, tol, &mesh.vertices);
  mesh.triangles.reserve(tris.size());
  for (const Eigen::Vector3i& t : tris) mesh.triangles.push_back(Eigen::Vector3i(id[t[0]], id[t[1]], id[t[2]]));

  // closed, manifold, outward
  MeshCheckReport report;
  const EMeshError e = ValidateAndOrientMesh(&mesh, &report);
  if (e != EMeshError::None) {
    *why = Describe(e, report);
    return false;
  }
  *out = std::move(mesh);
  return true;
}

}  // namespace

bool ImportMesh(const std::string& path, double scale, gs::TriangleMesh* out, std::string* error,
                size_t max_triangles, double timeout_s) {
  std::string why;
  bool ok = false;
  TriangleMesh mesh;
  try {
    ok = Import(path, scale, &mesh, &why, max_triangles, timeout_s);
  } catch (const std::exception& ex) {
    why = std::string("import failed: ") + ex.what();
    ok = false;
  } catch (...) {
    why = "import failed: unknown exception";
    ok = false;
  }
  if (out) {
    out->vertices.clear();
    out->triangles.clear();
    if (ok) *out = std::move(mesh);
  }
  if (error) *error = ok ? std::string() : "mesh '" + path + "': " + why;
  return ok;
}

}  // namespace gs::app
