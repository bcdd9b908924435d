// The ray caster (scenes/ray_caster.h) at any scale: Embree works in single precision,
// so the caster hands it the scene divided by a power of two near its size.
#include "scenes/ray_caster.h"
#include "scenes/scene.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

using namespace raybundle;
using scenes::Vec3;

namespace {

// A closed room 5.6 x 5.5 x 5.6 (times k, moved by `at`) with a block on its floor,
// fronts inward.
scenes::Scene room(double k, const Vec3& at = Vec3::Zero()) {
    scenes::Scene s;
    scenes::Material m;
    m.albedo = scenes::Rgb(0.5, 0.5, 0.5);
    const int w = s.add_material(m);
    auto quad = [&](Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
        s.add_object({a * k + at, b * k + at, c * k + at, d * k + at}, {{0, 1, 2}, {0, 2, 3}}, w);
    };
    const double X = 5.56, Y = 5.48, Z = 5.59;
    quad({0, 0, 0}, {0, 0, Z}, {X, 0, Z}, {X, 0, 0});          // floor
    quad({0, Y, 0}, {X, Y, 0}, {X, Y, Z}, {0, Y, Z});          // ceiling
    quad({0, 0, Z}, {0, Y, Z}, {X, Y, Z}, {X, 0, Z});          // back
    quad({0, 0, 0}, {X, 0, 0}, {X, Y, 0}, {0, Y, 0});          // front
    quad({0, 0, 0}, {0, Y, 0}, {0, Y, Z}, {0, 0, Z});          // left
    quad({X, 0, 0}, {X, 0, Z}, {X, Y, Z}, {X, Y, 0});          // right
    quad({1.3, 1.65, 0.65}, {1.3, 1.65, 2.3}, {2.95, 1.65, 2.3}, {2.95, 1.65, 0.65});  // a block's top
    s.finalize();
    return s;
}

// Ray i of a fixed set: a direction spread over the sphere, and a point inside the room.
Vec3 direction(int i) {
    const double u = std::fmod(0.618034 * i, 1.0), v = std::fmod(0.414214 * i + 0.3, 1.0);
    const double z = 1.0 - 2.0 * u, r = std::sqrt(1.0 - z * z), a = 2.0 * M_PI * v;
    return {r * std::cos(a), r * std::sin(a), z};
}
Vec3 inside(int i) {
    return {0.5 + 4.5 * std::fmod(0.7548776 * i, 1.0), 0.2 + 5.0 * std::fmod(0.5698403 * i, 1.0),
            0.5 + 4.5 * std::fmod(0.1234567 * i + 0.5, 1.0)};
}

}  // namespace

TEST_CASE("ray caster: the same hits at any scale, from 1e-28 to 1e15", "[scenes][raycast]") {
    // 2,000 rays from inside the room. At a power-of-two scale the hits are the same
    // bit for bit (the frame is exact); at others the same patches at distances within
    // 1e-5 of the room's size (single precision). Before the frame, a room 5.6e13 wide overflowed Embree's tests
    // (infinite distances, then an assertion's abort), and one 5.6e-28 wide underflowed
    // them: every ray missed.
    const scenes::Scene one = room(1.0);
    const scenes::RayCaster base(one);
    std::vector<Vec3> from, dir;
    for (int i = 0; i < 2000; ++i) {
        from.push_back(inside(i));
        dir.push_back(direction(i));
    }
    for (const double k : {0x1p40, 0x1p-90, 1e13, 1e15, 1e-28, 1e-6}) {
        INFO("scale " << k);
        const scenes::Scene scaled = room(k);
        const scenes::RayCaster caster(scaled);
        const bool exact = std::ilogb(k) == std::log2(k);
        int same = 0, missed = 0;
        double worst = 0.0;
        for (std::size_t i = 0; i < from.size(); ++i) {
            const auto a = base.intersect(from[i], dir[i]);
            const auto b = caster.intersect(from[i] * k, dir[i]);
            missed += b.valid() ? 0 : 1;
            if (a.patch != b.patch) continue;
            ++same;
            worst = std::max(worst, std::abs(b.t / k - a.t));
            if (exact) {
                CHECK(b.t / k == a.t);
                CHECK(b.b1 == a.b1);
                CHECK(b.b2 == a.b2);
            }
        }
        CHECK(missed == 0);
        CHECK(same >= (exact ? 2000 : 1990));  // elsewhere rounding may pick the neighbour across an edge
        CHECK(worst < 1e-5 * 9.6);  // 1e-5 of the room's diagonal: single precision's rounding, a few times over
    }
}

TEST_CASE("ray caster: the same hits far from the origin", "[scenes][raycast]") {
    // The room moved 1e6 and 1e9 away (a site's coordinates): Embree's frame is centred
    // on the scene. Before, at 1e6 its single-precision corners were 0.06 apart, and an
    // image of a room 0.5 wide was 27 % off.
    const scenes::Scene one = room(1.0);
    const scenes::RayCaster base(one);
    for (const double away : {1e6, 1e9}) {
        INFO("moved " << away);
        const Vec3 at(away, -0.5 * away, away);
        const scenes::Scene moved = room(1.0, at);
        const scenes::RayCaster caster(moved);
        int same = 0;
        double worst = 0.0;
        for (int i = 0; i < 2000; ++i) {
            const Vec3 from = inside(i), dir = direction(i);
            const auto h0 = base.intersect(from, dir);
            const auto h1 = caster.intersect(from + at, dir);
            if (h0.patch != h1.patch) continue;
            ++same;
            worst = std::max(worst, std::abs(h1.t - h0.t));
        }
        CHECK(same >= 1990);
        CHECK(worst < 1e-5 * 9.6);  // 1e-5 of the room's diagonal: single precision's rounding, a few times over
    }
}

TEST_CASE("ray caster: an origin beyond single precision of the scene's frame", "[scenes][raycast]") {
    // Rays from 1e20 away (2e19 of the room's size: past what a float holds in Embree's
    // frame, whose assertion then aborted the run) are answered: a miss where they pass
    // far from the room. (Where they are aimed at it, double precision itself has lost
    // the aim: 1e20 is held to 16384. They may hit or miss, but they do not abort.)
    const scenes::Scene s = room(1.0);
    const scenes::RayCaster caster(s);
    const Vec3 centre(2.78, 2.74, 2.795);
    int answered = 0;
    for (int i = 0; i < 200; ++i) {
        const Vec3 dir = direction(i);
        const Vec3 far = centre - 1e20 * dir, aside = far + 1e19 * dir.unitOrthogonal();
        const auto aimed = caster.intersect(far, dir);
        answered += aimed.patch < static_cast<int>(s.patch_count()) ? 1 : 0;
        CHECK_FALSE(caster.intersect(aside, dir).valid());
        CHECK_FALSE(caster.occluded(aside, dir, 0.0, 2e20));
        std::vector<scenes::RayHit> hits;
        caster.all_hits(aside, dir, hits);
        CHECK(hits.empty());
    }
    CHECK(answered == 200);
}
