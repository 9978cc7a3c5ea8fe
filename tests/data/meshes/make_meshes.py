#!/usr/bin/env python3
"""Writes the small test meshes used by tests/app/mesh_import_test.cpp (run from this folder)."""
import base64
import json
import random
import struct

# cube [-1, 1]^3 as outward quads (vertex i has x = bit 0, y = bit 1, z = bit 2)
CUBE_V = [(1 if i & 1 else -1, 1 if i & 2 else -1, 1 if i & 4 else -1) for i in range(8)]
CUBE_Q = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
CUBE_T = [t for q in CUBE_Q for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
# octahedron with vertices at +-1 on each axis: volume 4/3
OCTA_V = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
OCTA_T = []
for sx, ix in ((1, 0), (-1, 1)):
    for sy, iy in ((1, 2), (-1, 3)):
        for sz, iz in ((1, 4), (-1, 5)):
            OCTA_T.append((ix, iy, iz) if sx * sy * sz > 0 else (ix, iz, iy))


def obj(name, verts, faces, header):
    with open(name, "w") as f:
        f.write("# " + header + "\n")
        for v in verts:
            f.write("v %r %r %r\n" % tuple(float(c) for c in v))
        for t in faces:
            f.write("f " + " ".join(str(i + 1) for i in t) + "\n")


def normal(a, b, c):
    u = [b[i] - a[i] for i in range(3)]
    w = [c[i] - a[i] for i in range(3)]
    n = (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])
    length = sum(x * x for x in n) ** 0.5
    return tuple(x / length for x in n)


# OBJ: the cube as quads (assimp triangulates), side 2, volume 8
obj("cube.obj", CUBE_V, CUBE_Q, "cube [-1,1]^3 as quads, outward")

# OBJ: one corner written twice, the copy 1 float32 ulp away (the weld must merge it)
verts = CUBE_V + [(1.0000001, 1, 1)]
quads = [tuple(8 if i == 7 and k < 3 else i for i in q) for k, q in enumerate(CUBE_Q)]
obj("cube_ulp.obj", verts, quads, "cube whose +z face uses a copy of corner 7 one float32 ulp away")

# ASCII STL: the cube shifted to [0, 2]^3 and wound INWARD (the import must flip it)
with open("cube_inward_ascii.stl", "w") as f:
    f.write("solid cube\n")
    for a, b, c in CUBE_T:
        pa, pb, pc = ([x + 1 for x in CUBE_V[i]] for i in (a, c, b))
        f.write("  facet normal %g %g %g\n    outer loop\n" % normal(pa, pb, pc))
        for p in (pa, pb, pc):
            f.write("      vertex %g %g %g\n" % tuple(p))
        f.write("    endloop\n  endfacet\n")
    f.write("endsolid cube\n")

# binary STL: the octahedron
with open("octahedron_binary.stl", "wb") as f:
    f.write(b"binary octahedron".ljust(80, b" "))
    f.write(struct.pack("<I", len(OCTA_T)))
    for t in OCTA_T:
        p = [OCTA_V[i] for i in t]
        f.write(struct.pack("<3f", *normal(*p)))
        for v in p:
            f.write(struct.pack("<3f", *v))
        f.write(struct.pack("<H", 0))

# ASCII PLY: the octahedron scaled by 3 (volume 36)
with open("octahedron_ascii.ply", "w") as f:
    f.write("ply\nformat ascii 1.0\ncomment octahedron, vertices at +-3\n")
    f.write("element vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % len(OCTA_V))
    f.write("element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(OCTA_T))
    for v in OCTA_V:
        f.write("%g %g %g\n" % tuple(3 * c for c in v))
    for t in OCTA_T:
        f.write("3 %d %d %d\n" % t)

# glTF 2.0 with an embedded buffer: the cube under two nodes, translation (10, 0, 0)
# then scale 2 (side 4, volume 64, centre (10, 0, 0))
pos = b"".join(struct.pack("<3f", *v) for v in CUBE_V)
idx = b"".join(struct.pack("<3H", *t) for t in CUBE_T)
buf = pos + idx
gltf = {
    "asset": {"version": "2.0", "generator": "graspsim make_meshes.py"},
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"name": "parent", "translation": [10, 0, 0], "children": [1]},
              {"name": "cube", "mesh": 0, "scale": [2, 2, 2]}],
    "meshes": [{"name": "cube", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
    "buffers": [{"byteLength": len(buf),
                 "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos), "target": 34962},
                    {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx), "target": 34963}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
                   "min": [-1, -1, -1], "max": [1, 1, 1]},
                  {"bufferView": 1, "componentType": 5123, "count": len(idx) // 2, "type": "SCALAR"}],
}
with open("cube_nodes.gltf", "w") as f:
    json.dump(gltf, f, indent=1)
    f.write("\n")

# bad meshes
obj("open_box.obj", CUBE_V, CUBE_Q[:5], "cube without its +x face: 4 boundary edges")
obj("nonmanifold.obj", CUBE_V + [(3, 3, 0)], CUBE_Q + [(0, 1, 8)], "closed cube plus a fin on edge 0-1")
obj("inconsistent.obj", CUBE_V, CUBE_Q[:5] + [tuple(reversed(CUBE_Q[5]))], "cube with one face wound inward")
with open("points_only.obj", "w") as f:
    f.write("# vertices and no faces\n")
    for v in CUBE_V:
        f.write("v %d %d %d\n" % v)
open("empty.obj", "w").close()
rng = random.Random(1234)
with open("garbage.ply", "wb") as f:
    f.write(bytes(rng.randrange(256) for _ in range(777)))
with open("garbage.stl", "wb") as f:
    f.write(bytes(rng.randrange(256) for _ in range(555)))
