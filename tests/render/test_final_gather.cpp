// The final gather (003): exact answers on the homogeneous box, agreement with the
// patch image, the filters' ordering of 003 Fig. 8, and the geometry-aware lookup.
#include "gather_options.h"
#include "render/final_gather.h"
#include "render/metrics.h"
#include "render/gbuffer.h"
#include "render/lights.h"
#include "render/shade.h"
#include "sampling/rng.h"
#include "scenes/builtin.h"
#include "scenes/errors.h"
#include "scenes/loader.h"
#include "scenes/subdivide.h"
#include "solver/first_shot.h"
#include "solver/solver.h"
#include "solver/stochastic_iteration.h"
#include "visibility/backend.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <limits>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

using namespace raybundle;
using scenes::Rgb;
using scenes::Vec3;

namespace {

solver::RadianceField solve(const scenes::Scene& scene, long steps, bool diffuse_shot = false) {
    const solver::Transport transport(scene, solver::ShotOptions{diffuse_shot});
    auto backend = visibility::make_backend("painter", scene, {});
    solver::SolverOptions opt;
    sampling::RunOptions opt_run;
    opt.steps = steps;
    solver::StochasticIteration it(transport, *backend, opt, opt_run);
    it.run();
    return it.field();
}

// The default solver's field after `steps` steps, with the diffuse shot.
// The mean over pixels and channels.
double mean_of(const render::Image& img) {
    double s = 0.0;
    for (float v : img.rgb) s += v;
    return s / static_cast<double>(img.rgb.size());
}

solver::RadianceField diffuse_shot_field(const scenes::Scene& scene, long steps) {
    const solver::Transport transport(scene, solver::ShotOptions{true});
    solver::SolverOptions so;
    so.steps = steps;
    auto solver = solver::make_solver(transport, so, {});
    solver->run();
    return solver->field();
}

// Two rooms under one floor, one ceiling and two long walls (single quads), a
// two-sided partition between them, the lamp in the far room; `cut`: the patches cut
// where the partition stands on the others (scenes/contacts.h), else left as modelled.
scenes::Scene two_rooms(bool cut) {
    const std::string text = R"({
      "camera": {"eye": [0.5, 1.5, 2], "target": [4, 1.5, 2], "fov_y": 80, "width": 24, "height": 24},
      "materials": {"w": {"albedo": [0.8, 0.8, 0.8]}, "p": {"albedo": [0.8, 0.8, 0.8], "two_sided": true},
                    "lamp": {"albedo": [0, 0, 0], "emission": [20, 20, 20]}},
      "objects": [
        {"quad": [[0, 0, 0], [0, 0, 4], [8, 0, 4], [8, 0, 0]], "material": "w"},
        {"quad": [[0, 3, 0], [8, 3, 0], [8, 3, 4], [0, 3, 4]], "material": "w"},
        {"quad": [[0, 0, 0], [8, 0, 0], [8, 3, 0], [0, 3, 0]], "material": "w"},
        {"quad": [[0, 0, 4], [0, 3, 4], [8, 3, 4], [8, 0, 4]], "material": "w"},
        {"quad": [[0, 0, 0], [0, 3, 0], [0, 3, 4], [0, 0, 4]], "material": "w"},
        {"quad": [[8, 0, 0], [8, 0, 4], [8, 3, 4], [8, 3, 0]], "material": "w"},
        {"quad": [[4, 0, 0], [4, 0, 4], [4, 3, 4], [4, 3, 0]], "material": "p"},
        {"quad": [[5.5, 2.99, 1.5], [6.5, 2.99, 1.5], [6.5, 2.99, 2.5], [5.5, 2.99, 2.5]], "material": "lamp"}],
      "patch_size": 0.7, "cut_contacts": )" + std::string(cut ? "true" : "false") + "}";
    return scenes::parse_scene(text, "rooms.json", ".");
}

// A team of threads standing in for MPI ranks (render/ranks.h): share_rows() copies each
// member's block into a common buffer, waits for all, and copies the whole back.
class ThreadTeam {
public:
    explicit ThreadTeam(int members) : members_(members) {}
    class Member final : public sampling::Team {
    public:
        Member(ThreadTeam& team, int rank) : team_(team), rank_(rank) {}
        int rank() const override { return rank_; }
        int size() const override { return team_.members_; }
        void share_rows(void* data, std::size_t row_bytes, int rows) const override {
            team_.wait([&] { team_.buffer_.resize(row_bytes * static_cast<std::size_t>(rows)); });
            for (int y = rank_; y < rows; y += size()) {
                const std::size_t at = row_bytes * static_cast<std::size_t>(y);
                std::memcpy(team_.buffer_.data() + at, static_cast<char*>(data) + at, row_bytes);
            }
            team_.wait([] {});
            std::memcpy(data, team_.buffer_.data(), team_.buffer_.size());
            team_.wait([] {});
        }

    private:
        ThreadTeam& team_;
        int rank_;
    };

private:
    // A barrier; the last member to arrive runs `last` before the others go on.
    template <class F>
    void wait(F last) {
        std::unique_lock<std::mutex> lock(mutex_);
        const long generation = generation_;
        if (++arrived_ == members_) {
            last();
            arrived_ = 0;
            ++generation_;
            all_.notify_all();
        } else {
            all_.wait(lock, [&] { return generation_ != generation; });
        }
    }
    int members_;
    std::mutex mutex_;
    std::condition_variable all_;
    int arrived_ = 0;
    long generation_ = 0;
    std::vector<char> buffer_;
};

// The rows member k of `members` owns of `rows` (sampling::Team::rows_of).
long team_rows(int k, int members, int rows) { return (rows - k + members - 1) / members; }

}  // namespace

TEST_CASE("ray casting: occluded() answers as intersect() does, two-sided patches' backs included", "[render][rays]") {
    // Rays between random points of the two rooms, through the two-sided partition from
    // both sides, with segments that end short of a wall, on it, and past it.
    const scenes::Scene scene = two_rooms(true);
    const scenes::RayCaster caster(scene, 1);
    sampling::Rng rng(7);
    int blocked = 0, open = 0;
    for (int i = 0; i < 20000; ++i) {
        const scenes::Vec3 from(0.05 + 7.9 * rng.uniform(), 0.05 + 2.9 * rng.uniform(), 0.05 + 3.9 * rng.uniform());
        const scenes::Vec3 to(0.05 + 7.9 * rng.uniform(), 0.05 + 2.9 * rng.uniform(), 0.05 + 3.9 * rng.uniform());
        const double r = (to - from).norm();
        const double t_max = r * (0.5 + rng.uniform());
        const bool hit = caster.intersect(from, (to - from) / r, 0.0, t_max).valid();
        INFO("ray " << i);
        REQUIRE(caster.occluded(from, (to - from) / r, 0.0, t_max) == hit);
        ++(hit ? blocked : open);
    }
    CHECK(blocked > 2000);  // both answers are asked for, many times
    CHECK(open > 2000);
}

TEST_CASE("diffuse shot: spread over a team, each member shoots to its receivers and all hold the whole shot",
          "[render][team]") {
    auto scene = scenes::make_builtin("cornell-box", 150.0);
    const scenes::RayCaster caster(scene);
    const int n = static_cast<int>(scene.patch_count());
    long rays_alone = 0;
    const auto alone = solver::diffuse_shot(scene, caster, rays_alone, sampling::RunOptions{});
    for (const int members : {2, 3}) {
        ThreadTeam team(members);
        std::vector<ThreadTeam::Member> member;
        for (int k = 0; k < members; ++k) member.emplace_back(team, k);
        std::vector<std::vector<scenes::Rgb>> shots(static_cast<std::size_t>(members));
        std::vector<long> rays(static_cast<std::size_t>(members), 0), receivers(static_cast<std::size_t>(members), 0);
        std::vector<std::thread> threads;
        for (int k = 0; k < members; ++k)
            threads.emplace_back([&, k] {
                sampling::RunOptions mine;
                mine.team = &member[static_cast<std::size_t>(k)];
                mine.threads = 2;
                mine.progress_every = 1;
                mine.progress = [&, k](const sampling::Progress& p) { receivers[static_cast<std::size_t>(k)] = p.total; };
                shots[static_cast<std::size_t>(k)] = solver::diffuse_shot(scene, caster, rays[static_cast<std::size_t>(k)], mine);
            });
        for (auto& t : threads) t.join();
        for (int k = 0; k < members; ++k) {
            INFO(members << " members, member " << k);
            CHECK(receivers[static_cast<std::size_t>(k)] == team_rows(k, members, n));
            CHECK(rays[static_cast<std::size_t>(k)] == rays_alone);
            bool same = true;
            for (int i = 0; i < n; ++i) same = same && (shots[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)] == alone[static_cast<std::size_t>(i)]).all();
            CHECK(same);
        }
    }
}

TEST_CASE("final gather: spread over a team by rows, every member makes the image one process makes", "[render][gather]") {
    auto scene = scenes::make_builtin("cornell-box", 120.0);
    scene.camera.width = 40;
    scene.camera.height = 31;  // rows that do not divide evenly
    const auto field = solve(scene, 200, true);
    const scenes::RayCaster caster(scene);
    const render::PinholeCamera camera(scene.camera);
    for (const int spp : {1, 3}) {
        render::GatherOptions o = guide_only_gather();
        o.gather_rays = 8;
        o.direct_samples = 2;
        o.spp = spp;
        sampling::RunOptions run;
        run.seed = 5;
        const auto alone = render::final_gather(scene, caster, field, camera, o, run);
        for (const int members : {2, 3}) {
            ThreadTeam team(members);
            std::vector<ThreadTeam::Member> member;
            for (int k = 0; k < members; ++k) member.emplace_back(team, k);
            std::vector<render::GatherResult> results(static_cast<std::size_t>(members));
            std::vector<std::thread> threads;
            for (int k = 0; k < members; ++k)
                threads.emplace_back([&, k] {
                    sampling::RunOptions mine = run;
                    mine.team = &member[static_cast<std::size_t>(k)];
                    results[static_cast<std::size_t>(k)] = render::final_gather(scene, caster, field, camera, o, mine);
                });
            for (auto& t : threads) t.join();
            for (const auto& r : results) {
                INFO("spp " << spp << ", " << members << " members");
                CHECK(r.image.rgb == alone.image.rgb);
                CHECK(r.indirect_filtered.rgb == alone.indirect_filtered.rgb);
                CHECK(r.direct.rgb == alone.direct.rgb);
                CHECK(r.gather_rays == alone.gather_rays);
                CHECK(r.shadow_rays == alone.shadow_rays);
                CHECK(r.lookups == alone.lookups);
                CHECK(r.bias.rgb == alone.bias.rgb);  // the probe's rows shared too
                CHECK(r.bias_rays == alone.bias_rays);
            }
        }
    }
}

TEST_CASE("final gather: the homogeneous box is 1 everywhere within noise", "[render][gather]") {
    auto scene = scenes::make_builtin("homogeneous-box", 0.34);
    scene.camera.width = scene.camera.height = 24;
    // The diagonal pixels lie exactly on the seams of two walls, where the other
    // (emitting) wall is seen edge-on: light sampling alone misses its near field there,
    // the cosine-weighted half of the MIS pair does not.
    const auto field = solve(scene, 2000);
    const scenes::RayCaster caster(scene);
    const render::PinholeCamera camera(scene.camera);
    render::GatherOptions o = guide_only_gather();
    o.gather_rays = 1024;
    o.direct_samples = 256;
    o.filter.filter = render::Filter::none;
    const auto r = render::final_gather(scene, caster, field, camera, o, {});
    double sum = 0.0;
    std::vector<double> dev;
    for (int y = 0; y < 24; ++y)
        for (int x = 0; x < 24; ++x) {
            const float* p = r.image.at(x, y);
            for (int k = 0; k < 3; ++k) {
                sum += p[k];
                dev.push_back(std::abs(p[k] - 1.0));
            }
        }
    std::sort(dev.begin(), dev.end());
    const double mean = sum / static_cast<double>(dev.size()), p90 = dev[dev.size() * 9 / 10];
    INFO("mean " << mean << ", 90th percentile of |L - 1| " << p90 << ", worst " << dev.back());
    CHECK(mean == Approx(1.0).epsilon(0.01));
    CHECK(p90 < 0.02);
    CHECK(dev.back() < 0.05);
    // The indirect part alone: the field reflects 0.5 everywhere.
    CHECK(r.indirect.at(12, 12)[0] == Approx(0.5).epsilon(0.05));
}

TEST_CASE("final gather: the Cornell box agrees with the smooth patch image away from edges", "[render][gather]") {
    auto scene = scenes::make_builtin("cornell-box", 80.0);
    scene.camera.width = scene.camera.height = 64;
    const auto field = solve(scene, 4000, true);
    const scenes::RayCaster caster(scene);
    const render::PinholeCamera camera(scene.camera);
    render::GatherOptions o = guide_only_gather();
    o.gather_rays = 256;
    o.direct_samples = 64;
    o.filter.filter = render::Filter::none;
    const auto r = render::final_gather(scene, caster, field, camera, o, {});
    const auto patch_image = render::shade(scene, field, render::make_gbuffer(scene, caster, camera), render::Shading::Smooth);
    // Away from edges: the guide's normal and depth are smooth over a 5 x 5 window.
    double diff = 0.0, ref = 0.0;
    int used = 0;
    for (int y = 2; y < 62; ++y)
        for (int x = 2; x < 62; ++x) {
            bool smooth = r.depth.at(x, y)[0] > 0.0f;
            for (int dy = -2; dy <= 2 && smooth; ++dy)
                for (int dx = -2; dx <= 2 && smooth; ++dx) {
                    const float* n0 = r.normal.at(x, y);
                    const float* n1 = r.normal.at(x + dx, y + dy);
                    smooth = n0[0] == n1[0] && n0[1] == n1[1] && n0[2] == n1[2] &&
                             std::abs(r.depth.at(x + dx, y + dy)[0] / r.depth.at(x, y)[0] - 1.0f) < 0.05f;
                }
            if (!smooth) continue;
            ++used;
            for (int k = 0; k < 3; ++k) {
                diff += std::abs(r.image.at(x, y)[k] - patch_image.at(x, y)[k]);
                ref += patch_image.at(x, y)[k];
            }
        }
    INFO(used << " pixels away from edges; relative mean difference " << diff / ref);
    CHECK(used > 500);
    CHECK(diff / ref < 0.08);
}

TEST_CASE("final gather: emission samples of their own take the noise off a light's edges", "[render][gather]") {
    auto scene = scenes::make_builtin("cornell-box", 80.0);
    scene.camera.width = scene.camera.height = 48;
    const auto field = solve(scene, 500, true);
    const scenes::RayCaster caster(scene);
    const render::PinholeCamera camera(scene.camera);
    render::GatherOptions o = guide_only_gather();
    o.gather_rays = 4;
    o.direct_samples = 2;
    o.spp = 4;
    auto image = [&](int emission_samples, int spp, std::uint64_t seed) {
        o.emission_samples = emission_samples;
        o.spp = spp;
        sampling::RunOptions run;
        run.seed = seed;
        return render::final_gather(scene, caster, field, camera, o, run).image;
    };
    const auto reference = image(0, 1024, 9);
    // The light panel and a pixel around it (its radiance is 17; the ceiling's 0.1).
    double without = 0.0, with = 0.0, sum = 0.0;
    for (std::uint64_t seed = 1; seed <= 4; ++seed) {
        const auto a = image(0, 4, seed), b = image(64, 4, seed);
        for (int y = 1; y < 47; ++y)
            for (int x = 1; x < 47; ++x) {
                bool near_light = false;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) near_light |= reference.at(x + dx, y + dy)[0] > 5.0f;
                if (!near_light) continue;
                for (int k = 0; k < 3; ++k) {
                    without += std::abs(a.at(x, y)[k] - reference.at(x, y)[k]);
                    with += std::abs(b.at(x, y)[k] - reference.at(x, y)[k]);
                    sum += reference.at(x, y)[k];
                }
            }
    }
    INFO("around the light, relative L1: 4 camera samples " << without / sum << ", with 64 emission samples "
                                                           << with / sum);
    CHECK(sum > 0.0);
    CHECK(with < 0.5 * without);
    o.emission_samples = -1;
    CHECK_THROWS_WITH(render::final_gather(scene, caster, field, camera, o, {}), Catch::Contains(">= 0"));
}

TEST_CASE("geometry-aware lookup: the most similar guide by normal and depth", "[render][gather]") {
    const Vec3 wall(0, 0, -1), pole(1, 0, 0);
    // A sample on the wall (depth 10) among two pole guides (depth 2) and two wall guides.
    CHECK(render::most_similar_guide(wall, 10.0, {pole, wall, pole, wall}, {2.0, 10.5, 2.1, 9.8}) == 3);
    // Same normals everywhere: depth decides.
    CHECK(render::most_similar_guide(wall, 2.0, {wall, wall, wall, wall}, {10.0, 2.2, 10.0, 2.1}) == 3);
    // Identical candidates: the first.
    CHECK(render::most_similar_guide(wall, 5.0, {wall, wall}, {5.0, 5.0}) == 0);
    CHECK(render::most_similar_guide(wall, 5.0, {}, {}) == -1);
}

TEST_CASE("geometry-aware lookup: no indirect light across a depth discontinuity", "[render][gather]") {
    // A thin dark post (3 pixels wide, albedo 0.5) 1 unit in front of a wall lit from
    // the side; the wall's incident indirect light is much brighter than the post's
    // front. Extra samples on the post must take the post's light, and wall samples the
    // wall's: every pixel stays between the values of the surfaces it covers.
    scenes::Scene s;
    scenes::Material wall_m, post_m, lamp_m;
    wall_m.name = "wall";
    wall_m.albedo = Rgb::Constant(0.8);
    post_m.name = "post";
    post_m.albedo = Rgb::Constant(0.5);
    lamp_m.name = "lamp";
    lamp_m.albedo = Rgb::Constant(0.0);
    lamp_m.emission = Rgb::Constant(10.0);
    const int wm = s.add_material(wall_m), pm = s.add_material(post_m), lm = s.add_material(lamp_m);
    // The wall z = 0 facing +z; a floor-like reflector y = -1 facing +y; a lamp facing -y above.
    s.add_object({{-2, -1, 0}, {2, -1, 0}, {2, 2, 0}, {-2, 2, 0}}, {{{0, 1, 2}}, {{0, 2, 3}}}, wm);
    s.add_object({{-2, -1, 0}, {-2, -1, 3}, {2, -1, 3}, {2, -1, 0}}, {{{0, 1, 2}}, {{0, 2, 3}}}, wm);
    s.add_object({{-0.5, 2, 0.5}, {0.5, 2, 0.5}, {0.5, 2, 1.5}, {-0.5, 2, 1.5}}, {{{0, 1, 2}}, {{0, 2, 3}}}, lm);
    // The post: a thin quad at z = 1.5 facing the camera, 0.08 wide.
    s.add_object({{-0.04, -1, 1.5}, {0.04, -1, 1.5}, {0.04, 1.5, 1.5}, {-0.04, 1.5, 1.5}},
                 {{{0, 1, 2}}, {{0, 2, 3}}}, pm);
    s.finalize();
    scenes::subdivide(s, 0.25);
    s.camera.eye = Vec3(0, 0.2, 5);
    s.camera.target = Vec3(0, 0.2, 0);
    s.camera.fov_y = 40;
    s.camera.width = s.camera.height = 96;  // the post is about 3 pixels wide
    const auto field = solve(s, 3000, true);
    const scenes::RayCaster caster(s);
    const render::PinholeCamera camera(s.camera);
    render::GatherOptions o = guide_only_gather();
    o.gather_rays = 64;
    o.direct_samples = 16;
    o.filter.filter = render::Filter::none;
    o.spp = 16;
    const auto r = render::final_gather(s, caster, field, camera, o, {});
    // The post's edges: every extra sample near them has a guide on its own surface
    // among its four (the post covers at least one pixel centre per row), and the
    // similarity picks it.
    INFO(r.lookups << " lookups, " << r.lookups_across << " across a depth discontinuity");
    CHECK(r.lookups > 100000);
    CHECK(r.lookups_across == 0);
    // The same scene with the post thinner than a pixel: now some samples on it have
    // no guide on it (003 Fig. 3b), and the counter sees them.
    scenes::Scene thin = s;
    thin.camera.width = thin.camera.height = 24;
    const render::PinholeCamera small(thin.camera);
    const auto t = render::final_gather(thin, caster, field, small, o, {});
    INFO("thin: " << t.lookups << " lookups, " << t.lookups_across << " across");
    CHECK(t.lookups_across > 0);
}

TEST_CASE("final gather: guided <= bilateral and <= A-Trous, all far below unfiltered (003 Fig. 8)",
          "[render][gather][filters]") {
    auto scene = scenes::make_builtin("cornell-box", 80.0);
    scene.camera.width = scene.camera.height = 64;
    const auto field = solve(scene, 3000, true);
    const scenes::RayCaster caster(scene);
    const render::PinholeCamera camera(scene.camera);
    for (const int spp : {1, 4}) {
        render::GatherOptions base = guide_only_gather();
        base.spp = spp;
        base.direct_samples = 64;
        base.gather_rays = 16;
        // The reference: 2,048 gather rays, no filter, the same direct light (same seed).
        render::GatherOptions ref_o = base;
        ref_o.gather_rays = 2048;
        ref_o.filter.filter = render::Filter::none;
        const auto ref = render::final_gather(scene, caster, field, camera, ref_o, {}).image;
        auto error = [&](const render::GatherOptions& o) {
            return render::mse(render::final_gather(scene, caster, field, camera, o, {}).image, ref);
        };
        render::GatherOptions none = base;
        none.filter.filter = render::Filter::none;
        const double unfiltered = error(none);
        double guided = std::numeric_limits<double>::infinity(), bilateral = guided, atrous = guided;
        // The sweeps (bench/gather_study filters runs a larger one: the best values lie inside).
        for (const int radius : {2, 4, 8})
            for (const double en : {0.001, 0.01})
                for (const double ed : {0.0003, 0.003}) {
                    render::GatherOptions o = base;
                    o.filter.filter = render::Filter::guided;
                    o.filter.radius = radius;
                    o.filter.eps_normal = en;
                    o.filter.eps_depth = ed;
                    guided = std::min(guided, error(o));
                }
        for (const double sigma : {2.0, 4.0})
            for (const double sn : {0.05, 0.3})
                for (const double sd : {0.01, 0.02, 0.05}) {
                    render::GatherOptions o = base;
                    o.filter.filter = render::Filter::bilateral;
                    o.filter.radius = static_cast<int>(2 * sigma);
                    o.filter.sigma_spatial = sigma;
                    o.filter.sigma_normal = sn;
                    o.filter.sigma_depth = sd;
                    bilateral = std::min(bilateral, error(o));
                }
        for (const int it : {3, 5})
            for (const double sc : {0.3, 1.0})
                for (const double sd : {0.01, 0.03}) {
                    render::GatherOptions o = base;
                    o.filter.filter = render::Filter::atrous;
                    o.filter.atrous_iterations = it;
                    o.filter.sigma_colour = sc;
                    o.filter.sigma_normal = 0.3;
                    o.filter.sigma_depth = sd;
                    atrous = std::min(atrous, error(o));
                }
        INFO(spp << " spp: MSE unfiltered " << unfiltered << ", guided " << guided << ", bilateral " << bilateral
                 << ", A-Trous " << atrous);
        CHECK(guided <= bilateral);
        CHECK(guided <= atrous);
        CHECK(guided < 0.25 * unfiltered);
        CHECK(bilateral < 0.5 * unfiltered);
        CHECK(atrous < 0.5 * unfiltered);
    }
}

TEST_CASE("final gather: the sky lights an open plane (rho L_sky)", "[render][gather][sky]") {
    scenes::Scene s;
    scenes::Material m;
    m.name = "ground";
    m.albedo = Rgb::Constant(0.5);
    s.add_object({{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}}, {{{0, 1, 2}}, {{0, 2, 3}}}, s.add_material(m));
    s.finalize();
    scenes::subdivide(s, 0.25);
    scenes::Sky sky;
    sky.radiance = Rgb(1.0, 2.0, 0.5);
    sky.up = Vec3(0, 0, 1);
    s.sky = sky;
    s.camera.eye = Vec3(0, -0.5, 2);
    s.camera.target = Vec3(0, 0, 0);
    s.camera.up = Vec3(0, 0, 1);
    s.camera.fov_y = 30;
    s.camera.width = s.camera.height = 16;
    const auto field = solve(s, 200);
    const scenes::RayCaster caster(s);
    const render::PinholeCamera camera(s.camera);
    render::GatherOptions o = guide_only_gather();
    o.gather_rays = 256;
    o.filter.filter = render::Filter::none;
    const auto r = render::final_gather(s, caster, field, camera, o, {});
    Rgb sum = Rgb::Zero();
    int n = 0;
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            if (r.depth.at(x, y)[0] <= 0.0f) continue;
            const float* p = r.image.at(x, y);
            sum += Rgb(p[0], p[1], p[2]);
            ++n;
        }
    REQUIRE(n > 200);
    const Rgb mean = sum / n;
    INFO("mean pixel " << mean.transpose());
    for (int c = 0; c < 3; ++c) CHECK(mean[c] == Approx(0.5 * sky.radiance[c]).epsilon(0.02));
}

TEST_CASE("final gather: no light leaks through a partition that stands on a full floor", "[render][gather][contacts]") {
    // Two rooms under one floor, one ceiling and two long walls (single quads), a
    // two-sided partition between them, the lamp in the far room: the near room is
    // black. Without the cut at the contacts the floor's, ceiling's and walls' patches
    // that run on under the partition carry the far room's light across: the near room
    // shows 0.03. With it, 2e-5 remains: bundle rays that slip through the seams where
    // the partition meets the other objects (separate meshes, not welded).
    for (const bool cut : {true, false}) {
        const auto scene = two_rooms(cut);
        const auto field = diffuse_shot_field(scene, 400);
        const scenes::RayCaster caster(scene);
        render::GatherOptions o = guide_only_gather();
        o.gather_rays = 16;
        o.spp = 4;
        const auto r = render::final_gather(scene, caster, field, render::PinholeCamera(scene.camera), o, {});
        const float brightest = *std::max_element(r.image.rgb.begin(), r.image.rgb.end());
        INFO((cut ? "cut" : "not cut") << ": brightest pixel of the near room " << brightest);
        if (cut)
            CHECK(brightest < 2e-4f);
        else
            CHECK(brightest > 0.01f);
    }
}

TEST_CASE("final gather: the field as a control variate converges to the truth from a wrong field",
          "[render][gather][correction]") {
    // The homogeneous box is 1 everywhere; a field of 0.7 everywhere stands for a field
    // that is wrong (as a coarse one is in a contact shadow). Read as the answer, it
    // makes the indirect light 0.2 instead of 0.5 (its emission, 0.5, left out); used as
    // a control variate, the reading plus (path - field) / q is right on average for any
    // q > 0, and the paths end by chance, not at a depth that would bias them.
    auto scene = scenes::make_builtin("homogeneous-box", 0.34);
    scene.camera.width = scene.camera.height = 16;
    solver::RadianceField wrong;
    wrong.radiance.assign(scene.patch_list().size(), Rgb::Constant(0.7));
    const scenes::RayCaster caster(scene);
    const render::PinholeCamera camera(scene.camera);
    render::GatherOptions o = guide_only_gather();
    o.gather_rays = 256;
    o.filter.filter = render::Filter::none;
    o.correction = 0.0;
    const auto read = render::final_gather(scene, caster, wrong, camera, o, {});
    INFO("read as the answer: indirect " << mean_of(read.indirect) << ", image " << mean_of(read.image));
    // 0.2 where rays read the field; hits nearer than two patch sizes go on (near_hits).
    CHECK(mean_of(read.indirect) < 0.3);
    CHECK(mean_of(read.image) < 0.9);
    for (const double q : {0.25, 0.5, 1.0}) {
        o.correction = q;
        const auto r = render::final_gather(scene, caster, wrong, camera, o, {});
        INFO("q = " << q << ": indirect " << mean_of(r.indirect) << ", image " << mean_of(r.image) << ", gather rays "
                    << r.gather_rays << " (" << read.gather_rays << " without)");
        CHECK(mean_of(r.indirect) == Approx(0.5).epsilon(0.02));
        CHECK(mean_of(r.image) == Approx(1.0).epsilon(0.01));
        // Paths go on about 1 / (1 - 0.5) vertices past the first, where they go on.
        CHECK(r.gather_rays > read.gather_rays);
        CHECK(r.gather_rays < read.gather_rays * (1.0 + 4.0 * q));
    }
    // Not a probability: refused, not silently off (NaN, negative) or biased (above 1).
    for (const double q : {-0.1, 1.5, std::nan("")}) {
        o.correction = q;
        CHECK_THROWS_AS(render::final_gather(scene, caster, wrong, camera, o, {}), scenes::OptionError);
    }
}

TEST_CASE("final gather: the correction takes out light a field leaks through a wall", "[render][gather][correction]") {
    // The two rooms with the patches running on under the partition (not cut at the
    // contacts), so the field leaks the far room's light into the near one. The
    // corrected gather sees the near room black on average.
    const auto scene = two_rooms(false);
    const auto field = diffuse_shot_field(scene, 400);
    const scenes::RayCaster caster(scene);
    render::GatherOptions o = guide_only_gather();
    o.gather_rays = 64;
    o.filter.filter = render::Filter::none;
    o.correction = 0.0;
    const double leaked = mean_of(render::final_gather(scene, caster, field, render::PinholeCamera(scene.camera), o, {}).image);
    o.correction = 0.5;
    const double corrected = mean_of(render::final_gather(scene, caster, field, render::PinholeCamera(scene.camera), o, {}).image);
    INFO("near room's mean: " << leaked << " read from the field, " << corrected << " corrected");
    CHECK(leaked > 0.005);
    CHECK(std::abs(corrected) < leaked / 10.0);
}

TEST_CASE("final gather: the bias probe measures a wrong field's error and leaves the image as it was",
          "[render][gather][bias]") {
    // The homogeneous box with a field of 0.7 everywhere (the truth is 1): read as the
    // answer it makes the image about 0.86. The bias image's mean is an unbiased
    // estimate of that error (image - truth); with the right field it is about 0. The
    // probe draws from streams of its own: the image is bit for bit the same without it.
    auto scene = scenes::make_builtin("homogeneous-box", 0.34);
    scene.camera.width = scene.camera.height = 16;
    const scenes::RayCaster caster(scene);
    const render::PinholeCamera camera(scene.camera);
    render::GatherOptions o = guide_only_gather();
    o.gather_rays = 256;
    o.filter.filter = render::Filter::none;
    o.bias_probe = 0.25;
    o.corrected_image = true;
    for (const double level : {0.7, 1.0}) {
        solver::RadianceField field;
        field.radiance.assign(scene.patch_list().size(), Rgb::Constant(level));
        const auto r = render::final_gather(scene, caster, field, camera, o, {});
        const double error = mean_of(r.image) - 1.0, estimated = mean_of(r.bias);
        INFO("field " << level << ": image error " << error << ", bias image's mean " << estimated << ", probe rays "
                      << r.bias_rays << " beside " << r.gather_rays);
        if (level < 1.0) {
            CHECK(error < -0.1);
            CHECK(estimated == Approx(error).epsilon(0.1));
        } else {
            CHECK(std::abs(error) < 0.01);
            CHECK(std::abs(estimated) < 0.01);
        }
        CHECK(r.bias_rays > 0);
        CHECK(r.bias_rays < r.gather_rays);
        // The image as the correction at the probe's rate makes it: right on average
        // whatever the field; its bias image, with no filter, nothing.
        INFO("corrected image's mean " << mean_of(r.corrected));
        CHECK(std::abs(mean_of(r.corrected) - 1.0) < 0.01);
        CHECK(mean_of(r.corrected_bias) == 0.0);
        render::GatherOptions off = o;
        off.bias_probe = 0.0;
        const auto plain = render::final_gather(scene, caster, field, camera, off, {});
        CHECK(plain.image.rgb == r.image.rgb);
        CHECK(plain.bias_rays == 0);
        CHECK(plain.corrected.rgb.empty());
        CHECK(r.bias_probed);
        CHECK_FALSE(plain.bias_probed);
        CHECK(mean_of(plain.bias) == 0.0);  // no filter: only the probe has something to say
    }
    // With the correction on there is no field error in the image to probe.
    o.correction = 0.5;
    solver::RadianceField field;
    field.radiance.assign(scene.patch_list().size(), Rgb::Constant(0.7));
    CHECK(render::final_gather(scene, caster, field, camera, o, {}).bias_rays == 0);
    for (const double p : {-0.1, 1.5, std::nan("")}) {
        o.bias_probe = p;
        CHECK_THROWS_AS(render::final_gather(scene, caster, field, camera, o, {}), scenes::OptionError);
    }
}

TEST_CASE("final gather: camera samples take E from guides drawn like them, so a contact line is not biased",
          "[render][gather][contacts]") {
    // A floor (albedo 0.5) and a low wall (height 0.1, albedo 0) standing on it, seen
    // from above; a field of 1 on the wall and 0 on the floor, no lights. A floor point
    // at distance d from the wall's foot then shows 0.5 Omega(d) / pi, Lambert's
    // projected solid angle of the wall: half its maximum by d = 0.06, a steep and
    // curved profile across the few pixel rows next to the contact line. A camera
    // sample takes E from a guide: one drawn anywhere in its own pixel has the sample's
    // E as its mean, and where the pixel's guide met the wall, the nearest guide on the
    // floor stands in. With guides at the pixels' centres and the most similar of the
    // four around a sample (as the gather had it), the row the wall cuts came out 4.5 %
    // too bright against Lambert's formula, box-filtered, at any number of passes; now
    // every row is within 0.5 %.
    scenes::Scene s;
    scenes::Material floor_m, wall_m;
    floor_m.name = "floor";
    floor_m.albedo = Rgb::Constant(0.5);
    wall_m.name = "wall";
    wall_m.albedo = Rgb::Zero();
    const int fm = s.add_material(floor_m), wm = s.add_material(wall_m);
    s.add_object({{-2, 0, 0}, {-2, 0, 2}, {2, 0, 2}, {2, 0, 0}}, {{{0, 1, 2}}, {{0, 2, 3}}}, fm);
    s.add_object({{-2, 0, 0}, {2, 0, 0}, {2, 0.1, 0}, {-2, 0.1, 0}}, {{{0, 1, 2}}, {{0, 2, 3}}}, wm);
    s.camera.eye = Vec3(0, 0.5, 0.5);
    s.camera.target = Vec3(0, 0, 0.1);
    s.camera.fov_y = 30;
    s.camera.width = s.camera.height = 32;
    s.finalize();
    // The same wall as a lamp of radiance 1 gives Omega through AreaLights.
    scenes::Scene lamp = s;
    lamp.materials[static_cast<std::size_t>(wm)].emission = Rgb::Ones();
    const render::AreaLights wall(lamp);
    solver::RadianceField field;
    for (std::size_t p = 0; p < s.patch_list().size(); ++p) {
        const Rgb L = s.patch_list()[p].material == wm ? Rgb::Ones() : Rgb::Zero();
        field.radiance.push_back(L);
        field.corners.push_back({L, L, L});
    }
    const scenes::RayCaster caster(s);
    const render::PinholeCamera camera(s.camera);
    // The exact image: each pixel the mean over 16 x 16 points of it.
    const int W = 32, H = 32, sub = 16;
    std::vector<double> exact(static_cast<std::size_t>(W) * H, 0.0);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            for (int j = 0; j < sub; ++j)
                for (int i = 0; i < sub; ++i) {
                    const Vec3 d = camera.direction(x + (i + 0.5) / sub, y + (j + 0.5) / sub);
                    const auto hit = caster.intersect(camera.eye(), d);
                    if (!hit.valid() || s.patch_list()[static_cast<std::size_t>(hit.patch)].material != fm) continue;
                    const Vec3 point = camera.eye() + hit.t * d;
                    exact[static_cast<std::size_t>(y) * W + x] +=
                        0.5 * wall.irradiance(point, Vec3::UnitY())[0] / M_PI / (sub * sub);
                }
    // The gather's image, the mean of 16 passes (their own streams and guide points).
    render::GatherOptions o;
    o.gather_rays = 256;
    o.spp = 16;
    o.emission_samples = 0;
    o.near_hits = false;  // the field is the truth here: read it everywhere
    o.bias_probe = 0.0;
    o.filter.filter = render::Filter::none;
    std::vector<double> image(exact.size(), 0.0);
    const int passes = 16;
    for (int pass = 0; pass < passes; ++pass) {
        o.pass = static_cast<std::uint64_t>(pass);
        const auto r = render::final_gather(s, caster, field, camera, o, {});
        for (std::size_t k = 0; k < image.size(); ++k) image[k] += r.image.rgb[3 * k] / passes;
    }
    // Row by row (the contact line runs across the image), where the floor is lit.
    double worst = 0.0;
    int rows = 0;
    for (int y = 0; y < H; ++y) {
        double a = 0.0, b = 0.0;
        for (int x = 0; x < W; ++x) {
            a += image[static_cast<std::size_t>(y) * W + x];
            b += exact[static_cast<std::size_t>(y) * W + x];
        }
        if (b < 0.05 * W) continue;  // rows of wall, and of far floor (whose E is mostly noise)
        ++rows;
        worst = std::max(worst, std::abs(a / b - 1.0));
        INFO("row " << y << ": image " << a / W << ", Lambert " << b / W);
        CHECK(a == Approx(b).epsilon(0.015));
    }
    INFO("worst row " << worst);
    CHECK(rows >= 8);
}
