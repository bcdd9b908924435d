// The global painter's backend and its scan converter against exact answers.
#include "sampling/directions.h"
#include "scenes/builtin.h"
#include "scenes/loader.h"
#include "visibility/backend.h"
#include "visibility/raster.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace raybundle;
using scenes::Vec3;

TEST_CASE("scan conversion of a perturbed mesh covers every pixel centre exactly once", "[visibility][raster]") {
    // Also far from the origin, where a 16384-pixel map puts its last tiles.
    const int offset = GENERATE(0, 16000);
    const int W = 256, N = 24;
    const double lo = 10.0, hi = 240.0, cell = (hi - lo) / N;
    sampling::Rng rng(42);
    std::vector<double> gx((N + 1) * (N + 1)), gy((N + 1) * (N + 1));
    for (int j = 0; j <= N; ++j)
        for (int i = 0; i <= N; ++i) {
            // Interior vertices wander; some sit exactly on pixel-centre rows and columns (ties).
            const bool inner = i > 0 && j > 0 && i < N && j < N;
            double x = lo + i * cell + (inner ? (rng.uniform() - 0.5) * 0.6 * cell : 0.0);
            double y = lo + j * cell + (inner ? (rng.uniform() - 0.5) * 0.6 * cell : 0.0);
            if (inner && rng.uniform() < 0.2) x = std::floor(x) + 0.5;
            if (inner && rng.uniform() < 0.2) y = std::floor(y) + 0.5;
            gx[j * (N + 1) + i] = std::nearbyint((x + offset) * visibility::kSubpixel);
            gy[j * (N + 1) + i] = std::nearbyint((y + offset) * visibility::kSubpixel);
        }
    std::vector<int> coverage(W * W, 0);
    double area = 0.0;
    auto tri = [&](int a, int b, int c) {
        const double X[3] = {gx[a], gx[b], gx[c]}, Y[3] = {gy[a], gy[b], gy[c]};
        area += 0.5 * std::abs((X[1] - X[0]) * (Y[2] - Y[0]) - (Y[1] - Y[0]) * (X[2] - X[0]));
        visibility::rasterize_triangle(X, Y, offset, offset + W, offset, offset + W, [&](int y, int x0, int x1) {
            for (int x = x0; x < x1; ++x) ++coverage[(y - offset) * W + (x - offset)];
        });
    };
    for (int j = 0; j < N; ++j)
        for (int i = 0; i < N; ++i) {
            const int a = j * (N + 1) + i, b = a + 1, c = a + N + 2, d = a + N + 1;
            if ((i + j) % 2) {
                tri(a, b, c);
                tri(a, c, d);
            } else {
                tri(a, b, d);  // clockwise: orientation must not matter
                tri(b, c, d);
            }
        }
    long covered = 0;
    for (int y = 0; y < W; ++y)
        for (int x = 0; x < W; ++x) {
            const int n = coverage[y * W + x];
            REQUIRE(n <= 1);
            covered += n;
            const bool inside = x + 0.5 > lo && x + 0.5 < hi && y + 0.5 > lo && y + 0.5 < hi;
            if (inside) REQUIRE(n == 1);
        }
    // The outer boundary is the axis-aligned square [10, 240]^2: exactly 230^2 pixel centres.
    CHECK(covered == 230 * 230);
    CHECK(area / (visibility::kSubpixel * visibility::kSubpixel) == Approx(230.0 * 230.0));
}

TEST_CASE("two parallel squares: the jitter-averaged entry is the exact projected overlap", "[visibility][painter]") {
    // Source: unit square at z = 0 facing +z. Receiver: the square shifted by 0.3 in x
    // at z = 1 facing -z. Along w = (tx, ty, 1)/|.| the overlap is ox * oy * cos.
    const std::string text = R"({
      "camera": {"eye": [0.5, 0.5, 5], "target": [0.5, 0.5, 0]},
      "materials": {"m": {"albedo": [0.5, 0.5, 0.5]}},
      "objects": [
        {"quad": [[0,0,0], [1,0,0], [1,1,0], [0,1,0]], "material": "m"},
        {"quad": [[0.3,0,1], [0.3,1,1], [1.3,1,1], [1.3,0,1]], "material": "m"}],
      "patch_size": 0.3})";
    const auto scene = scenes::parse_scene(text, "squares.json", ".");
    std::vector<char> on_receiver(scene.patch_count());
    for (std::size_t i = 0; i < scene.patch_count(); ++i) on_receiver[i] = scene.patch_list()[i].centroid.z() > 0.5;

    visibility::BackendOptions opt;
    opt.resolution = 200;
    auto backend = visibility::make_backend("painter", scene, opt);
    sampling::Rng rng(3);
    const double shifts[][2] = {{0.0, 0.0}, {0.2, 0.1}, {-0.25, 0.3}, {0.5, -0.2}};
    for (const auto& t : shifts) {
        const Vec3 w = Vec3(t[0], t[1], 1.0).normalized();
        const double ox = std::max(0.0, std::min(1.0 + t[0], 1.3) - std::max(t[0], 0.3));
        const double oy = std::max(0.0, std::min(1.0 + t[1], 1.0) - std::max(t[1], 0.0));
        const double exact = ox * oy * w.z();
        const int samples = 400;
        double sum = 0.0;
        visibility::GeometryMatrix m;
        for (int s = 0; s < samples; ++s) {
            backend->transfer(w, {rng.uniform(), rng.uniform()}, m);
            for (const auto& e : m.entries) {
                REQUIRE(on_receiver[e.receiver]);
                REQUIRE(!on_receiver[e.source]);
                sum += e.area;
            }
        }
        INFO("shift " << t[0] << ", " << t[1]);
        CHECK(sum / samples == Approx(exact).epsilon(0.005));
    }
}

TEST_CASE("closed box: each receiver's row sum is its projected area", "[visibility][painter]") {
    const auto scene = scenes::make_builtin("homogeneous-box", 0.25);
    const auto& patches = scene.patch_list();
    visibility::BackendOptions opt;
    opt.resolution = 256;
    auto backend = visibility::make_backend("painter", scene, opt);
    sampling::RandomDirections dirs(11);
    sampling::Rng rng(12);
    visibility::GeometryMatrix m;
    for (int d = 0; d < 8; ++d) {
        const Vec3 w = dirs.next();
        // Average over jitters: pixel noise averages out, a systematic leak would not.
        const int samples = 64;
        std::vector<double> row(patches.size(), 0.0);
        for (int s = 0; s < samples; ++s) {
            backend->transfer(w, {rng.uniform(), rng.uniform()}, m);
            for (const auto& e : m.entries) {
                REQUIRE(patches[e.receiver].normal.dot(w) < 0.0);
                REQUIRE(patches[e.source].normal.dot(w) > 0.0);
                row[e.receiver] += e.area / samples;
            }
        }
        double total = 0.0, exact_total = 0.0;
        for (std::size_t i = 0; i < patches.size(); ++i) {
            const double exact = patches[i].area * std::max(0.0, -patches[i].normal.dot(w));
            total += row[i];
            exact_total += exact;
            // Per patch: within pixel noise (a patch covers >= ~100 pixels when face-on).
            if (exact > 0.2 * patches[i].area) CHECK(row[i] == Approx(exact).epsilon(0.03));
            if (exact == 0.0) CHECK(row[i] == 0.0);
        }
        CHECK(total == Approx(exact_total).epsilon(0.002));
    }
}

TEST_CASE("a two-sided panel of coincident opposite triangles does not leak light", "[visibility][painter]") {
    // Below: a source facing up. Middle: the panel, one quad facing up (source) and
    // one facing down (receiver) at the same place; the source comes first in the
    // file, so an index tie-break would let it shine through the receiver. Above: a
    // receiver facing down.
    const std::string text = R"({
      "camera": {"eye": [0.5, 0.5, 5], "target": [0.5, 0.5, 0]}, "patch_size": "none",
      "materials": {"lower": {"albedo": [0.5, 0.5, 0.5]}, "down": {"albedo": [0.5, 0.5, 0.5]},
                    "up": {"albedo": [0.5, 0.5, 0.5]}, "upper": {"albedo": [0.5, 0.5, 0.5]}},
      "objects": [
        {"quad": [[0,0,-1], [1,0,-1], [1,1,-1], [0,1,-1]], "material": "lower"},
        {"quad": [[0,0,0], [1,0,0], [1,1,0], [0,1,0]], "material": "up"},
        {"quad": [[0,0,0], [0,1,0], [1,1,0], [1,0,0]], "material": "down"},
        {"quad": [[0,0,1], [0,1,1], [1,1,1], [1,0,1]], "material": "upper"}]})";
    const auto scene = scenes::parse_scene(text, "panel.json", ".");
    auto name = [&](std::uint32_t p) { return scene.material_of(p).name; };
    auto backend = visibility::make_backend("painter", scene, {});
    visibility::GeometryMatrix m;
    double into_down = 0.0, into_upper = 0.0;
    backend->transfer(Vec3(0, 0, 1), {0.3, 0.7}, m);
    for (const auto& e : m.entries) {
        const std::string r = name(e.receiver), s = name(e.source);
        if (r == "down") {
            CHECK(s == "lower");
            into_down += e.area;
        } else {
            CHECK(r == "upper");
            CHECK(s == "up");
            into_upper += e.area;
        }
    }
    CHECK(into_down == Approx(1.0).epsilon(0.05));
    CHECK(into_upper == Approx(1.0).epsilon(0.05));
}

TEST_CASE("unknown backend names list the known ones", "[visibility]") {
    const auto scene = scenes::make_builtin("homogeneous-box");
    REQUIRE_THROWS_WITH(visibility::make_backend("zbufer", scene, {}),
                        Catch::Matchers::Contains("unknown visibility backend 'zbufer' (known: exact-painter, painter"));
}

TEST_CASE("the default resolution gives a small patch about 16 pixels", "[visibility]") {
    const auto scene = scenes::make_builtin("cornell-box");
    const int r = visibility::default_resolution(scene);
    std::vector<double> areas;
    for (const auto& p : scene.patch_list()) areas.push_back(p.area);
    std::sort(areas.begin(), areas.end());
    const double pixel = 2.0 * scene.bounds_radius() / r;
    const double covered = areas[areas.size() / 10] / (pixel * pixel);
    CHECK(covered >= 16.0);
    CHECK(covered < 16.5);  // the resolution is rounded up by less than one pixel per side
    CHECK(r >= 64);
    CHECK(r <= 2048);
}
