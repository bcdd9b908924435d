#pragma once
// Hardware z-buffer visibility through OpenGL 4.5 (004 section 5.1.4's idea, done by
// depth peeling).
//
// Parameters (BackendOptions): resolution (int, pixels per side of the same jittered
// grid the painter's uses; default: default_resolution(scene)), jitter (bool, default
// true).
//
// The patches are drawn with an orthographic projection along w into an R32UI
// framebuffer that stores patch id + 1 (exact integers) and a 32-bit float depth
// buffer. Depth peeling extracts the depth layers one pass at a time: pass k keeps, per
// pixel, the nearest fragment behind layer k - 1. Consecutive layers are consecutive
// surfaces along each pixel's ray, so a source in layer k followed by a receiver in
// layer k + 1 adds one pixel's area to A(receiver, source). Peeling stops at the first
// empty layer (an occlusion query).
//
// Why depth peeling rather than the paper's emitter/receiver peeling: each pass is one
// plain z-buffer draw of the whole scene with one extra depth comparison, the number
// of passes is the scene's depth complexity along w (4-8 for a furnished room), and the
// order is exact per pixel, so interpenetrating patches come out right, as with the
// global z-buffer. Emitter/receiver peeling needs a visibility test per patch and more
// passes when patches overlap cyclically.
//
// The OpenGL context comes from gl_context.h (OSMesa by default, EGL on a GPU).
// Limitation: coincident surfaces (a two-sided panel made of two opposite triangles at
// the same place) peel as one layer, so the pair behind the panel is lost; the global
// z-buffer handles them.
#include "visibility/backend.h"

#include <memory>

namespace raybundle::visibility {

class ZBufferBackend final : public Backend {
public:
    ZBufferBackend(const scenes::Scene& scene, const BackendOptions& options);
    ~ZBufferBackend() override;
    std::string name() const override { return "zbuffer"; }
    int resolution() const override;
    void transfer(const Vec3& direction, const Eigen::Vector2d& jitter, GeometryMatrix& out) override;
    // The OpenGL implementation in use.
    std::string details() const override;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace raybundle::visibility
