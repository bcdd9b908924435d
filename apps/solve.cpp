// `raybundle solve`: load -> check memory -> render::run -> write, and the summary line.
#include "cli.h"
#include "progress.h"
#include "render/ranks.h"
#include "render/signals.h"

#include "render/image_io.h"
#include "render/memory.h"
#include "render/output_set.h"
#include "render/patch_io.h"
#include "render/run_record.h"
#include "scenes/errors.h"

#include <chrono>
#include <cstdio>
#include <iostream>
#include <limits>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace raybundle::apps {

namespace {

// The outputs asked for, all written or none (render/output_set.h).
void write_outputs(const Command& c, const scenes::Scene& scene, const render::RunResult& r, double seconds_scene) {
    render::OutputSet outputs(render::signal_tracker());
    for (const auto& path : c.images)
        outputs.stage(path, [&](const std::string& tmp) { render::write_image(tmp, r.image, c.exposure, c.config.run.threads); });
    if (r.gather && !c.aov.empty()) {
        const auto& g = *r.gather;
        const render::Image* aovs[] = {&g.direct, &g.indirect, &g.indirect_filtered, &g.bias, &g.normal, &g.depth};
        static_assert(std::size(aovs) == kAovNames.size());
        for (std::size_t i = 0; i < kAovNames.size(); ++i)
            outputs.stage(c.aov + "/" + kAovNames[i] + ".exr",
                          [&](const std::string& tmp) { render::write_exr(tmp, *aovs[i]); });
    }
    if (r.field && !c.patches_csv.empty())
        outputs.stage(c.patches_csv, [&](const std::string& tmp) { render::write_patch_csv(tmp, scene, *r.field); });
    if (r.field && !c.ply.empty())
        outputs.stage(c.ply, [&](const std::string& tmp) { render::write_patch_ply(tmp, scene, *r.field, c.exposure); });
    if (r.field)
        for (const auto& path : c.baked)
            outputs.stage(path, [&](const std::string& tmp) { render::write_patch_glb(tmp, scene, *r.field, c.exposure); });
    if (!c.csv.empty()) outputs.stage(c.csv, [&](const std::string& tmp) { render::write_convergence_csv(tmp, r.rows); });
    const nlohmann::json record = render::stats_record(r, seconds_scene, c.config.run.threads);
    if (!c.stats.empty()) outputs.stage(c.stats, [&](const std::string& tmp) { render::write_json(tmp, record); });
    outputs.commit();
}

// The summary line: the run's (render/run_record.h) and the files written.
void print_summary(const Command& c, const scenes::Scene& scene, const render::RunResult& r) {
    std::vector<std::string> written = c.images;
    if (r.field) written.insert(written.end(), c.baked.begin(), c.baked.end());
    if (r.gather && !c.aov.empty()) written.push_back(c.aov + "/");
    const auto files = r.field ? std::vector<const std::string*>{&c.stats, &c.csv, &c.patches_csv, &c.ply}
                               : std::vector<const std::string*>{&c.csv, &c.stats};
    for (const auto* path : files)
        if (!path->empty()) written.push_back(*path);
    std::string wrote;
    for (const auto& path : written) wrote += (wrote.empty() ? "; wrote " : ", ") + path;
    if (written.empty()) wrote = "; wrote nothing (-o FILE.png writes the image)";
    std::printf("%s%s\n", render::summary(scene, r).c_str(), wrote.c_str());
}

}  // namespace

int solve(const Command& c, Ranks& ranks) {
#if defined(__GLIBC__)
    // What the run frees stays with the process, which ends after it: blocks up to
    // 32 MiB come from the heaps (not mappings of their own, unmapped when freed), and
    // no heap is given back (up to 2 GiB free). glibc gave them back heap by heap on one
    // thread: 3.8 ms as a run on two threads at 121k patches ended (the arenas of the
    // chains' threads), 6-11 ms at the teardown. The peak memory stays (318 MB there).
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max());
#endif
    render::install_signal_handlers();
    ProgressBar bar(c.quiet || !ranks.leader());
    render::RunConfig config = c.config;
    config.run.progress = [&](const sampling::Progress& p) { bar(p); };
    if (ranks.spread()) config.run.team = &ranks;
    const auto t_command = std::chrono::steady_clock::now();  // a time budget counts from here
    // The checkpoint to go on from: read first (a wrong file stops the run at once).
    try {
        if (ranks.spread()) render::require_spreadable(config, ranks.size());
        // Ranks on one machine share its memory: every rank bounds the checkpoint, the
        // scene and the run alike, by the least share.
        config.memory = scenes::memory_share(ranks.spread() ? &ranks : nullptr);
        if (!c.resume.empty()) config.resume = render::read_checkpoint(c.resume, config.memory);
        const auto t_scene = std::chrono::steady_clock::now();
        const scenes::Scene scene = load_scene(c, config.memory, bar, ranks.spread() ? &ranks : nullptr);
        const double seconds_scene = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_scene).count();
        render::check_outputs(c.outputs, render::with_scene_files(c.inputs, scene));  // its meshes too
        render::require_memory(config, scene);
        try {
            if (!c.reference.empty()) config.reference = render::read_reference(c.reference, scene);
        } catch (const scenes::OptionError& e) {
            throw UsageError("--reference " + e.problem());  // the problem names the file
        }
        render::RunHooks hooks;
        hooks.warn = [&](const std::string& line) {
            bar.clear();
            std::cerr << "raybundle: warning: " << scenes::printable(line) << "\n";
        };
        hooks.stoppable = [] { render::set_stoppable(true); };
        hooks.stop_requested = [] { return render::stop_requested(); };
        hooks.temporaries = render::signal_tracker();
        config.seconds_spent = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_command).count();
        const render::RunResult result = render::run(scene, config, hooks);
        bar.clear();
        if (!ranks.leader()) return result.signal != 0 ? 128 + result.signal : 0;
        // The scene as solved: refined where the run refined it (--refine).
        write_outputs(c, result.scene(scene), result, seconds_scene);
        if (!c.quiet) print_summary(c, result.scene(scene), result);
        // A signal that came while the outputs were written counts too.
        if (const int signal = result.signal != 0 ? result.signal : render::stop_requested(); signal != 0) {
            const bool cut = result.rounds.interrupted;
            std::cerr << "raybundle: " << render::signal_name(signal) << ": "
                      << (cut ? "stopped after " + std::to_string(result.steps) +
                                    (result.planned_steps > 0 ? " of " + std::to_string(result.planned_steps) : "") +
                                    " steps; the outputs are of the steps done (\"partial\" in the stats)"
                              : "the run was complete; its outputs are written")
                      << (cut && result.checkpointed >= 0 ? "; go on with --resume " + config.checkpoint : "") << "\n";
            return 128 + signal;
        }
        return 0;
    } catch (const render::RunInterrupted& e) {
        bar.clear();
        std::cerr << "raybundle: " << render::signal_name(e.signal) << ": " << e.what() << ", nothing written"
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
