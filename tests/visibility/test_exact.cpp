// Exact visibility on scenes modelled as people model them: surfaces that touch,
// nearly touch, lie on each other or cross. Every exact backend against the exact
// arrangement, entry by entry within its pixel noise; the solved radiance against
// ray casting; the exact painter against the global z-buffer pixel for pixel, with
// both of its inner loops; the centre-sorted painter shown to fail where it must.
#include "sampling/directions.h"
#include "scenes/builtin.h"
#include "scenes/diagnostics.h"
#include "scenes/loader.h"
#include "solver/solver.h"
#include "visibility/backend.h"
#include "visibility/exact_painter.h"
#include "visibility/exact_spans.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

using namespace raybundle;
using scenes::Vec3;

namespace {

// JSON for a quad with corners a, b, c, d (in order round it) facing `normal`.
std::string quad(Vec3 a, Vec3 b, Vec3 c, Vec3 d, const Vec3& normal, const std::string& material) {
    if ((b - a).cross(c - a).dot(normal) < 0) std::swap(b, d);
    std::ostringstream s;
    s.precision(17);
    s << R"({"quad": [)";
    const Vec3 corners[4] = {a, b, c, d};
    for (int k = 0; k < 4; ++k)
        s << (k ? "," : "") << '[' << corners[k].x() << ',' << corners[k].y() << ',' << corners[k].z() << ']';
    s << R"(], "material": ")" << material << "\"}";
    return s.str();
}

// The six faces of the box [lo, hi], facing out (or in, for a room).
std::string box(const Vec3& lo, const Vec3& hi, const std::string& material, bool inward = false) {
    std::string out;
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
            const int u = (axis + 1) % 3, v = (axis + 2) % 3;
            Vec3 c[4];
            for (int k = 0; k < 4; ++k) {
                c[k][axis] = side ? hi[axis] : lo[axis];
                c[k][u] = (k == 1 || k == 2) ? hi[u] : lo[u];
                c[k][v] = (k >= 2) ? hi[v] : lo[v];
            }
            Vec3 normal = Vec3::Zero();
            normal[axis] = (side ? 1.0 : -1.0) * (inward ? -1.0 : 1.0);
            out += (out.empty() ? "" : ",") + quad(c[0], c[1], c[2], c[3], normal, material);
        }
    return out;
}

// The unit room (walls facing in, albedo 0.5) with a light panel hanging 1e-4 below its
// full ceiling, and `extra` objects; not cut at the contacts (scenes/contacts.h), so
// that the backends meet patches that overlap, touch and cross.
scenes::Scene room(const std::string& extra, const std::string& name) {
    const std::string text = R"({
      "camera": {"eye": [0.5, 0.5, 0.05], "target": [0.5, 0.5, 1]},
      "materials": {"wall": {"albedo": [0.5, 0.5, 0.5]}, "lamp": {"albedo": [0.5, 0.5, 0.5], "emission": [4, 4, 4]},
                    "red": {"albedo": [0.8, 0.2, 0.1]}, "green": {"albedo": [0.1, 0.7, 0.2]}},
      "patch_size": 0.125, "cut_contacts": false,
      "objects": [)" + box(Vec3(0, 0, 0), Vec3(1, 1, 1), "wall", true) +
                             "," + quad(Vec3(0.35, 1 - 1e-4, 0.35), Vec3(0.65, 1 - 1e-4, 0.35),
                                        Vec3(0.65, 1 - 1e-4, 0.65), Vec3(0.35, 1 - 1e-4, 0.65), Vec3(0, -1, 0), "lamp") +
                             (extra.empty() ? "" : "," + extra) + "]}";
    return scenes::parse_scene(text, name + ".json", ".");
}

// The scenes of the issue: each one a way surfaces meet in real models.
std::vector<std::pair<std::string, scenes::Scene>> contact_scenes() {
    std::vector<std::pair<std::string, scenes::Scene>> s;
    s.emplace_back("light panel 1e-4 below a full ceiling", room("", "panel"));
    s.emplace_back("a box (with its bottom face) standing on a full floor",
                   room(box(Vec3(0.3, 0, 0.3), Vec3(0.6, 0.4, 0.6), "red"), "block"));
    s.emplace_back("a decal 1e-5 in front of a wall",
                   room(quad(Vec3(1e-5, 0.3, 0.3), Vec3(1e-5, 0.6, 0.3), Vec3(1e-5, 0.6, 0.6), Vec3(1e-5, 0.3, 0.6),
                             Vec3(1, 0, 0), "red"),
                        "decal"));
    s.emplace_back("two interpenetrating boxes",
                   room(box(Vec3(0.2, 0.1, 0.2), Vec3(0.55, 0.5, 0.55), "red") + "," +
                            box(Vec3(0.4, 0.3, 0.4), Vec3(0.75, 0.7, 0.75), "green"),
                        "crossing"));
    s.emplace_back("two boxes 1e-4 apart",
                   room(box(Vec3(0.2, 0, 0.3), Vec3(0.5, 0.4, 0.6), "red") + "," +
                            box(Vec3(0.5 + 1e-4, 0, 0.3), Vec3(0.8, 0.4, 0.6), "green"),
                        "gap"));
    return s;
}

bool built(const std::string& name) {
    const auto names = visibility::backend_names();
    return std::find(names.begin(), names.end(), name) != names.end();
}

using Key = std::pair<std::uint32_t, std::uint32_t>;

// Per entry: the mean over jitters and its standard error.
struct Averaged {
    std::map<Key, std::pair<double, double>> entries;  // mean, standard error
    double pixel_area = 0.0;
};

Averaged jitter_average(visibility::Backend& backend, const Vec3& w, int jitters, std::uint64_t seed, double pixel_area) {
    sampling::Rng rng(seed);
    std::map<Key, std::pair<double, double>> sums;  // sum, sum of squares
    visibility::GeometryMatrix g;
    for (int s = 0; s < jitters; ++s) {
        backend.transfer(w, {rng.uniform(), rng.uniform()}, g);
        for (const auto& e : g.entries) {
            auto& [sum, sq] = sums[{e.receiver, e.source}];
            sum += e.area;
            sq += e.area * e.area;
        }
    }
    Averaged a;
    a.pixel_area = pixel_area;
    for (const auto& [k, s] : sums) {
        const double mean = s.first / jitters;
        const double var = std::max(0.0, s.second / jitters - mean * mean) * jitters / (jitters - 1.0);
        a.entries[k] = {mean, std::sqrt(var / jitters)};
    }
    return a;
}

// Entry by entry against exact values: z = (mean - exact) / standard error, the error
// floored at one pixel over sqrt(jitters) (an entry a few jitters miss). Returns the
// mean of z^2 (about 1 within pixel noise) and the largest |z|.
std::pair<double, double> z_scores(const Averaged& a, const std::map<Key, double>& exact, int jitters) {
    std::map<Key, std::pair<double, double>> all = a.entries;
    for (const auto& [k, v] : exact) all.emplace(k, std::make_pair(0.0, 0.0));
    const double floor = a.pixel_area / std::sqrt(static_cast<double>(jitters));
    double sum = 0.0, worst = 0.0;
    for (const auto& [k, m] : all) {
        const auto it = exact.find(k);
        const double e = it == exact.end() ? 0.0 : it->second;
        const double z = (m.first - e) / std::hypot(m.second, floor);
        sum += z * z;
        worst = std::max(worst, std::abs(z));
    }
    return {sum / static_cast<double>(all.size()), worst};
}

std::map<Key, double> matrix(visibility::Backend& backend, const Vec3& w) {
    visibility::GeometryMatrix g;
    backend.transfer(w, {0.5, 0.5}, g);
    std::map<Key, double> m;
    for (const auto& e : g.entries) m[{e.receiver, e.source}] += e.area;
    return m;
}

}  // namespace

TEST_CASE("the default backend is an exact one", "[visibility][exact]") {
    const auto& info = visibility::backend_info(visibility::kDefaultBackend);
    CHECK(info.exact);
    CHECK(visibility::backend_names().front() == visibility::kDefaultBackend);
    CHECK_FALSE(visibility::backend_info("painter").exact);
}

#ifdef RAYBUNDLE_HAVE_CGAL
// (Without CGAL there is no exact matrix to compare with: this case is not compiled;
// the others compare the exact backends with each other.)
TEST_CASE("contact scenes: every exact backend matches the arrangement within pixel noise", "[visibility][exact]") {
    REQUIRE(built("arrangement"));
    constexpr int kJitters = 32, kResolution = 160;
    sampling::RandomDirections dirs(17);
    std::vector<Vec3> directions;
    for (int d = 0; d < 3; ++d) directions.push_back(dirs.next());
    directions.push_back(Vec3(0.2, -0.95, 0.24).normalized());  // light going down, nearly vertical
    for (auto& [what, scene] : contact_scenes()) {
        auto exact = visibility::make_backend("arrangement", scene, {});
        std::vector<std::map<Key, double>> reference;
        for (const auto& w : directions) reference.push_back(matrix(*exact, w));
        for (const auto& info : visibility::backend_infos()) {
            if (!info.discrete) continue;
            visibility::BackendOptions opt;
            opt.resolution = kResolution;
            auto backend = visibility::make_backend(info.name, scene, opt);
            const double pixel = 2.0 * scene.bounds_radius() / kResolution;
            double worst_mean = 0.0;
            for (std::size_t d = 0; d < directions.size(); ++d) {
                const auto a = jitter_average(*backend, directions[d], kJitters, 300 + d, pixel * pixel);
                const auto [mean_z2, max_z] = z_scores(a, reference[d], kJitters);
                worst_mean = std::max(worst_mean, mean_z2);
                if (info.exact) {
                    INFO(what << ": " << info.name << ", direction " << d << ": mean z^2 " << mean_z2 << ", max |z| "
                              << max_z);
                    CHECK(mean_z2 < 2.0);
                    CHECK(max_z < 8.0);
                }
            }
            if (info.name == "painter" && what.rfind("light panel", 0) == 0) {
                // The centre-sorted painter puts ceiling patches in front of the panel.
                INFO(what << ": the painter's worst mean z^2 " << worst_mean);
                CHECK(worst_mean > 20.0);
            }
        }
    }
}
#endif

TEST_CASE("contact scenes: every exact backend solves the radiance ray casting does", "[visibility][exact][solver]") {
    // The same seed: the same directions and jitters for every backend, so the runs
    // differ only where the matrices do. (The arrangement costs ~0.2 s a direction
    // here: it runs fewer steps, against ray casting with as many.)
    auto mean_radiance = [](const scenes::Scene& scene, const std::string& backend_name, long steps) {
        const solver::Transport transport(scene);
        solver::SolverOptions options;
        options.visibility = backend_name;
        options.map.resolution = 160;
        options.steps = steps;
        sampling::RunOptions run;
        run.seed = 11;
        const auto solve = solver::make_solver(transport, options, run);
        solve->run();
        return solve->field().mean_radiance(scene);
    };
    for (auto& [what, scene] : contact_scenes()) {
        std::map<long, double> raycast;
        for (const auto& info : visibility::backend_infos()) {
            if (!info.exact || info.name == "raycast") continue;
            const long steps = info.discrete ? 200 : 16;
            if (!raycast.count(steps)) raycast[steps] = mean_radiance(scene, "raycast", steps);
            const double m = mean_radiance(scene, info.name, steps);
            INFO(what << ": " << info.name << " " << m << " against raycast " << raycast[steps] << " (" << steps
                      << " steps)");
            CHECK(m == Approx(raycast[steps]).epsilon(0.005));
        }
    }
}

// Scenes on which exact per-pixel backends must agree pixel for pixel: the Cornell box
// refined, the homogeneous box, the contact scenes, and a soup of random triangles
// crossing each other everywhere (not cut at the crossings): deep misorders.
static std::vector<std::pair<std::string, scenes::Scene>> pixel_exact_scenes() {
    std::vector<std::pair<std::string, scenes::Scene>> scenes;
    scenes.emplace_back("cornell-box", scenes::make_builtin("cornell-box", 100.0));
    scenes.emplace_back("homogeneous-box", scenes::make_builtin("homogeneous-box", 0.25));
    for (auto& s : contact_scenes()) scenes.push_back(std::move(s));
    {
        sampling::Rng rng(99);
        std::string objects;
        for (int t = 0; t < 300; ++t) {
            const Vec3 c(rng.uniform(), rng.uniform(), rng.uniform());
            std::ostringstream o;
            o.precision(17);
            o << R"({"triangle": [)";
            for (int k = 0; k < 3; ++k) {
                const Vec3 p = c + 0.3 * Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5);
                o << (k ? "," : "") << '[' << p.x() << ',' << p.y() << ',' << p.z() << ']';
            }
            o << R"(], "material": "m"})";
            objects += (objects.empty() ? "" : ",") + o.str();
        }
        scenes.emplace_back("random triangles",
                            scenes::parse_scene(R"({"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0]},
              "cut_contacts": false, "patch_size": "none", "materials": {"m": {"albedo": [0.5, 0.5, 0.5]}}, "objects": [)" + objects + "]}",
                                                "soup.json", "."));
    }
    return scenes;
}

TEST_CASE("the exact painter gives the global z-buffer's matrix, pixel for pixel", "[visibility][exact]") {
    // Both order each pixel's surfaces by exact depth; they share the map's grid and
    // scan conversion, so their matrices agree but for depths that tie within 2e-9 of
    // the scene's radius (a few pixels where surfaces cross, at most).
    auto scenes = pixel_exact_scenes();
    std::size_t inserted = 0, listed = 0;
    for (const bool sky : {false, true})
        for (auto& [what, scene] : scenes) {
            visibility::BackendOptions opt;
            opt.resolution = 200;
            opt.sky = sky;
            auto reference = visibility::make_backend("global-zbuffer", scene, opt);
            auto painter = visibility::make_backend("exact-painter", scene, opt);
            auto& exact = dynamic_cast<visibility::ExactPainterBackend&>(*painter);
            sampling::RandomDirections dirs(5);
            sampling::Rng jitter(6);
            const double pixel_area = std::pow(2.0 * scene.bounds_radius() / opt.resolution, 2);
            for (int d = 0; d < 6; ++d) {
                const Vec3 w = dirs.next();
                const Eigen::Vector2d j(jitter.uniform(), jitter.uniform());
                visibility::GeometryMatrix expected;
                reference->transfer(w, j, expected);
                std::map<Key, double> want;
                for (const auto& e : expected.entries) want[{e.receiver, e.source}] += e.area;
                for (const auto* kernels : {&visibility::best_span_kernels(), &visibility::portable_span_kernels()}) {
                    exact.use_kernels(*kernels);
                    visibility::GeometryMatrix got;
                    painter->transfer(w, j, got);
                    std::map<Key, double> have;
                    for (const auto& e : got.entries) {
                        INFO(what << ": pair " << e.receiver << ", " << e.source << " twice");
                        CHECK(have.count({e.receiver, e.source}) == 0);
                        have[{e.receiver, e.source}] += e.area;
                    }
                    double differing = 0.0;  // pixels
                    for (auto [k, v] : want) differing += std::abs(v - (have.count(k) ? have[k] : 0.0)) / pixel_area;
                    for (auto [k, v] : have)
                        if (!want.count(k)) differing += v / pixel_area;
                    INFO(what << (sky ? " with sky" : "") << ", direction " << d << ", " << kernels->name
                              << " kernels: " << differing << " pixel pairs differ");
                    CHECK(differing <= 4.0);
                    inserted += exact.repairs().inserted;
                    listed += exact.repairs().listed;
                }
            }
        }
    // Both repairs ran: insertion between occupant and predecessor, and marked pixels.
    CHECK(inserted > 1000);
    CHECK(listed > 100);
}

// By how many pixel pairs two matrices of one map differ, and how many the first has.
static std::pair<double, double> pixel_difference(const visibility::GeometryMatrix& expected,
                                                  const visibility::GeometryMatrix& got, double pixel_area) {
    std::map<Key, double> want, have;
    double total = 0.0, differing = 0.0;
    for (const auto& e : expected.entries) {
        want[{e.receiver, e.source}] += e.area;
        total += e.area / pixel_area;
    }
    for (const auto& e : got.entries) have[{e.receiver, e.source}] += e.area;
    for (const auto& [k, v] : want) differing += std::abs(v - (have.count(k) ? have[k] : 0.0)) / pixel_area;
    for (const auto& [k, v] : have)
        if (!want.count(k)) differing += v / pixel_area;
    return {differing, total};
}

TEST_CASE("the GPU z-buffer gives the global z-buffer's matrix, pixel for pixel", "[visibility][exact][zbuffer]") {
    // The z-buffer peels every surface over each pixel centre and orders them by the
    // global z-buffer's own double-precision depths and tie rule: the same pairs. Only
    // which of two triangles owns a pixel centre lying exactly on their shared edge is
    // the rasteriser's rule rather than raster.h's, so a few pixels may move between
    // neighbours; the matrices must agree to 0.2 % of their pixels.
    if (!built("zbuffer")) {
        WARN("this build has no zbuffer backend: nothing to compare");
        return;
    }
    auto scenes = pixel_exact_scenes();
    for (const bool sky : {false, true})
        for (auto& [what, scene] : scenes) {
            visibility::BackendOptions opt;
            opt.resolution = 200;
            opt.sky = sky;
            auto reference = visibility::make_backend("global-zbuffer", scene, opt);
            auto zbuffer = visibility::make_backend("zbuffer", scene, opt);
            sampling::RandomDirections dirs(5);
            sampling::Rng jitter(6);
            const double pixel_area = std::pow(2.0 * scene.bounds_radius() / opt.resolution, 2);
            for (int d = 0; d < 4; ++d) {
                const Vec3 w = dirs.next();
                const Eigen::Vector2d j(jitter.uniform(), jitter.uniform());
                visibility::GeometryMatrix expected, got;
                reference->transfer(w, j, expected);
                zbuffer->transfer(w, j, got);
                bool ordered = true;  // one entry per pair, by receiver then source
                for (std::size_t k = 1; k < got.entries.size(); ++k) {
                    const auto &p = got.entries[k - 1], &e = got.entries[k];
                    ordered = ordered && (p.receiver < e.receiver || (p.receiver == e.receiver && p.source < e.source));
                }
                const auto [differing, total] = pixel_difference(expected, got, pixel_area);
                INFO(what << (sky ? " with sky" : "") << ", direction " << d << ": " << differing << " of " << total
                          << " pixel pairs differ");
                CHECK(ordered);
                CHECK(differing <= 4.0 + 0.002 * total);
            }
        }
}

TEST_CASE("the GPU z-buffer at the largest map (2048 pixels a side) agrees with the global z-buffer", "[visibility][zbuffer]") {
    // Over 4 million pixels: more compute groups than one dispatch dimension takes.
    if (!built("zbuffer")) {
        WARN("this build has no zbuffer backend: nothing to compare");
        return;
    }
    const auto scene = scenes::make_builtin("homogeneous-box", 0.5);
    visibility::BackendOptions opt;
    opt.resolution = 2048;
    auto reference = visibility::make_backend("global-zbuffer", scene, opt);
    auto zbuffer = visibility::make_backend("zbuffer", scene, opt);
    const Vec3 w = Vec3(0.3, -0.5, 0.81).normalized();
    visibility::GeometryMatrix expected, got;
    reference->transfer(w, {0.4, 0.6}, expected);
    zbuffer->transfer(w, {0.4, 0.6}, got);
    const double pixel_area = std::pow(2.0 * scene.bounds_radius() / opt.resolution, 2);
    const auto [differing, total] = pixel_difference(expected, got, pixel_area);
    INFO(differing << " of " << total << " pixel pairs differ");
    CHECK(total > 1e6);
    CHECK(differing <= 4.0 + 0.002 * total);
}

TEST_CASE("the GPU z-buffer: the same seed gives the same matrix, whatever the hash table's history", "[visibility][zbuffer]") {
    // The GPU counts pairs in a hash table whose slots depend on its threads' timing;
    // the entries come back sorted. A backend that has drawn other directions first (its
    // table and layer buffer as they left them) gives what a fresh one gives, bit for bit.
    if (!built("zbuffer")) {
        WARN("this build has no zbuffer backend: nothing to compare");
        return;
    }
    const auto scene = scenes::make_builtin("cornell-box", 100.0);
    visibility::BackendOptions opt;
    opt.resolution = 300;
    auto first = visibility::make_backend("zbuffer", scene, opt);
    auto second = visibility::make_backend("zbuffer", scene, opt);
    sampling::RandomDirections dirs(3);
    visibility::GeometryMatrix a, b;
    for (int d = 0; d < 5; ++d) first->transfer(dirs.next(), {0.3, 0.7}, a);  // history for `first`
    const Vec3 w = dirs.next();
    first->transfer(w, {0.25, 0.5}, a);
    second->transfer(w, {0.25, 0.5}, b);
    REQUIRE(a.entries.size() == b.entries.size());
    REQUIRE(!a.entries.empty());
    for (std::size_t k = 0; k < a.entries.size(); ++k) {
        CHECK(a.entries[k].receiver == b.entries[k].receiver);
        CHECK(a.entries[k].source == b.entries[k].source);
        CHECK(a.entries[k].area == b.entries[k].area);
    }
}

TEST_CASE("the GPU z-buffer: a batch gives the matrices one direction at a time gives", "[visibility][zbuffer]") {
    // transfer_many submits up to 16 directions at once, prepares and sorts them on the
    // caller's threads and runs `alongside` while the GPU works. 40 directions (three
    // submissions, the last one short) must give, bit for bit, what a fresh backend's
    // transfer() gives for each; a stack of 12 quads over the Cornell box's floor passes
    // the 8 surfaces a pixel the layer buffer first holds, so the batch also runs the
    // directions the GPU could not finish again, alone, with the buffer grown.
    if (!built("zbuffer")) {
        WARN("this build has no zbuffer backend: nothing to compare");
        return;
    }
    std::string objects;
    for (int k = 0; k < 12; ++k) {
        const double z = 0.05 * k;
        objects += (objects.empty() ? "" : ",") + quad(Vec3(0, 0, z), Vec3(1, 0, z), Vec3(1, 1, z), Vec3(0, 1, z),
                                                       Vec3(0, 0, 1), "m");
    }
    const auto stack = scenes::parse_scene(R"({"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0]},
        "patch_size": 0.25, "materials": {"m": {"albedo": [0.5, 0.5, 0.5]}}, "objects": [)" + objects + "]}",
                                           "stack.json", ".");
    for (const scenes::Scene* scene : {&stack, static_cast<const scenes::Scene*>(nullptr)}) {
        const auto box = scenes::make_builtin("cornell-box", 100.0);
        const scenes::Scene& s = scene ? *scene : box;
        INFO((scene ? "stacked quads" : "Cornell box"));
        visibility::BackendOptions opt;
        opt.resolution = 96;
        opt.sky = scene != nullptr;
        sampling::RandomDirections dirs(11);
        std::vector<Vec3> ws;
        std::vector<Eigen::Vector2d> jitters;
        for (int d = 0; d < 40; ++d) {
            ws.push_back(d % 5 == 0 ? Vec3(0, 0, d % 10 == 0 ? 1 : -1) : dirs.next());  // along the stack too
            jitters.emplace_back(0.05 + 0.9 * ((d * 7) % 13) / 13.0, 0.05 + 0.9 * ((d * 5) % 11) / 11.0);
        }
        auto batched = visibility::make_backend("zbuffer", s, opt);
        std::vector<visibility::GeometryMatrix> got;
        int along = 0;
        batched->transfer_many(ws, jitters, got, 3, [&] { ++along; });
        CHECK(along == 1);
        REQUIRE(got.size() == ws.size());
        auto single = visibility::make_backend("zbuffer", s, opt);
        bool same = true;
        std::size_t entries = 0;
        for (std::size_t d = 0; d < ws.size(); ++d) {
            visibility::GeometryMatrix expected;
            single->transfer(ws[d], jitters[d], expected);
            same = same && got[d].direction == ws[d] && got[d].entries.size() == expected.entries.size();
            for (std::size_t k = 0; same && k < expected.entries.size(); ++k)
                same = got[d].entries[k].receiver == expected.entries[k].receiver &&
                       got[d].entries[k].source == expected.entries[k].source &&
                       got[d].entries[k].area == expected.entries[k].area;
            entries += expected.entries.size();
        }
        CHECK(same);
        CHECK(entries > 40);
        // A batch of one goes through transfer()'s own buffers.
        std::vector<visibility::GeometryMatrix> one;
        batched->transfer_many({ws[3]}, {jitters[3]}, one, 3, [&] { ++along; });
        CHECK(along == 2);
        REQUIRE(one.size() == 1);
        CHECK(one[0].entries.size() == got[3].entries.size());
    }
}

TEST_CASE("the GPU z-buffer: more than 64 surfaces over one pixel is a clear error", "[visibility][zbuffer]") {
    // 70 parallel quads stacked along z: every pixel under them holds 70 surfaces,
    // more than the pairing pass orders; the error says so and names a backend that
    // has no such limit.
    if (!built("zbuffer")) {
        WARN("this build has no zbuffer backend: nothing to check");
        return;
    }
    std::string objects;
    for (int k = 0; k < 70; ++k) {
        const double z = 0.01 * k;
        objects += (objects.empty() ? "" : ",") + quad(Vec3(0, 0, z), Vec3(1, 0, z), Vec3(1, 1, z), Vec3(0, 1, z),
                                                       Vec3(0, 0, 1), "m");
    }
    const auto scene = scenes::parse_scene(R"({"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0]},
        "patch_size": "none", "materials": {"m": {"albedo": [0.5, 0.5, 0.5]}}, "objects": [)" + objects + "]}",
                                           "stack.json", ".");
    visibility::BackendOptions opt;
    opt.resolution = 32;
    auto zbuffer = visibility::make_backend("zbuffer", scene, opt);
    visibility::GeometryMatrix m;
    try {
        zbuffer->transfer(Vec3(0, 0, 1), {0.5, 0.5}, m);
        FAIL("no error for 70 surfaces over one pixel");
    } catch (const std::runtime_error& e) {
        const std::string what = e.what();
        INFO(what);
        CHECK(what.find("70 surfaces over one pixel") != std::string::npos);
        CHECK(what.find("exact-painter") != std::string::npos);
    }
}

TEST_CASE("coplanar overlapping patches facing the same way are found", "[visibility][exact][scenes]") {
    // A decal exactly on the wall overlaps it; one 1e-5 in front of it does not; nor do
    // a mesh's own neighbouring patches, which only share edges.
    const auto on = room(quad(Vec3(0, 0.3, 0.3), Vec3(0, 0.6, 0.3), Vec3(0, 0.6, 0.6), Vec3(0, 0.3, 0.6),
                              Vec3(1, 0, 0), "red"),
                         "on");
    const auto off = contact_scenes()[2].second;
    const auto found = scenes::coplanar_overlaps(on);
    CHECK(found.pairs > 0);
    CHECK(on.material_of(found.first).name != on.material_of(found.second).name);  // the decal and the wall
    CHECK(scenes::coplanar_overlaps(off).pairs == 0);
    CHECK(scenes::coplanar_overlaps(scenes::make_builtin("cornell-box")).pairs == 0);
    // Ties are decided the same way for every jitter and thread: by patch index.
    visibility::BackendOptions opt;
    opt.resolution = 128;
    auto a = visibility::make_backend("exact-painter", on, opt), b = visibility::make_backend("exact-painter", on, opt);
    visibility::GeometryMatrix ma, mb;
    a->transfer(Vec3(-0.6, 0.3, 0.74).normalized(), {0.3, 0.8}, ma);
    b->transfer(Vec3(-0.6, 0.3, 0.74).normalized(), {0.3, 0.8}, mb);
    REQUIRE(ma.entries.size() == mb.entries.size());
    for (std::size_t k = 0; k < ma.entries.size(); ++k) {
        CHECK(ma.entries[k].receiver == mb.entries[k].receiver);
        CHECK(ma.entries[k].area == mb.entries[k].area);
    }
}
