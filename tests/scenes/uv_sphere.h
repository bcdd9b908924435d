#pragma once
// A UV sphere for the shading-normal tests: the unit sphere about the origin, `rings`
// bands of latitude (fans at the poles) and `segments` of longitude, front sides out,
// and writers for it as OBJ and PLY.
#include "scenes/scene.h"

#include <array>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

namespace raybundle::test {

struct UvSphere {
    std::vector<scenes::Vec3> vertices;
    std::vector<std::array<int, 3>> triangles;
};

inline UvSphere uv_sphere(int segments, int rings) {
    using scenes::Vec3;
    UvSphere s;
    s.vertices.emplace_back(0, 0, 1);
    for (int j = 1; j < rings; ++j)
        for (int i = 0; i < segments; ++i) {
            const double theta = M_PI * j / rings, phi = 2 * M_PI * i / segments;
            s.vertices.emplace_back(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
        }
    s.vertices.emplace_back(0, 0, -1);
    const int south = static_cast<int>(s.vertices.size()) - 1;
    auto at = [&](int j, int i) { return 1 + (j - 1) * segments + (i % segments); };  // ring j = 1 .. rings-1
    auto add = [&](int a, int b, int c) {
        // Counter-clockwise seen from outside: the normal points away from the centre.
        const Vec3 n = (s.vertices[b] - s.vertices[a]).cross(s.vertices[c] - s.vertices[a]);
        if (n.dot(s.vertices[a] + s.vertices[b] + s.vertices[c]) < 0) std::swap(b, c);
        s.triangles.push_back({a, b, c});
    };
    for (int i = 0; i < segments; ++i) {
        add(0, at(1, i), at(1, i + 1));
        add(south, at(rings - 1, i), at(rings - 1, i + 1));
        for (int j = 1; j + 1 < rings; ++j) {
            add(at(j, i), at(j + 1, i), at(j + 1, i + 1));
            add(at(j, i), at(j + 1, i + 1), at(j, i + 1));
        }
    }
    return s;
}

// OBJ text; with `normals` every corner names its vertex's exact sphere normal, half
// of the faces as `v//vn`, half as `v/vt/vn`.
inline std::string obj_text(const UvSphere& s, bool normals) {
    std::ostringstream os;
    os.precision(17);
    for (const auto& v : s.vertices) os << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    if (normals) {
        os << "vt 0.5 0.5\n";
        // Scaled by 2: the reader normalises.
        for (const auto& v : s.vertices) os << "vn " << 2 * v.x() << ' ' << 2 * v.y() << ' ' << 2 * v.z() << '\n';
    }
    for (std::size_t f = 0; f < s.triangles.size(); ++f) {
        os << 'f';
        for (int k : s.triangles[f]) {
            os << ' ' << k + 1;
            if (normals) os << (f % 2 ? "/1/" : "//") << k + 1;
        }
        os << '\n';
    }
    return os.str();
}

// ASCII PLY text with the vertex properties nx, ny, nz (the exact sphere normals).
inline std::string ply_text(const UvSphere& s) {
    std::ostringstream os;
    os.precision(9);
    os << "ply\nformat ascii 1.0\nelement vertex " << s.vertices.size()
       << "\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\n"
          "property float nz\nelement face "
       << s.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
    for (const auto& v : s.vertices)
        os << v.x() << ' ' << v.y() << ' ' << v.z() << ' ' << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    for (const auto& t : s.triangles) os << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
    return os.str();
}

// The angle between two directions in degrees.
inline double degrees_between(const scenes::Vec3& a, const scenes::Vec3& b) {
    return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

}  // namespace raybundle::test
