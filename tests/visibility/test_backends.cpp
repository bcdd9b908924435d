// Properties every visibility backend must have, checked over all of them, and
// cross-checks between the backends.
#include "sampling/directions.h"
#include "scenes/builtin.h"
#include "scenes/loader.h"
#include "solver/stochastic_iteration.h"
#include "visibility/backend.h"
#include "visibility/pair_entries.h"
#include "visibility/parallel.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>
#include <utility>

using namespace raybundle;
using scenes::Vec3;

namespace {

using Matrix = std::map<std::pair<std::uint32_t, std::uint32_t>, double>;  // (receiver, source) -> area

// A(w) averaged over `samples` jitters (the same jitters for every backend).
Matrix averaged(visibility::Backend& backend, const Vec3& w, int samples, std::uint64_t seed) {
    sampling::Rng rng(seed);
    Matrix m;
    visibility::GeometryMatrix g;
    for (int s = 0; s < samples; ++s) {
        backend.transfer(w, {rng.uniform(), rng.uniform()}, g);
        for (const auto& e : g.entries) m[{e.receiver, e.source}] += e.area / samples;
    }
    return m;
}

// ||a - b||_F / ||b||_F
double relative_frobenius(const Matrix& a, const Matrix& b) {
    double diff = 0.0, norm = 0.0;
    Matrix all = b;
    for (const auto& [k, v] : a) all.emplace(k, 0.0);
    for (const auto& [k, vb] : all) {
        const auto it = a.find(k);
        const double va = it == a.end() ? 0.0 : it->second;
        diff += (va - vb) * (va - vb);
        norm += vb * vb;
    }
    return std::sqrt(diff / norm);
}

}  // namespace

TEST_CASE("every backend: closed-box row sums are the projected areas", "[visibility][backends]") {
    const std::string name = GENERATE(from_range(visibility::backend_names()));
    const auto scene = scenes::make_builtin("homogeneous-box", 0.34);
    const auto& patches = scene.patch_list();
    visibility::BackendOptions opt;
    opt.resolution = 96;
    auto backend = visibility::make_backend(name, scene, opt);
    sampling::RandomDirections dirs(21);
    for (int d = 0; d < 3; ++d) {
        const Vec3 w = dirs.next();
        const Matrix m = averaged(*backend, w, 24, 100 + d);
        std::vector<double> row(patches.size(), 0.0);
        for (const auto& [k, area] : m) {
            REQUIRE(patches[k.first].normal.dot(w) < 0.0);   // receivers face against w
            REQUIRE(patches[k.second].normal.dot(w) > 0.0);  // sources face w
            row[k.first] += area;
        }
        double total = 0.0, exact_total = 0.0;
        for (std::size_t i = 0; i < patches.size(); ++i) {
            const double exact = patches[i].area * std::max(0.0, -patches[i].normal.dot(w));
            total += row[i];
            exact_total += exact;
            if (exact > 0.3 * patches[i].area) CHECK(row[i] == Approx(exact).epsilon(0.05));
        }
        INFO(name << ", direction " << d);
        CHECK(total == Approx(exact_total).epsilon(0.003));
    }
}

TEST_CASE("every backend: a set's backends, sharing the scene's arrays, give a lone backend's matrices",
          "[visibility][backends]") {
    // BackendSet makes the scene's patch arrays (and the map's resolution) once for the
    // backends of all its threads; each of them must compute what a backend made alone,
    // with arrays of its own, computes: the same entries in the same order.
    const std::string name = GENERATE(from_range(visibility::backend_names()));
    if (!visibility::backend_info(name).side_by_side) return;  // one backend a set: nothing shared
    const auto scene = scenes::make_builtin("cornell-box", 120.0);
    auto alone = visibility::make_backend(name, scene, {});
    visibility::BackendSet set(name, scene, {}, 3);
    REQUIRE(set.threads() == 3);
    sampling::RandomDirections dirs(4);
    sampling::Rng rng(9);
    for (int d = 0; d < 4; ++d) {
        const Vec3 w = dirs.next();
        const Eigen::Vector2d jitter(rng.uniform(), rng.uniform());
        visibility::GeometryMatrix expected;
        alone->transfer(w, jitter, expected);
        REQUIRE(!expected.entries.empty());
        for (int t = 0; t < set.threads(); ++t) {
            INFO(name << ", thread " << t << ", direction " << d);
            CHECK(set.at(t).resolution() == alone->resolution());
            visibility::GeometryMatrix got;
            set.at(t).transfer(w, jitter, got);
            REQUIRE(got.entries.size() == expected.entries.size());
            bool same = true;
            for (std::size_t k = 0; k < got.entries.size(); ++k)
                same = same && got.entries[k].receiver == expected.entries[k].receiver &&
                       got.entries[k].source == expected.entries[k].source && got.entries[k].area == expected.entries[k].area;
            CHECK(same);
        }
    }
}

TEST_CASE("every backend: the expected matrix is reciprocal between w and -w", "[visibility][backends]") {
    // The pair (i receives from j along w) is the pair (j receives from i along -w), over
    // the same visible projected area.
    const std::string name = GENERATE(from_range(visibility::backend_names()));
    const auto scene = scenes::make_builtin("cornell-box", 150.0);
    visibility::BackendOptions opt;
    opt.resolution = 256;
    auto backend = visibility::make_backend(name, scene, opt);
    const Vec3 w = Vec3(0.3, -0.8, 0.5).normalized();
    const Matrix forward = averaged(*backend, w, 64, 7);
    const Matrix backward_raw = averaged(*backend, -w, 64, 8);
    Matrix backward;
    for (const auto& [k, area] : backward_raw) backward[{k.second, k.first}] = area;
    INFO(name);
    CHECK(relative_frobenius(backward, forward) < (name == "arrangement" ? 1e-9 : 0.02));
}

#ifdef RAYBUNDLE_HAVE_CGAL
namespace {
// The arrangement backend computes A(w) exactly; the discrete backends' jitter averages
// must converge to it. Row sums within 1 % (relative L1 over receivers), the matrix
// within 2 % (relative Frobenius norm), at ten fixed directions. The exact backends on
// the Cornell box as modelled (the panel under a full ceiling, the blocks on a full
// floor); the approximate ones on the version cut to fit them. Jitters per direction:
// the pixel noise of an entry falls as 1/sqrt(samples). One test case per scene: each
// takes minutes under the sanitizers, where one limit holds per test.
void discrete_backends_agree_with_arrangement(const char* scene_name) {
    const std::map<std::string, int> jitters = {{"painter", 128}};
    sampling::RandomDirections dirs(5);
    std::vector<Vec3> directions;
    for (int d = 0; d < 10; ++d) directions.push_back(dirs.next());
    const auto scene = scenes::make_builtin(scene_name);
    auto exact = visibility::make_backend("arrangement", scene, {});
    std::vector<Matrix> reference;
    for (const auto& w : directions) reference.push_back(averaged(*exact, w, 1, 0));
    for (const auto& info : visibility::backend_infos()) {
        if (!info.discrete || info.exact != (std::string(scene_name) == "cornell-box")) continue;
        // The z-buffer gives the global z-buffer's matrix pixel for pixel (test_exact.cpp)
        // and meets the arrangement on the contact scenes; its 640 maps of 512² here cost
        // minutes on llvmpipe under the sanitizers, and would test nothing new.
        if (info.name == "zbuffer") continue;
        visibility::BackendOptions opt;
        opt.resolution = 512;
        auto backend = visibility::make_backend(info.name, scene, opt);
        for (int d = 0; d < 10; ++d) {
            const Matrix m = averaged(*backend, directions[d], jitters.count(info.name) ? jitters.at(info.name) : 64,
                                      50 + d);
            std::vector<double> row(scene.patch_count(), 0.0), row_ref(scene.patch_count(), 0.0);
            for (const auto& [k, area] : m) row[k.first] += area;
            for (const auto& [k, area] : reference[d]) row_ref[k.first] += area;
            double diff = 0.0, norm = 0.0;
            for (std::size_t i = 0; i < row.size(); ++i) {
                diff += std::abs(row[i] - row_ref[i]);
                norm += row_ref[i];
            }
            INFO(info.name << " against arrangement on " << scene_name << ", direction " << d);
            CHECK(diff / norm < 0.01);
            CHECK(relative_frobenius(m, reference[d]) < 0.02);
        }
    }
}
}  // namespace

TEST_CASE("the exact backends agree with the arrangement on the Cornell box as modelled", "[visibility][backends]") {
    discrete_backends_agree_with_arrangement("cornell-box");
}

TEST_CASE("the approximate backends agree with the arrangement on the Cornell box cut to fit",
          "[visibility][backends]") {
    discrete_backends_agree_with_arrangement("cornell-box-cut");
}
#endif

TEST_CASE("interpenetrating patches: exact per-pixel order where centre sorting fails", "[visibility][backends]") {
    // Two unit squares crossing like an X (seen along y), both receiving from a source
    // square below. Square A rises from z = -0.2 to 0.2 along x, square B falls from
    // 0.21 to -0.19: A is lower, so it receives, for x < 0.5125, and B for x > 0.5125.
    // Along w = +z the visible projected areas are those footprints: 0.5125 and 0.4875.
    // (Not cut along the crossing line: scenes/contacts.h would make the backends'
    // work easy.)
    const std::string text = R"({
      "camera": {"eye": [0.5, 0.5, 5], "target": [0.5, 0.5, 0]}, "cut_contacts": false, "patch_size": "none",
      "materials": {"m": {"albedo": [0.5, 0.5, 0.5]}},
      "objects": [
        {"quad": [[0,0,-1], [1,0,-1], [1,1,-1], [0,1,-1]], "material": "m"},
        {"quad": [[0,0,-0.2], [0,1,-0.2], [1,1,0.2], [1,0,0.2]], "material": "m"},
        {"quad": [[0,0,0.21], [0,1,0.21], [1,1,-0.19], [1,0,-0.19]], "material": "m"}]})";
    const auto scene = scenes::parse_scene(text, "x.json", ".");
    visibility::BackendOptions opt;
    opt.resolution = 200;
    std::map<std::string, std::pair<double, double>> received;  // backend -> (square A, square B)
    for (const auto& name : visibility::backend_names()) {
        auto backend = visibility::make_backend(name, scene, opt);
        const Matrix m = averaged(*backend, Vec3(0, 0, 1), 16, 3);
        double a = 0.0, b = 0.0;
        for (const auto& [k, area] : m) (scene.patch_list()[k.first].normal.x() > 0 ? a : b) += area;
        received[name] = {a, b};
    }
    for (const char* exact_backend : {"global-zbuffer", "raycast", "zbuffer"}) {
        if (!received.count(exact_backend)) continue;  // not built
        INFO(exact_backend);
        CHECK(received[exact_backend].first == Approx(0.5125).epsilon(0.005));
        CHECK(received[exact_backend].second == Approx(0.4875).epsilon(0.005));
    }
    // The arrangement inserts the squares' crossing line: exact.
    if (received.count("arrangement")) {
        CHECK(received["arrangement"].first == Approx(0.5125).epsilon(1e-9));
        CHECK(received["arrangement"].second == Approx(0.4875).epsilon(1e-9));
    }
    // At ten directions, against the (now exact) arrangement: the per-pixel backends
    // agree like on the Cornell box; the painter's centre order does not.
    if (received.count("arrangement")) {
        auto exact = visibility::make_backend("arrangement", scene, opt);
        sampling::RandomDirections dirs(31);
        double painter_worst = 0.0;
        for (int d = 0; d < 10;) {
            const Vec3 w = dirs.next();
            const Matrix ref = averaged(*exact, w, 1, 0);
            if (ref.empty()) continue;  // w nearly in the squares' planes: nothing to compare
            ++d;
            for (const auto& name : visibility::backend_names()) {
                if (name == "arrangement") continue;
                visibility::BackendOptions o;
                o.resolution = 256;
                auto backend = visibility::make_backend(name, scene, o);
                const double f = relative_frobenius(averaged(*backend, w, name == "painter" ? 16 : 48, 40 + d), ref);
                INFO(name << " against arrangement, direction " << d);
                if (name == "painter")
                    painter_worst = std::max(painter_worst, f);
                else
                    CHECK(f < 0.02);
            }
        }
        // Documented in docs/benchmarks.md: the painter is off by up to this much here.
        WARN("painter against arrangement on the X scene, worst of ten directions: " << painter_worst);
        CHECK(painter_worst > 0.02);
    }
    // The painter sorts each square's two triangles by their centres: each triangle
    // is wholly in front of or behind the other square's, so the crossing line is lost
    // and the split comes out near 0.5 / 0.5 (measured: 0.500 / 0.499).
    const auto painter = received["painter"];
    CHECK(std::abs(painter.first - 0.5125) > 0.01);
    CHECK(painter.first + painter.second == Approx(1.0).epsilon(0.005));
}

TEST_CASE("every backend: a two-sided panel does not leak", "[visibility][backends]") {
    // A source below, a tilted two-sided panel wider than both (two opposite quads at
    // the same place, with the same diagonal but their corners listed from different
    // starting points, so that their depths round differently), a receiver above.
    // Nothing may pass from below to above, nor between the panel's two sides.
    const std::string text = R"({
      "camera": {"eye": [0.5, 0.5, 5], "target": [0.5, 0.5, 0]}, "patch_size": "none",
      "materials": {"lower": {"albedo": [0.5, 0.5, 0.5]}, "down": {"albedo": [0.5, 0.5, 0.5]},
                    "up": {"albedo": [0.5, 0.5, 0.5]}, "upper": {"albedo": [0.5, 0.5, 0.5]}},
      "objects": [
        {"quad": [[0,0,-1], [1,0,-1], [1,1,-1], [0,1,-1]], "material": "lower"},
        {"quad": [[-1,-1,0.22], [2,-1,0.37], [2,2,0.46], [-1,2,0.31]], "material": "up"},
        {"quad": [[2,2,0.46], [2,-1,0.37], [-1,-1,0.22], [-1,2,0.31]], "material": "down"},
        {"quad": [[0,0,1.5], [0,1,1.5], [1,1,1.5], [1,0,1.5]], "material": "upper"}]})";
    const auto scene = scenes::parse_scene(text, "panel.json", ".");
    for (const auto& name : visibility::backend_names()) {
        visibility::BackendOptions opt;
        opt.resolution = 128;
        auto backend = visibility::make_backend(name, scene, opt);
        sampling::RandomDirections dirs(9);
        for (int d = 0; d < 20; ++d) {
            Vec3 w = dirs.next();
            if (w.z() < 0) w = -w;  // light going up
            visibility::GeometryMatrix m;
            backend->transfer(w, {0.37, 0.61}, m);
            for (const auto& e : m.entries) {
                const std::string r = scene.material_of(e.receiver).name, s = scene.material_of(e.source).name;
                INFO(name << ", direction " << d << ": " << r << " receives from " << s);
                CHECK(!(r == "down" && s == "up"));  // through the panel, within it
                CHECK(!(r == "upper" && s == "lower"));
            }
        }
    }
}

namespace {
// Same seed: same directions (and jitters), so the runs differ only where the backends'
// matrices do: by pixel noise, against the exact arrangement. Every backend on the
// Cornell box cut to fit the painter; the exact ones also on the box as modelled, where
// the painter is off by about 20 % (the panel under the ceiling). One test case per
// scene, as above.
void same_radiance_with_every_backend(const char* scene_name) {
    const auto scene = scenes::make_builtin(scene_name, 150.0);
    std::map<std::string, solver::RadianceField> fields;
    for (const auto& info : visibility::backend_infos()) {
        if (std::string(scene_name) == "cornell-box" && !info.exact) continue;
        visibility::BackendOptions opt;
        opt.resolution = 256;
        auto backend = visibility::make_backend(info.name, scene, opt);
        solver::SolverOptions it_opt;
        sampling::RunOptions it_opt_run;
        it_opt.steps = 200;
        it_opt_run.seed = 4;
        solver::StochasticIteration it(scene, *backend, it_opt, it_opt_run);
        it.run();
        fields[info.name] = it.field();
    }
    const auto& ref = fields.count("arrangement") ? fields["arrangement"] : fields["raycast"];
    for (const auto& [name, field] : fields) {
        double diff = 0.0, norm = 0.0;
        for (std::size_t i = 0; i < scene.patch_count(); ++i) {
            diff += scene.patch_list()[i].area * (field.radiance[i] - ref.radiance[i]).abs().sum();
            norm += scene.patch_list()[i].area * ref.radiance[i].sum();
        }
        INFO(name << " against the reference on " << scene_name);
        CHECK(diff / norm < 0.02);
    }
}
}  // namespace

TEST_CASE("the solver reaches the same radiance with every backend on the Cornell box cut to fit",
          "[visibility][backends][solver]") {
    same_radiance_with_every_backend("cornell-box-cut");
}

TEST_CASE("the solver reaches the same radiance with every exact backend on the Cornell box as modelled",
          "[visibility][backends][solver]") {
    same_radiance_with_every_backend("cornell-box");
}

TEST_CASE("counted pairs arriving in any order become entries sorted by receiver and source",
          "[visibility][backends][pairs]") {
    // As the z-buffer's GPU table hands them over: distinct (receiver, source, count)
    // records in the order its slots were claimed. Ids of 12, 17, 26 and 32 bits (the
    // last two too wide to pack beside a 22-bit count), counts up to a 2048-pixel map.
    std::mt19937_64 random(7);
    for (const std::uint32_t id_limit : {3722u + 2u, 121324u + 2u, 40000000u, 0xffffffffu})
        for (const std::uint32_t m : {0u, 1u, 200u, 5000u, 200000u}) {
            CAPTURE(id_limit, m);
            std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> truth;
            while (truth.size() < m) {
                const auto r = static_cast<std::uint32_t>(random() % id_limit);
                const auto s = static_cast<std::uint32_t>(random() % id_limit);
                truth.emplace(std::make_pair(r, s), static_cast<std::uint32_t>(1 + random() % (2048u * 2048u)));
            }
            std::vector<std::uint32_t> words;
            for (const auto& [pair, count] : truth) words.insert(words.end(), {pair.first, pair.second, count});
            const double area = 0.25;
            visibility::PairCountScratch scratch;
            std::vector<visibility::TransferEntry> first, again, wide;
            for (int order = 0; order < 2; ++order) {
                // Records shuffled (as whole records) before each call.
                std::vector<std::uint32_t> index(m);
                std::iota(index.begin(), index.end(), 0u);
                std::shuffle(index.begin(), index.end(), random);
                std::vector<std::uint32_t> shuffled;
                for (std::uint32_t j : index) shuffled.insert(shuffled.end(), words.begin() + 3 * j, words.begin() + 3 * j + 3);
                visibility::entries_from_counts(shuffled.data(), m, area, scratch, order == 0 ? first : again);
                if (order == 0) visibility::entries_from_counts_wide(shuffled.data(), m, area, scratch, wide);
            }
            REQUIRE(first.size() == m);
            auto t = truth.begin();
            for (std::size_t j = 0; j < m; ++j, ++t) {
                REQUIRE(first[j].receiver == t->first.first);
                REQUIRE(first[j].source == t->first.second);
                REQUIRE(first[j].area == static_cast<double>(t->second) * area);
                for (const auto* other : {&again, &wide}) {
                    REQUIRE((*other)[j].receiver == first[j].receiver);
                    REQUIRE((*other)[j].source == first[j].source);
                    REQUIRE((*other)[j].area == first[j].area);
                }
            }
        }
}

TEST_CASE("the radix sort orders keys by their bits above the ignored ones", "[visibility][backends][pairs]") {
    std::mt19937_64 random(11);
    for (const int low : {0, 7, 22, 40, 63})
        for (const std::size_t n : {std::size_t{0}, std::size_t{3}, std::size_t{255}, std::size_t{256}, std::size_t{100000}})
            // (0xff000000000000ff: whole digits inside the span that no key changes.)
            for (const std::uint64_t spread : {std::uint64_t{0xff}, std::uint64_t{0xfff0f0000},
                                               std::uint64_t{0xff000000000000ff}, ~std::uint64_t{0}}) {
                CAPTURE(low, n, spread);
                std::vector<std::uint64_t> keys(n), tmp;
                for (auto& k : keys) k = random() & spread;
                std::vector<std::uint64_t> expected = keys;
                visibility::radix_sort(keys, tmp, low);
                REQUIRE(keys.size() == n);
                const auto high = [low](std::uint64_t k) { return k >> low; };
                for (std::size_t j = 1; j < n; ++j) REQUIRE(high(keys[j - 1]) <= high(keys[j]));
                // A permutation of the keys.
                std::sort(expected.begin(), expected.end());
                std::sort(keys.begin(), keys.end());
                REQUIRE(keys == expected);
            }
}

TEST_CASE("per-pixel pairs become one entry per distinct pair, counted and sorted", "[visibility][backends][pairs]") {
    // As the global z-buffer and ray casting record them: one key per pixel, repeated
    // over the pixels a pair covers. Entries are appended after what `out` holds.
    std::mt19937_64 random(5);
    for (const std::uint32_t id_limit : {1u, 3724u, 121326u, 0xffffffffu})
        for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{300}, std::size_t{400000}}) {
            CAPTURE(id_limit, n);
            std::vector<std::pair<std::uint32_t, std::uint32_t>> distinct(1 + n / 50);
            for (auto& [r, s] : distinct)
                r = static_cast<std::uint32_t>(random() % id_limit), s = static_cast<std::uint32_t>(random() % id_limit);
            std::map<std::pair<std::uint32_t, std::uint32_t>, std::size_t> truth;
            std::vector<std::uint64_t> pairs(n), tmp;
            for (auto& k : pairs) {
                const auto& p = distinct[random() % distinct.size()];
                ++truth[p];
                k = static_cast<std::uint64_t>(p.first) << 32 | p.second;
            }
            std::vector<visibility::TransferEntry> out{{7, 8, 9.0}};
            visibility::entries_from_pairs(pairs, tmp, 0.5, out);
            REQUIRE(out.size() == 1 + truth.size());
            CHECK((out[0].receiver == 7 && out[0].source == 8 && out[0].area == 9.0));
            std::size_t j = 1;
            for (const auto& [p, count] : truth) {
                REQUIRE(out[j].receiver == p.first);
                REQUIRE(out[j].source == p.second);
                REQUIRE(out[j].area == 0.5 * static_cast<double>(count));
                ++j;
            }
        }
}
