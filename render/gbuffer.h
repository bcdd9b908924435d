#pragma once
// The G-buffer: for one point of every pixel (its centre, or one drawn uniformly from
// it), the patch the camera sees there and from which side, the point, the depth and
// the barycentric coordinates. The patch's normal and the shading normal are the
// scene's (Patch::normal, Scene::shading_normal(patch, b1, b2)): not kept per pixel,
// so that a 512^2 buffer is 21 MB, not 37.
#include "render/camera.h"
#include "scenes/ray_caster.h"

#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace raybundle::render {

struct GSample {
    int patch = -1;      // -1: background
    bool front = false;  // the camera sees the patch's front side (its normal against the ray)
    scenes::Vec3 direction = scenes::Vec3::Zero();  // the camera ray's (unit)
    scenes::Vec3 point = scenes::Vec3::Zero();
    double depth = 0.0;         // distance from the eye
    double b1 = 0.0, b2 = 0.0;  // barycentric weights of the patch's 2nd and 3rd vertex
};

// What a camera ray that meets no surface shows: the sky radiance arriving from its
// direction, or black.
inline scenes::Rgb background(const scenes::Scene& scene, const scenes::Vec3& direction) {
    return scene.sky ? scene.sky->arriving_along(-direction) : scenes::Rgb::Zero();
}

// A vector's allocator that leaves the elements' construction to their owner
// (make_gbuffer constructs every sample in place on the threads: a 512^2 buffer's
// 21 MB are first touched there, not zeroed by one thread beforehand). Only for
// trivially destructible element types: one left unconstructed by an exception
// needs no destructor.
template <class T>
struct ConstructedByOwner : std::allocator<T> {
    static_assert(std::is_trivially_destructible_v<T>);
    template <class U>
    struct rebind {
        using other = ConstructedByOwner<U>;
    };
    ConstructedByOwner() = default;
    template <class U>
    ConstructedByOwner(const ConstructedByOwner<U>&) noexcept {}
    template <class U>
    void construct(U*) noexcept {}
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

struct GBuffer {
    int width = 0, height = 0;
    // Every sample is constructed by make_gbuffer: resize() and vector(n) leave new
    // elements unconstructed here (ConstructedByOwner), so whoever grows it must
    // construct them.
    std::vector<GSample, ConstructedByOwner<GSample>> samples;
    const GSample& at(int x, int y) const { return samples[static_cast<std::size_t>(y) * width + x]; }
};

// Where in its pixel each ray goes: the centre, or (drawn) a point uniform over the
// pixel from stream sampling::streams::kGuidePoints(pass, pixel) of `seed`.
struct PixelPoints {
    bool drawn = false;
    std::uint64_t seed = 0, pass = 0;
};

// One ray through every pixel; rows split over `threads` (same result for any count).
GBuffer make_gbuffer(const scenes::Scene& scene, const scenes::RayCaster& caster, const PinholeCamera& camera,
                     int threads = 1, const PixelPoints& points = {});

}  // namespace raybundle::render
