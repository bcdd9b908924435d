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
};

// Reads `path` (shown as `shown` in errors). Throws SceneError naming the file and
// the offending line or count: missing or unreadable file, unknown extension, a face
// index out of range, a file shorter than its header promises, non-finite coordinates.
MeshData read_mesh_file(const std::string& path, const std::string& shown);

}  // namespace raybundle::scenes
