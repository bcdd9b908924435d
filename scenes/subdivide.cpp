#include "scenes/subdivide.h"

#include "scenes/errors.h"

#include <cmath>
#include <sstream>

#include <algorithm>
#include <utility>
#include <vector>

namespace raybundle::scenes {

std::size_t subdivide(Scene& scene, double max_edge) {
    TriMesh& mesh = scene.mesh;
    const double limit2 = max_edge * max_edge;
    std::size_t splits = 0;
    std::vector<std::pair<double, TriMesh::EdgeHandle>> long_edges;
    for (;;) {
        long_edges.clear();
        for (auto e : mesh.edges()) {
            const double len2 = mesh.calc_edge_sqr_length(e);
            if (len2 > limit2) long_edges.emplace_back(len2, e);
        }
        if (long_edges.empty()) break;
        // Longest first: splitting the longest edge of a triangle is what keeps shapes bounded.
        std::stable_sort(long_edges.begin(), long_edges.end(),
                         [](const auto& a, const auto& b) { return a.first > b.first; });
        for (const auto& [len2, e] : long_edges) {
            // An earlier split in this pass may have shortened this edge (it keeps one half).
            if (mesh.calc_edge_sqr_length(e) <= limit2) continue;
            const auto h = mesh.halfedge_handle(e, 0);
            const auto mid = 0.5 * (mesh.point(mesh.from_vertex_handle(h)) + mesh.point(mesh.to_vertex_handle(h)));
            mesh.split_copy(e, mid);
            ++splits;
        }
    }
    scene.finalize();
    return splits;
}

void check_refinement(const Scene& scene, double max_edge, const std::string& shown) {
    std::ostringstream size;
    size << max_edge;
    if (!(max_edge > 0.0) || !std::isfinite(max_edge))
        throw SceneError(shown, "patch_size", "must be a positive number, got " + size.str());
    const double estimate = scene.total_area() / (0.25 * max_edge * max_edge);
    if (estimate > 2e7) {
        std::ostringstream count;
        count << estimate;
        throw SceneError(shown, "patch_size",
                         size.str() + " would make about " + count.str() + " patches (limit 20,000,000)");
    }
}

}  // namespace raybundle::scenes
