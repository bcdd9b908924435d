#pragma once
// Ray casting against the scene's patches through Embree: one BVH built per scene,
// shared by the renderer (camera rays) and, later, the final gather and the
// `raycast` visibility backend.
#include "scenes/scene.h"

#include <limits>
#include <memory>
#include <vector>

namespace raybundle::scenes {

struct RayHit {
    int patch = -1;       // -1: the ray left the scene
    double t = 0.0;       // distance along the (unit) direction
    double b1 = 0.0;      // barycentric weights of the patch's 2nd and 3rd vertices
    double b2 = 0.0;
    bool valid() const { return patch >= 0; }
};

class RayCaster {
public:
    // Builds the BVH on `threads` threads (0: Embree's choice, every hardware thread);
    // the BVH, and so every hit, is the same for any count.
    explicit RayCaster(const Scene& scene, int threads = 0);
    ~RayCaster();
    RayCaster(const RayCaster&) = delete;
    RayCaster& operator=(const RayCaster&) = delete;

    // Nearest hit of the ray org + t dir, t in (t_min, t_max). Both sides of a patch
    // are hit (patches block light from behind too), but for a two-sided material the
    // ray meets the twin that faces it; thread-safe.
    RayHit intersect(const Vec3& org, const Vec3& dir, double t_min = 0.0,
                     double t_max = std::numeric_limits<double>::infinity()) const;

    // Whether intersect(org, dir, t_min, t_max) would hit anything: the same answer,
    // sooner (the traversal stops at the first hit it accepts, in whatever order); for
    // shadow rays. Thread-safe.
    bool occluded(const Vec3& org, const Vec3& dir, double t_min, double t_max) const;

    // Every crossing of the ray org + t dir with a patch, t in (t_min, t_max), in order
    // of increasing t (ties in patch order). Replaces the contents of `hits`.
    void all_hits(const Vec3& org, const Vec3& dir, std::vector<RayHit>& hits, double t_min = 0.0,
                  double t_max = std::numeric_limits<double>::infinity()) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace raybundle::scenes
