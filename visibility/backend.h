#pragma once
// A global visibility backend: for a direction w, which patch sees which along w
// (a bundle of parallel rays covering the whole scene), as the geometry matrix A(w)
// of 004 section 3, eq. 8 and 29-31.
//
// Call order: make_backend(name, scene, options) once, then transfer() once per
// global direction. Backends keep scratch memory between calls; one backend object
// serves one thread.
#include "scenes/scene.h"

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace raybundle::visibility {

using scenes::Vec3;

// Receiver patch i sees source patch j along the light's direction of travel w, over
// `area` of visible projected area (on the plane perpendicular to w). Source j faces
// w (n_j . w > 0) and receiver i faces against it (n_i . w < 0). The same entry
// serves -w with the roles swapped: i is then the source, j the receiver.
// A(w)_ij = area / area_i (eq. 30).
//
// Sky entries (only with BackendOptions::sky; n = the patch count): (i, n) where
// receiver i is the first surface along a ray (it sees the open sky upstream), and
// (n + 1, j) where source j is the last one (along -w, it sees the open sky).
struct TransferEntry {
    std::uint32_t receiver;
    std::uint32_t source;
    double area;
};

struct GeometryMatrix {
    Vec3 direction = Vec3::Zero();
    std::vector<TransferEntry> entries;  // grouped by receiver, each (receiver, source) once
};

struct BackendOptions {
    int resolution = 0;   // visibility-map pixels per side; 0: derived from the scene
    bool jitter = true;   // shift the pixel grid by the given sub-pixel offset
    bool sky = false;     // also emit sky entries (a scene without sky skips them)
};

class Backend {
public:
    virtual ~Backend() = default;
    virtual std::string name() const = 0;
    // The resolution in use (pixels per side of the map), 0 for continuous backends.
    virtual int resolution() const = 0;
    // Anything else a run should record about the backend (e.g. the OpenGL renderer).
    virtual std::string details() const { return {}; }
    // Computes A(direction) for a unit direction. `jitter` in [0,1)^2 is the sub-pixel
    // shift of the map's grid (ignored without BackendOptions::jitter, and by
    // continuous backends); a fresh uniform jitter per direction makes pixel-count
    // areas unbiased estimates of the exact projected areas.
    virtual void transfer(const Vec3& direction, const Eigen::Vector2d& jitter, GeometryMatrix& out) = 0;
};

// Makes a backend by name: "painter", "global-zbuffer", "raycast". Throws std::invalid_argument for an unknown
// name, listing the known ones.
std::unique_ptr<Backend> make_backend(const std::string& name, const scenes::Scene& scene,
                                      const BackendOptions& options);

// The names make_backend knows.
std::vector<std::string> backend_names();

// The default map resolution for a scene: a small patch (the 10th percentile of
// patch areas) covers about 16 pixels when seen face-on; clamped to [64, 2048].
int default_resolution(const scenes::Scene& scene);

}  // namespace raybundle::visibility
