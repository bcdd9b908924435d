#pragma once
// Reading OBJ/PLY/OFF meshes through OpenMesh IO, with the structural checks that
// OpenMesh leaves out (it skips bad faces and short files quietly).
#include "scenes/scene.h"

#include <array>
#include <string>
#include <vector>

namespace raybundle::scenes {

struct MeshData {
    std::vector<Vec3> vertices;
    std::vector<std::array<int, 3>> triangles;  // polygons are triangulated
    // The file's normals at every triangle's corners (unit), or empty when it has none.
    // A zero vector: no normal at that corner (an OBJ face without them).
    std::vector<std::array<Vec3, 3>> normals;
};

// Reads `path` (shown as `shown` in errors). Throws SceneError naming the file and
// the offending line or count: missing or unreadable file, unknown extension, a face
// index out of range, a file shorter than its header promises, non-finite coordinates,
// a bad normal (non-finite, zero length, an OBJ normal index out of range, an OBJ face
// with normals at some corners only, a PLY vertex with some of nx, ny, nz).
// Normals: OBJ `vn` (faces `v//vn`, `v/vt/vn`) and the PLY vertex properties nx, ny, nz.
MeshData read_mesh_file(const std::string& path, const std::string& shown);

}  // namespace raybundle::scenes
