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
#include <functional>
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
    std::vector<TransferEntry> entries;  // each (receiver, source) once, in no particular order
};

struct BackendOptions {
    int resolution = 0;   // visibility-map pixels per side; 0: derived from the scene
    bool jitter = true;   // shift the pixel grid by the given sub-pixel offset
    bool sky = false;     // also emit sky entries (a scene without sky skips them)
};

// A cache line of its own (alignas 64: its size a multiple of it too): backends of
// different threads are made one after another and write their counters as they draw.
class alignas(64) Backend {
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

    // A batch: out[k] = A(directions[k]) with jitters[k], the matrix transfer() gives
    // (out is resized to the batch). A backend on a GPU submits many directions at once
    // (one wait for the GPU per submission, its CPU work on up to `threads` threads of
    // the caller's, which must not call this backend meanwhile); the default computes
    // them in turn. `alongside`, when given, runs once on the calling thread, where the
    // backend can, while its work is in flight. It must not touch `out`.
    virtual void transfer_many(const std::vector<Vec3>& directions, const std::vector<Eigen::Vector2d>& jitters,
                               std::vector<GeometryMatrix>& out, int threads, const std::function<void()>& alongside) {
        (void)threads;
        out.resize(directions.size());
        if (alongside) alongside();
        for (std::size_t k = 0; k < directions.size(); ++k) transfer(directions[k], jitters[k], out[k]);
    }
    // How many directions transfer_many() takes at once to good effect (1: no gain).
    virtual int batch_directions() const { return 1; }
};

// What a backend can do: one row per backend this build has, the default first.
struct BackendInfo {
    std::string name;
    // Every receiver paired with the surface really in front of it along w at each
    // pixel centre (or exactly, without pixels), whatever the patches' sizes, contacts
    // or overlaps. The centre-sorted painter is not: it orders whole patches.
    bool exact;
    bool discrete;          // a pixel map: BackendOptions::resolution and jitter apply
    bool sky;               // can emit sky entries (BackendOptions::sky)
    bool side_by_side;      // one object per thread may run at once (not: one OpenGL context)
    std::string summary;    // one line for `raybundle backends`
};
const std::vector<BackendInfo>& backend_infos();
// The row of a backend; throws OptionError("visibility") for an unknown name, listing the known ones.
const BackendInfo& backend_info(const std::string& name);
// The names make_backend knows, the default first.
std::vector<std::string> backend_names();
// The backend used when none is named: exact, and the fastest of those.
inline const char* const kDefaultBackend = "exact-painter";

// Makes a backend by name (see backend_infos()). Throws OptionError for an unknown
// name (listing the known ones), a backend this build lacks, or options it does not
// support.
// `arrays`, where given, are the scene's patch arrays (visibility/patch_arrays.h) that
// the pixel backends read, shared with other backends (BackendSet makes them once for
// all its threads); without, a backend makes its own.
struct PatchArrays;
std::unique_ptr<Backend> make_backend(const std::string& name, const scenes::Scene& scene,
                                      const BackendOptions& options,
                                      std::shared_ptr<const PatchArrays> arrays = nullptr);

// The default map resolution for a scene: a small patch (the 10th percentile of
// patch areas) covers about 16 pixels when seen face-on; clamped to [64, 2048].
int default_resolution(const scenes::Scene& scene);

}  // namespace raybundle::visibility
