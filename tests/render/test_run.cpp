// The run as a library call (render/run.h): every method through the one call the
// command line makes, the path tracer, the decisions it records, checkpoints of
// another run refused, and results that depend on the seed alone.
#include "../scenes/temp_dir.h"
#include "render/checkpoint.h"
#include "render/memory.h"
#include "render/output_set.h"
#include "render/run.h"
#include "scenes/builtin.h"
#include "solver/solver.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <filesystem>
#include <string>
#include <vector>

using namespace raybundle;

namespace {

scenes::Scene small_box() {
    auto scene = scenes::make_builtin("homogeneous-box", 0.25);
    scene.camera.width = scene.camera.height = 24;
    return scene;
}

render::RunConfig patch_image(const std::string& method, long steps) {
    render::RunConfig config;
    config.solver.method = method;
    config.solver.steps = steps;
    if (method != "iteration") config.solver.depth = 4;
    config.gather.gather_rays = 0;  // the patch image
    config.run.threads = 2;
    return config;
}

}  // namespace

TEST_CASE("run: every method converges on the homogeneous box within its known bias", "[render][run]") {
    // The exact radiance is 1; walks truncated at D = 4 bounces converge to 1 - 2^-5
    // (the diffuse shot, on by default in this diffuse scene with area lights, adds
    // the first bounce exactly: D + 1 bounces), stochastic iteration to 1. Each method
    // at a budget of about 2,000 visibility maps: its field's relative L1 error against
    // what it converges to within 3 %, its mean within 1 %, and the run's own estimate
    // of the error within a factor 3 of the true one.
    const auto method = GENERATE(from_range(solver::method_names()));
    const auto scene = small_box();
    const long steps = method == "iteration" ? 2000 : 500;
    const render::RunResult r = render::run(scene, patch_image(method, steps));
    const double exact = r.record.at("exact_radiance").get<double>();
    const double expected = method == "iteration" ? 1.0 : 1.0 - std::ldexp(1.0, -6);
    INFO(method << ": mean " << r.mean_radiance << ", converges to " << exact << ", error " << *r.error
                << ", estimated " << r.field_estimate);
    CHECK(exact == Approx(expected));
    REQUIRE(r.error);
    CHECK(*r.error < 0.03);
    CHECK(std::abs(r.mean_radiance - exact) < 0.01 * exact);
    CHECK(r.field_estimate > *r.error / 3.0);
    CHECK(r.field_estimate < *r.error * 3.0);
    CHECK(r.record.at("decisions").at("diffuse_shot_choice") == "on: a diffuse scene with area lights");
    CHECK(r.record.at("method") == method);
    CHECK(r.record.at("chains") == 2);
    CHECK(r.steps == steps);
    CHECK(r.planned_steps == steps);
    CHECK(r.record.at("steps_planned") == steps);
}

TEST_CASE("run: a target's rounds have no planned steps, and the stats say what ran", "[render][run]") {
    // The rounds go on as their estimates say, so --iterations is only the first round's
    // size: "steps_planned" is null, not that size, and "iterations" the steps run.
    auto config = patch_image("iteration", 200);
    config.rounds.target_error = 0.05;
    const render::RunResult r = render::run(small_box(), config);
    CHECK(r.planned_steps == 0);
    CHECK(r.record.at("steps_planned").is_null());
    CHECK(r.record.at("iterations") == r.steps);
    CHECK(r.steps > 0);
}

TEST_CASE("run: the same seed gives the same image for any thread count, another seed another", "[render][run]") {
    const auto scene = small_box();
    auto config = patch_image("bidirectional", 40);
    config.gather = render::GatherOptions{};  // the run's defaults
    config.gather.gather_rays = 4;
    config.gather.spp = 2;
    config.run.threads = 1;
    const auto a = render::run(scene, config);
    config.run.threads = 3;
    const auto b = render::run(scene, config);
    config.run.seed = 2;
    const auto c = render::run(scene, config);
    CHECK(a.image.rgb == b.image.rgb);
    bool same_field = a.field->radiance.size() == b.field->radiance.size();
    for (std::size_t i = 0; same_field && i < a.field->radiance.size(); ++i)
        same_field = (a.field->radiance[i] == b.field->radiance[i]).all();
    CHECK(same_field);
    CHECK(a.image.rgb != c.image.rgb);
    REQUIRE(a.gather);
    CHECK(a.record.at("final_gather").at("gather_rays") == 4);
}

TEST_CASE("run: the chains side by side give the field of chains in turn, and the stats time every phase",
          "[render][run]") {
    // One thread: the chains in turn. Two and more: side by side, each on its share of
    // the threads (render/progressive.h). Stochastic iteration batches its directions
    // by the thread count, walks draw theirs one walk at a time: both must not care.
    const auto method = GENERATE(as<std::string>{}, "iteration", "bidirectional");
    const auto scene = small_box();
    auto config = patch_image(method, method == "iteration" ? 120 : 30);
    config.gather = render::GatherOptions{};
    config.gather.gather_rays = 4;
    std::vector<render::RunResult> runs;
    for (int threads : {1, 2, 4}) {
        config.run.threads = threads;
        runs.push_back(render::run(scene, config));
    }
    for (std::size_t k = 1; k < runs.size(); ++k) {
        INFO(method << ", run " << k);
        CHECK(runs[k].image.rgb == runs[0].image.rgb);
        bool same = true;
        for (std::size_t i = 0; i < runs[0].field->radiance.size(); ++i)
            same = same && (runs[k].field->radiance[i] == runs[0].field->radiance[i]).all();
        CHECK(same);
    }
    CHECK_THAT(runs[0].record.at("decisions").at("threads").get<std::string>(),
               !Catch::Contains("side by side"));
    CHECK_THAT(runs[2].record.at("decisions").at("threads").get<std::string>(),
               Catch::Contains("the two chains side by side on 2 and 2 threads"));
    // The phases in order, each with its wall seconds and threads; together no longer
    // than the run.
    const auto& phases = runs[2].record.at("phases");
    std::vector<std::string> names;
    double sum = 0.0;
    for (const auto& p : phases) {
        names.push_back(p.at("phase"));
        CHECK(p.at("seconds").get<double>() >= 0.0);
        CHECK(p.at("threads") == 4);
        sum += p.at("seconds").get<double>();
    }
    CHECK(names == std::vector<std::string>{"ray_caster", "scene_check", "first_shot", "diffuse_shot", "setup", "solve",
                                            "gather_guides", "filter", "gather_samples"});
    CHECK(sum <= runs[2].record.at("seconds_total").get<double>());
}

TEST_CASE("run: the path tracer has no field, and a reference is compared", "[render][run][pathtrace]") {
    const auto scene = small_box();
    render::RunConfig config;
    config.solver.method = "pathtrace";
    config.path.spp = 8;
    config.run.threads = 2;
    const auto traced = render::run(scene, config);
    CHECK_FALSE(traced.field);
    CHECK(traced.record.at("method") == "pathtrace");
    // The homogeneous box is 1 everywhere: the path tracer's image too, within its noise.
    double mean = 0.0;
    for (float v : traced.image.rgb) mean += v / static_cast<double>(traced.image.rgb.size());
    CHECK(mean == Approx(1.0).epsilon(0.02));
    // Against itself as the reference: no error.
    config.reference = traced.image;
    config.reference_file = "itself.exr";
    const auto again = render::run(scene, config);
    REQUIRE(again.against);
    CHECK(again.against->relative_l1 == 0.0);
    CHECK(again.record.at("reference").at("file") == "itself.exr");
}

TEST_CASE("run: a checkpoint of another run is refused, naming the file and the difference", "[render][run]") {
    const auto scene = small_box();
    auto config = patch_image("iteration", 50);
    config.identity = {{"--iterations", {"50"}}};
    render::Checkpoint other;
    other.identity = render::run_identity({{"--iterations", {"60"}}}, scene);
    config.resume = other;
    config.resume_file = "other.ckpt";
    CHECK_THROWS_WITH(render::run(scene, config),
                      Catch::StartsWith("other.ckpt: made by another run: --iterations was 60, now 50"));
}

TEST_CASE("run: a checkpoint of an older format, and what a team cannot do, are refused in one line", "[render][run]") {
    test::TempDir dir;
    const std::string old = dir.write("old.ckpt", "raybundle checkpoint 1\n" + std::string(64, '\0'));
    CHECK_THROWS_WITH(render::read_checkpoint(old),
                      Catch::Contains("old.ckpt") && Catch::Contains("a checkpoint of format 1") &&
                          Catch::Contains("this one reads format 2"));
    auto config = patch_image("iteration", 50);
    CHECK_NOTHROW(render::require_spreadable(config, 2));
    CHECK_THROWS_WITH(render::require_spreadable(config, 1000), Catch::StartsWith("1000 ranks: at most"));
    config.rounds.time_budget = 5.0;
    CHECK_THROWS_WITH(render::require_spreadable(config, 2), Catch::StartsWith("--time-budget on 2 ranks"));
    config = patch_image("iteration", 50);
    config.checkpoint = "c.ckpt";
    CHECK_THROWS_WITH(render::require_spreadable(config, 2), Catch::StartsWith("--checkpoint works in one process"));
    config = patch_image("pathtrace", 1);
    CHECK_THROWS_WITH(render::require_spreadable(config, 2), Catch::StartsWith("--method pathtrace runs in one process"));
}

TEST_CASE("run: the memory guards count the process's share of its machine", "[render][run][memory]") {
    test::TempDir dir;
    // Three ranks on node1, 30 MB among them: a 2048 x 2048 image needs more than 10 MB.
    const scenes::MemoryShare shared{10'000'000, 30'000'000, 3, "node1"};
    auto config = patch_image("iteration", 50);
    config.memory = shared;
    auto scene = small_box();
    scene.camera.width = scene.camera.height = 2048;
    CHECK_THROWS_WITH(render::require_memory(config, scene),
                      Catch::Contains("the machine node1 has 30 MB for 3 ranks: try"));
    config.memory.bytes = 0;  // unknown: no bound
    CHECK_NOTHROW(render::require_memory(config, scene));
    // A checkpoint past half of the share is refused before it is read.
    std::string big = "raybundle checkpoint 2\n";
    big.resize(6'000'000, '\0');
    const std::string path = dir.write("big.ckpt", big);
    CHECK_THROWS_WITH(render::read_checkpoint(path, shared),
                      Catch::Contains("big.ckpt") &&
                          Catch::Contains("6 MB, more than half of the 10 MB this process may hold (the machine node1 "
                                          "has 30 MB for 3 ranks)"));
}

TEST_CASE("checkpoints: a header of the wrong types or out of range is refused, naming the file and the value",
          "[render][checkpoint]") {
    test::TempDir dir;
    const auto scene = small_box();
    const render::Checkpoint good{render::run_identity({{"--iterations", {"50"}}}, scene), 10, 1.5,
                                  nlohmann::json::array(), {"a", "b"}};
    auto refused = [&](const std::string& name, render::Checkpoint k) {
        const std::string path = (dir.path / (name + ".ckpt")).string();
        render::write_checkpoint(path, k);
        try {
            render::read_checkpoint(path);
        } catch (const render::CheckpointError& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    CHECK(refused("good", good) == "accepted");
    render::Checkpoint k = good;
    k.identity = 5;
    CHECK_THAT(refused("type", k), Catch::StartsWith((dir.path / "type.ckpt").string()) &&
                                       Catch::Contains("identity: not an object"));
    k = good;
    k.identity["scene"]["patches"] = "many";
    CHECK_THAT(refused("patches", k), Catch::Contains("identity.scene"));
    k = good;
    k.identity["options"]["--iterations"] = {50};
    CHECK_THAT(refused("options", k), Catch::Contains("identity.options.--iterations: not a list of strings"));
    k = good;
    k.seconds = std::nan("");
    CHECK_THAT(refused("nan", k), Catch::Contains("seconds"));
    k.seconds = -1.0;
    CHECK_THAT(refused("negative", k), Catch::Contains("seconds"));
    k.seconds = 1e308;
    CHECK_THAT(refused("huge", k), Catch::Contains("seconds"));
    k = good;
    k.steps_done = -3;
    CHECK_THAT(refused("steps", k), Catch::Contains("steps_done"));
    k = good;
    k.rows = nlohmann::json::object();
    CHECK_THAT(refused("rows", k), Catch::Contains("rows: not a list"));
}

TEST_CASE("checkpoints: a chain whose counters differ from the header's, and non-finite state, are refused",
          "[render][checkpoint]") {
    test::TempDir dir;
    const auto scene = small_box();
    auto checkpointed = [&](long steps, const std::string& name) {
        auto config = patch_image("iteration", steps);
        config.checkpoint = (dir.path / name).string();
        config.checkpoint_steps = 1;  // at every pause: the last one holds every step
        render::run(scene, config);
        return render::read_checkpoint(config.checkpoint);
    };
    const render::Checkpoint a = checkpointed(64, "a.ckpt"), b = checkpointed(128, "b.ckpt");
    REQUIRE(a.steps_done == 32);
    REQUIRE(b.steps_done == 64);
    auto resumed = [&](const render::Checkpoint& k) {
        const std::string path = (dir.path / "forged.ckpt").string();
        render::write_checkpoint(path, k);  // a checksum of its own: only the contents can tell
        auto config = patch_image("iteration", 128);
        config.resume = render::read_checkpoint(path);
        config.resume_file = path;
        render::run(scene, config);
    };
    CHECK_NOTHROW(resumed(b));
    render::Checkpoint forged = b;
    forged.states[1] = a.states[1];  // chain 1 of a run half as long
    CHECK_THROWS_WITH(resumed(forged), Catch::Contains("chain 1 counts 32 steps done") &&
                                           Catch::Contains("the header says 64"));
    // A value of the state that is not finite, with a valid checksum: a state ends with
    // its counters (solver/solver.cpp), the transport's seconds then the entries.
    forged = b;
    const double inf = std::numeric_limits<double>::infinity();
    std::memcpy(forged.states[0].data() + forged.states[0].size() - 2 * sizeof inf, &inf, sizeof inf);
    CHECK_THROWS_WITH(resumed(forged), Catch::Contains("chain 0") && Catch::Contains("not finite"));
}

TEST_CASE("outputs: an input by another name, a mesh of the scene, and names too long are refused",
          "[render][outputs]") {
    test::TempDir dir;
    const std::string scene_file = dir.write("s.json", "{}"), mesh = dir.write("m.obj", "v 0 0 0\n");
    std::filesystem::create_hard_link(scene_file, dir.path / "link.json");
    const std::vector<render::NamedFile> inputs = {{scene_file, "the scene file"}};
    CHECK_THROWS_WITH(render::check_outputs({{(dir.path / "link.json").string(), "--stats"}}, inputs),
                      Catch::EndsWith("is the scene file (it would be overwritten)"));
    scenes::Scene scene;
    scene.name = scene_file;
    scene.files = {scene_file, mesh};
    CHECK_THROWS_WITH(render::check_outputs({{mesh, "--patches"}}, render::with_scene_files({}, scene)),
                      Catch::Contains("is a mesh of the scene"));
    CHECK_NOTHROW(render::check_outputs({{(dir.path / "out.exr").string(), "-o"}}, render::with_scene_files({}, scene)));
    const std::string long_name = (dir.path / (std::string(230, 'x') + ".exr")).string();
    CHECK_THROWS_WITH(render::check_outputs({{long_name, "-o"}}, {}), Catch::Contains("a name of 234 bytes"));
    const std::string long_dir = (dir.path / std::string(300, 'd') / "x.exr").string();
    CHECK_THROWS_WITH(render::check_outputs({{long_dir, "-o"}}, {}), Catch::Contains("a name of 300 bytes"));
}

TEST_CASE("run: a stop asked for ends the solve at the next pause, the image made from the steps done",
          "[render][run]") {
    const auto scene = small_box();
    auto config = patch_image("walk", 400);
    render::RunHooks hooks;
    bool stoppable = false;
    hooks.stoppable = [&] { stoppable = true; };
    // Asked for from the 20th look on (the chains side by side look before each step;
    // a stop asked for before the first step begins none, and a run with no step
    // averaged has no image).
    int looks = 0;
    hooks.stop_requested = [&] { return ++looks >= 20 ? 15 : 0; };
    const auto r = render::run(scene, config, hooks);
    CHECK(stoppable);
    CHECK(r.signal == 15);
    CHECK(r.rounds.interrupted);
    CHECK(r.steps > 0);
    CHECK(r.steps < r.planned_steps);
    CHECK(r.record.at("partial") == true);
    CHECK(r.checkpointed == -1);  // none asked for
}

TEST_CASE("run: without checkpoints, the chains side by side read a stop at every step, not at pauses",
          "[render][run]") {
    // 400 steps per chain on 2 threads, the stop asked for once the progress reaches
    // 100 steps: both chains stop at one count, within their window of steps under way
    // (4 each) and their difference in speed of it. At pauses (the first after 16
    // steps per chain, the next as far apart as the clock allows: here the rest of the
    // round) it would have been read only after all 800. On a loaded machine the
    // threads run on after the progress that asks (with a busy loop beside the test, 4
    // of 28 runs went past 160, up to 180 steps): half the run is the bound.
    const auto scene = small_box();
    auto config = patch_image("iteration", 800);
    std::atomic<bool> asked{false};
    config.run.progress = [&](const sampling::Progress& p) {
        if (std::strcmp(p.phase, "solve") == 0 && p.done >= 100) asked = true;
    };
    render::RunHooks hooks;
    hooks.stop_requested = [&] { return asked ? 15 : 0; };
    const auto r = render::run(scene, config, hooks);
    CHECK(r.signal == 15);
    CHECK(r.rounds.interrupted);
    CHECK(r.record.at("partial") == true);
    CHECK(r.steps % 2 == 0);  // both chains at one count
    CHECK(r.steps >= 100);
    CHECK(r.steps <= 400);
    // Never asked: the same image as where no stop can be asked for (pauses instead).
    hooks.stop_requested = [] { return 0; };
    config.run.progress = nullptr;
    const auto read = render::run(scene, config, hooks);
    const auto paused = render::run(scene, config);
    CHECK(read.steps == 800);
    CHECK(read.image.rgb == paused.image.rgb);
}

TEST_CASE("run: a warning that repeats is passed on once, then with its count", "[render][run]") {
    const auto scene = small_box();
    auto config = patch_image("iteration", 256);  // 4 pauses of 32 steps per chain on 2 threads
    config.checkpoint = "/dev/null/c.ckpt";  // cannot be written: fails at every pause
    config.checkpoint_steps = 1;
    std::vector<std::string> warnings;
    render::RunHooks hooks;
    hooks.warn = [&](const std::string& line) { warnings.push_back(line); };
    render::run(scene, config, hooks);
    REQUIRE(warnings.size() == 2);
    CHECK_THAT(warnings[0], Catch::StartsWith("checkpoint /dev/null/c.ckpt") && Catch::EndsWith("the run goes on"));
    CHECK(warnings[1].rfind(warnings[0] + " (", 0) == 0);
    CHECK_THAT(warnings[1], Catch::EndsWith(" times)"));
    CHECK(std::stol(warnings[1].substr(warnings[0].size() + 2)) >= 2);
}
