// `raybundle solve`: load -> check memory -> render::run -> write, and the summary line.
#include "cli.h"
#include "outputs.h"
#include "progress.h"
#include "ranks.h"
#include "signals.h"

#include "render/image_io.h"
#include "render/memory.h"
#include "render/patch_io.h"
#include "render/run_record.h"
#include "sampling/streams.h"

#include <algorithm>
#include <cstdio>
#include <iostream>

namespace raybundle::apps {

namespace {

// What a run spread over ranks cannot do: one line, before any work.
void require_spreadable(const Command& c, const Ranks& ranks) {
    const std::string n = std::to_string(ranks.size());
    if (c.config.solver.method == "pathtrace")
        throw UsageError("--method pathtrace runs in one process: it is the reference, not spread over " + n + " ranks");
    if (c.config.rounds.time_budget > 0.0)
        throw UsageError("--time-budget on " + n + " ranks: how far the rounds go would depend on the machines' speed; "
                         "give --iterations or --target-error");
    if (!c.config.checkpoint.empty() || !c.resume.empty())
        throw UsageError(std::string(c.config.checkpoint.empty() ? "--resume" : "--checkpoint") +
                         " works in one process, not on " + n + " ranks");
    if (2 * static_cast<std::uint64_t>(ranks.size()) > sampling::streams::kMaxChains)
        throw UsageError(n + " ranks: at most " + std::to_string(sampling::streams::kMaxChains / 2) +
                         " (two independent chains each)");
}

std::string gigabytes(double bytes) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f GB", bytes / 1e9);
    return text;
}

// A run that cannot fit is refused before any work (render/memory.h), naming what to
// make smaller.
void require_memory(const Command& c, const scenes::Scene& scene) {
    const std::uint64_t available = render::memory_available();
    const render::MemoryNeed need = render::memory_need(c.config, scene);
    if (available == 0 || need.bytes <= static_cast<double>(available)) return;
    const std::string largest = need.pixels >= std::max(need.patches, need.maps)
                                    ? "a smaller image (--width, --height)"
                                : need.patches >= need.maps ? "larger patches (--patch-size)"
                                                            : "a smaller --resolution or another --visibility";
    throw UsageError(scene.name + ": " + std::to_string(scene.camera.width) + "x" + std::to_string(scene.camera.height) +
                     " pixels and " + std::to_string(scene.patch_count()) + " patches need about " +
                     gigabytes(need.bytes) + " (pixels " + gigabytes(need.pixels) + ", patches " +
                     gigabytes(need.patches) + ", maps " + gigabytes(need.maps) + "), this machine has " +
                     gigabytes(static_cast<double>(available)) + ": try " + largest);
}

// --reference: read before any work, so that a wrong size stops the run at once.
std::optional<render::Image> load_reference(const Command& c, const scenes::Scene& scene) {
    if (c.reference.empty()) return std::nullopt;
    render::Image ref;
    try {
        ref = render::read_exr(c.reference);
    } catch (const std::runtime_error& e) {
        throw UsageError(std::string("--reference ") + e.what());
    }
    if (ref.width != scene.camera.width || ref.height != scene.camera.height)
        throw UsageError("--reference " + c.reference + ": " + std::to_string(ref.width) + "x" +
                         std::to_string(ref.height) + " pixels, the image is " + std::to_string(scene.camera.width) +
                         "x" + std::to_string(scene.camera.height));
    return ref;
}

// The outputs asked for, all written or none (apps/outputs.h).
void write_outputs(const Command& c, const scenes::Scene& scene, const render::RunResult& r) {
    render::OutputSet outputs(signal_tracker());
    for (const auto& path : c.images)
        outputs.stage(path, [&](const std::string& tmp) { render::write_image(tmp, r.image, c.exposure); });
    if (r.gather && !c.aov.empty()) {
        const auto& g = *r.gather;
        const render::Image* aovs[] = {&g.direct, &g.indirect, &g.indirect_filtered, &g.normal, &g.depth};
        static_assert(std::size(aovs) == kAovNames.size());
        for (std::size_t i = 0; i < kAovNames.size(); ++i)
            outputs.stage(c.aov + "/" + kAovNames[i] + ".exr",
                          [&](const std::string& tmp) { render::write_exr(tmp, *aovs[i]); });
    }
    if (r.field && !c.patches_csv.empty())
        outputs.stage(c.patches_csv, [&](const std::string& tmp) { render::write_patch_csv(tmp, scene, *r.field); });
    if (r.field && !c.ply.empty())
        outputs.stage(c.ply, [&](const std::string& tmp) { render::write_patch_ply(tmp, scene, *r.field, c.exposure); });
    if (!c.csv.empty()) outputs.stage(c.csv, [&](const std::string& tmp) { render::write_convergence_csv(tmp, r.rows); });
    nlohmann::json record = r.record;
    if (r.signal != 0) record["interrupted_by"] = signal_name(r.signal);
    if (!c.stats.empty()) outputs.stage(c.stats, [&](const std::string& tmp) { render::write_json(tmp, record); });
    outputs.commit();
}

// The summary line.
void print_summary(const Command& c, const scenes::Scene& scene, const render::RunResult& r) {
    if (!r.field) {
        std::printf("%s: %zu patches, path traced %ld paths per pixel in %.2f s", scene.name.c_str(),
                    scene.patch_count(),
                    r.record["path_trace"]["paths"].get<long>() / (static_cast<long>(scene.camera.width) * scene.camera.height),
                    r.record["seconds_render"].get<double>());
    } else {
        std::printf("%s: %zu patches, %s %ld steps in %.2f s", scene.name.c_str(), scene.patch_count(),
                    r.report.method.c_str(), r.report.steps, r.rounds.seconds_solve);
        if (r.gather) std::printf(", final gather %.2f s", r.rounds.seconds_render);
        std::printf(", mean radiance %.6g", r.mean_radiance);
        if (r.error) std::printf(", relative L1 error %.3g", *r.error);
    }
    if (r.rounds.estimate >= 0.0)
        std::printf(", estimated error %.2g %% (%zu round%s)", 100.0 * r.rounds.estimate, r.rounds.rounds.size(),
                    r.rounds.rounds.size() == 1 ? "" : "s");
    if (r.against)
        std::printf(", against the reference: relative L1 %.4g, MSE %.4g", r.against->relative_l1, r.against->mse);
    std::vector<std::string> written = c.images;
    if (r.gather && !c.aov.empty()) written.push_back(c.aov + "/");
    const auto files = r.field ? std::vector<const std::string*>{&c.stats, &c.csv, &c.patches_csv, &c.ply}
                               : std::vector<const std::string*>{&c.csv, &c.stats};
    for (const auto* path : files)
        if (!path->empty()) written.push_back(*path);
    std::string wrote;
    for (const auto& path : written) wrote += (wrote.empty() ? "" : ", ") + path;
    if (!wrote.empty()) std::printf("; wrote %s", wrote.c_str());
    std::printf("\n");
}

}  // namespace

int solve(const Command& c, Ranks& ranks) {
    install_signal_handlers();
    if (ranks.spread()) require_spreadable(c, ranks);
    ProgressBar bar(c.quiet || !ranks.leader());
    render::RunConfig config = c.config;
    config.run.progress = [&](const sampling::Progress& p) { bar(p); };
    if (ranks.spread()) config.run.team = &ranks;
    // The checkpoint to go on from: read first (a wrong file stops the run at once).
    try {
        if (!c.resume.empty()) config.resume = render::read_checkpoint(c.resume);
        const scenes::Scene scene = load_scene(c);
        require_memory(c, scene);
        config.reference = load_reference(c, scene);
        render::RunHooks hooks;
        hooks.warn = [&](const std::string& line) {
            bar.clear();
            std::cerr << "raybundle: warning: " << line << "\n";
        };
        hooks.stoppable = [] { set_stoppable(true); };
        hooks.stop_requested = [] { return stop_requested(); };
        hooks.temporaries = signal_tracker();
        const render::RunResult result = render::run(scene, config, hooks);
        bar.clear();
        if (!ranks.leader()) return result.signal != 0 ? 128 + result.signal : 0;
        write_outputs(c, scene, result);
        if (!c.quiet) print_summary(c, scene, result);
        if (result.signal != 0) {
            const bool cut = result.rounds.interrupted;
            std::cerr << "raybundle: " << signal_name(result.signal) << ": "
                      << (cut ? "stopped after " + std::to_string(result.steps) + " of " +
                                    std::to_string(result.planned_steps) +
                                    " steps; the outputs are of the steps done (\"partial\" in the stats)"
                              : "the run was complete; its outputs are written")
                      << (cut && result.checkpointed >= 0 ? "; go on with --resume " + config.checkpoint : "") << "\n";
            return 128 + result.signal;
        }
        return 0;
    } catch (const render::RunInterrupted& e) {
        bar.clear();
        std::cerr << "raybundle: " << signal_name(e.signal) << ": " << e.what() << ", nothing written"
                  << (e.checkpointed >= 0 ? "; the checkpoint " + config.checkpoint + " holds the steps done" : "")
                  << "\n";
        return 128 + e.signal;
    } catch (const render::CheckpointError& e) {
        throw UsageError(std::string("--resume ") + e.what());
    } catch (const render::RunError& e) {
        throw UsageError(e.what());
    }
}

}  // namespace raybundle::apps
