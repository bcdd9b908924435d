#include "scenes/ray_caster.h"

#include "scenes/errors.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace raybundle::scenes {

struct RayCaster::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    // Patches of two-sided materials, with their normals: intersect() passes over their
    // back sides, where each has a twin facing the ray.
    std::vector<char> two_sided;
    std::vector<float> normals;  // 3 per patch, two-sided ones only filled
    bool any_two_sided = false;
    // Embree's frame: the scene's coordinates less the centre of its bounds, divided by
    // a power of two that brings the largest to [0.5, 1), and distances along a ray
    // divided with them. Embree works in single precision: a room 0.5 wide placed 1e6
    // from the origin (a site's coordinates) kept 0.06 of its detail, and its image was
    // 27 % off; its tests multiply three coordinates: a room 5.6e13 wide overflowed them
    // (t = inf, then rays from inf: Embree's assertion aborted the run), one 5.6e-28
    // wide underflowed them to nothing (every ray missed).
    Vec3 centre = Vec3::Zero();
    double scale = 1.0;
    ~Impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
};

RayCaster::RayCaster(const Scene& scene, int threads) : impl_(std::make_unique<Impl>()) {
    const std::string config = threads > 0 ? "threads=" + std::to_string(threads) : std::string();
    impl_->device = rtcNewDevice(config.empty() ? nullptr : config.c_str());
    if (!impl_->device)
        throw std::runtime_error("Embree: cannot create a device (error " +
                                 std::to_string(rtcGetDeviceError(nullptr)) + ")");
    impl_->scene = rtcNewScene(impl_->device);
    // Robust traversal: rays through shared edges must not slip between triangles.
    // all_hits() collects every crossing through a per-call filter function.
    rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    const auto& pos = scene.vertex_positions();
    const auto& patches = scene.patch_list();
    if (!pos.empty()) {
        Vec3 lo = pos.front(), hi = lo;
        for (const auto& p : pos) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
        impl_->centre = 0.5 * (lo + hi);
        const double largest = (hi - impl_->centre).cwiseMax(impl_->centre - lo).maxCoeff();
        if (largest > 0.0 && std::isfinite(largest)) impl_->scale = std::ldexp(1.0, std::ilogb(largest) + 1);
    }
    const double to_frame = 1.0 / impl_->scale;
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                           3 * sizeof(float), pos.size()));
    for (std::size_t i = 0; i < pos.size(); ++i)
        for (int k = 0; k < 3; ++k) vb[3 * i + k] = static_cast<float>((pos[i][k] - impl_->centre[k]) * to_frame);
    auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                              3 * sizeof(unsigned), patches.size()));
    for (std::size_t i = 0; i < patches.size(); ++i)
        for (int k = 0; k < 3; ++k) ib[3 * i + k] = static_cast<unsigned>(patches[i].v[k]);
    rtcCommitGeometry(geom);
    rtcAttachGeometry(impl_->scene, geom);
    rtcReleaseGeometry(geom);
    rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
    rtcCommitScene(impl_->scene);
    impl_->two_sided.assign(patches.size(), 0);
    impl_->normals.assign(3 * patches.size(), 0.0f);
    for (std::size_t i = 0; i < patches.size(); ++i)
        if (scene.material_of(i).two_sided) {
            impl_->two_sided[i] = 1;
            impl_->any_two_sided = true;
            for (int k = 0; k < 3; ++k) impl_->normals[3 * i + k] = static_cast<float>(patches[i].normal[k]);
        }
}

RayCaster::~RayCaster() = default;

namespace {

// A ray in Embree's frame (Impl::centre, scale): the origin moved and divided, the
// distances divided. An origin beyond single precision there (1e17 of the scene's size
// away: Embree's assertion refuses it) starts along its ray, 4 sizes before its nearest
// approach to the scene (nothing lies before that): `shift` is how far, in the frame,
// and a ray that passes too far from the scene to meet it is no ray (`meets` false).
struct FrameRay {
    RTCRayHit rh{};
    double shift = 0.0;
    bool meets = true;
};
FrameRay make_ray(const Vec3& org, const Vec3& dir, double t_min, double t_max, const Vec3& centre, double scale) {
    const double to_frame = 1.0 / scale;
    FrameRay r;
    Vec3 o = (org - centre) * to_frame;
    double t_near = t_min * to_frame, t_far = t_max * to_frame;
    if (o.cwiseAbs().maxCoeff() > 1e17) {
        const double length2 = dir.squaredNorm();
        r.shift = std::max(0.0, -o.dot(dir) / length2 - 4.0 / std::sqrt(length2));
        o += r.shift * dir;
        t_near = std::max(0.0, t_near - r.shift);
        t_far -= r.shift;
        r.meets = o.cwiseAbs().maxCoeff() <= 1e17 && t_far >= t_near;
    }
    RTCRayHit& rh = r.rh;
    rh.ray.org_x = static_cast<float>(o.x());
    rh.ray.org_y = static_cast<float>(o.y());
    rh.ray.org_z = static_cast<float>(o.z());
    rh.ray.dir_x = static_cast<float>(dir.x());
    rh.ray.dir_y = static_cast<float>(dir.y());
    rh.ray.dir_z = static_cast<float>(dir.z());
    rh.ray.tnear = static_cast<float>(t_near);
    // (A finite distance past single precision in the frame is no limit: infinity.)
    rh.ray.tfar = t_far >= static_cast<double>(std::numeric_limits<float>::max()) ? std::numeric_limits<float>::infinity()
                                                                                 : static_cast<float>(t_far);
    rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    return r;
}

// An intersect context that records every hit and rejects it, so traversal goes on.
struct CollectContext {
    RTCIntersectContext context;  // first member: Embree hands back a pointer to it
    std::vector<RayHit>* hits;
    double scale, shift;  // Impl::scale, FrameRay::shift
};

void collect_hit(const RTCFilterFunctionNArguments* args) {
    auto* ctx = reinterpret_cast<CollectContext*>(args->context);
    for (unsigned k = 0; k < args->N; ++k) {
        if (args->valid[k] == 0) continue;
        RayHit h;
        h.patch = static_cast<int>(RTCHitN_primID(args->hit, args->N, k));
        h.t = (RTCRayN_tfar(args->ray, args->N, k) + ctx->shift) * ctx->scale;
        h.b1 = RTCHitN_u(args->hit, args->N, k);
        h.b2 = RTCHitN_v(args->hit, args->N, k);
        ctx->hits->push_back(h);
        args->valid[k] = 0;
    }
}

void front_of_two_sided(const RTCFilterFunctionNArguments* args);

// An intersect context that passes over the back of two-sided patches (their twins
// face the ray at the same place); none where the scene has no two-sided patch.
struct FrontContext {
    RTCIntersectContext context;  // first member
    const std::vector<char>* two_sided;
    const std::vector<float>* normals;
    FrontContext(bool any, const std::vector<char>& sided, const std::vector<float>& facing)
        : two_sided(&sided), normals(&facing) {
        rtcInitIntersectContext(&context);
        if (any) context.filter = front_of_two_sided;
    }
};

void front_of_two_sided(const RTCFilterFunctionNArguments* args) {
    const auto* ctx = reinterpret_cast<const FrontContext*>(args->context);
    for (unsigned k = 0; k < args->N; ++k) {
        if (args->valid[k] == 0) continue;
        const unsigned prim = RTCHitN_primID(args->hit, args->N, k);
        if (!(*ctx->two_sided)[prim]) continue;
        const float* n = &(*ctx->normals)[3 * prim];
        const float facing = n[0] * RTCRayN_dir_x(args->ray, args->N, k) + n[1] * RTCRayN_dir_y(args->ray, args->N, k) +
                             n[2] * RTCRayN_dir_z(args->ray, args->N, k);
        if (facing > 0.0f) args->valid[k] = 0;
    }
}

}  // namespace

bool RayCaster::occluded(const Vec3& org, const Vec3& dir, double t_min, double t_max) const {
    // The filter intersect() uses: a hit is the same hit here, so the answer is its.
    FrontContext ctx(impl_->any_two_sided, impl_->two_sided, impl_->normals);
    FrameRay r = make_ray(org, dir, t_min, t_max, impl_->centre, impl_->scale);
    if (!r.meets) return false;
    rtcOccluded1(impl_->scene, &ctx.context, &r.rh.ray);
    return r.rh.ray.tfar < 0.0f;  // -inf where a hit was found
}

void RayCaster::all_hits(const Vec3& org, const Vec3& dir, std::vector<RayHit>& hits, double t_min,
                         double t_max) const {
    hits.clear();
    CollectContext ctx;
    rtcInitIntersectContext(&ctx.context);
    ctx.context.filter = collect_hit;
    ctx.hits = &hits;
    FrameRay r = make_ray(org, dir, t_min, t_max, impl_->centre, impl_->scale);
    if (!r.meets) return;
    ctx.scale = impl_->scale;
    ctx.shift = r.shift;
    rtcIntersect1(impl_->scene, &ctx.context, &r.rh);
    std::sort(hits.begin(), hits.end(), [](const RayHit& a, const RayHit& b) {
        return a.t < b.t || (a.t == b.t && a.patch < b.patch);
    });
    // A BVH with spatial splits may reference a triangle from several leaves.
    hits.erase(std::unique(hits.begin(), hits.end(),
                           [](const RayHit& a, const RayHit& b) { return a.patch == b.patch && a.t == b.t; }),
               hits.end());
}

RayHit RayCaster::intersect(const Vec3& org, const Vec3& dir, double t_min, double t_max) const {
    FrontContext ctx(impl_->any_two_sided, impl_->two_sided, impl_->normals);
    FrameRay r = make_ray(org, dir, t_min, t_max, impl_->centre, impl_->scale);
    RayHit hit;
    if (!r.meets) return hit;
    RTCRayHit& rh = r.rh;
    rtcIntersect1(impl_->scene, &ctx.context, &rh);
    if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
        hit.patch = static_cast<int>(rh.hit.primID);
        hit.t = (rh.ray.tfar + r.shift) * impl_->scale;
        hit.b1 = rh.hit.u;
        hit.b2 = rh.hit.v;
    }
    return hit;
}

}  // namespace raybundle::scenes
