#include "render/run_record.h"

#include "render/filters.h"
#include "render/image_io.h"
#include "render/signals.h"
#include "visibility/backend.h"
#include "visibility/exact_spans.h"

#include <algorithm>
#include <fstream>
#include <stdexcept>
#include <utility>

#ifndef RAYBUNDLE_VERSION
#define RAYBUNDLE_VERSION "unknown"
#endif

namespace raybundle::render {

using json = nlohmann::json;

namespace {

// The values a convergence row may have, by their names in a checkpoint.
constexpr std::pair<const char*, std::optional<double> ConvergenceRow::*> kRowValues[] = {
    {"error", &ConvergenceRow::error},
    {"mean", &ConvergenceRow::mean},
    {"estimate", &ConvergenceRow::estimate},
    {"image_estimate", &ConvergenceRow::image_estimate},
    {"image_l1", &ConvergenceRow::image_l1},
    {"image_mse", &ConvergenceRow::image_mse},
    {"image_block4_l1", &ConvergenceRow::image_block4_l1},
    {"image_worst_block16", &ConvergenceRow::image_worst_block16}};

json rounds_record(const Rounds& r, const RoundOptions& o) {
    json rounds = json::array();
    for (const auto& k : r.rounds) {
        rounds.push_back({{"scale", k.scale},
                          {"correction", k.correction},
                          {"corrected", k.corrected},
                          {"steps_share", k.steps},  // of the options' steps (a fraction, not a count)
                          {"seconds", k.seconds},
                          {"estimated_error", k.estimate},
                          {"estimated_noise", k.parts.noise},
                          {"estimated_probed", k.parts.probed},
                          {"estimated_bias", k.parts.bias},
                          {"estimated_shared_bias", k.parts.shared}});
        if (k.corrected_noise >= 0.0) rounds.back()["estimated_corrected_noise"] = k.corrected_noise;
        if (k.plan.reading > 0.0)
            rounds.back()["correction_plan"] =
                json{{"q", k.plan.q}, {"predicted", k.plan.predicted}, {"reading", k.plan.reading}};
    }
    json out = {{"image_estimated_error", r.estimate},
                {"image_estimated_noise", r.parts.noise},
                {"image_estimated_probed", r.parts.probed},
                {"image_estimated_bias", r.parts.bias},
                {"image_estimated_shared_bias", r.parts.shared},
                {"scale", r.scale},
                {"stopped", r.stopped},
                {"rounds", rounds}};
    if (r.field_share >= 0.0) {
        out["field_share"] = r.field_share;
        out["steps_share"] = r.steps_share;
    }
    if (o.target_error > 0.0) out["target_error"] = o.target_error;
    if (o.time_budget > 0.0) out["time_budget"] = o.time_budget;
    return out;
}

// The scene, the solver's report and the shots' decisions.
json solve_record(const scenes::Scene& scene, const RunConfig& c, const solver::SolverReport& report,
                  const solver::Transport& transport, std::size_t coplanar_overlaps) {
    const auto& v = report.visibility;
    const bool gather = c.gather.gather_rays > 0;
    std::string sky = "none: the scene has no sky (no sky entries in the maps)";
    if (scene.sky)
        sky = std::string(scene.sky->model == scenes::Sky::Model::constant ? "constant" : "CIE overcast") +
              " sky: map pixels that no patch covers upstream carry the sky radiance";
    json decisions = transport.decisions();
    decisions["sky"] = sky;
    if (!scene.refinement.empty()) decisions["patch_size"] = scene.refinement;
    decisions["contacts"] = contacts_line(scene);
    decisions["threads"] = "visibility: " + std::to_string(v.threads) +
                           (v.threads < c.run.threads ? " (this backend runs one at a time)" : "") +
                           " (one backend each; the light moves in order, so any count gives the same result)" +
                           (gather ? "; final gather and filters: " + std::to_string(c.run.threads) : "");
    for (const auto& [key, value] : report.decisions.items()) decisions[key] = value;
    json stats = {
        {"scene", scene.name},
        {"patches", scene.patch_count()},
        {"dropped_degenerate_triangles", scene.dropped_degenerate},
        {"welded_vertices", scene.welded_vertices},
        {"contacts", {{"lines", scene.contact_lines}, {"edges_split", scene.contact_splits},
                      {"contact_edges", scene.contact_edges}}},
        {"coplanar_overlaps", coplanar_overlaps},
        {"method", report.method},
        {"basis", c.solver.basis},
        {"iterations", report.steps},
        {"directions", report.directions},
        {"visibility", v.backend},
        {"visibility_details", v.details},
        {"visibility_exact", v.exact},
        {"resolution", v.resolution},
        {"seed", c.run.seed},
        {"threads", v.threads},
        {"threads_requested", c.run.threads},
        {"image", {{"width", scene.camera.width}, {"height", scene.camera.height}, {"shading", shading_name(c.shading)}}},
        {"seconds_first_shot", transport.shot_stats().seconds},
        {"seconds_diffuse_shot", transport.shot_stats().diffuse_seconds},
        {"seconds_visibility", report.seconds_visibility},
        {"seconds_transport", report.seconds_transport},
        {"geometry_entries_per_direction",
         report.directions > 0 ? static_cast<double>(report.entries_total) / report.directions : 0.0},
        {"memory_per_patch_bytes", report.bytes_per_patch},
        {"decisions", decisions},
    };
    if (report.method != "iteration") stats["walks"] = report.steps;
    for (const auto& [key, value] : report.details.items()) stats[key] = value;
    return stats;
}

// The final gather's settings and figures.
json gather_record(const RunConfig& c, const GatherResult& g) {
    const auto& o = c.gather;
    return {{"gather_rays", o.gather_rays},
            {"direct_samples", o.direct_samples},
            {"direct", direct_light_name(o.direct)},
            {"direct_at_hits", o.direct_at_hits},
            {"glossy_rays", o.glossy_rays},
            {"correction", c.auto_correction && o.correction == 0.0 && o.bias_probe > 0.0 ? json("auto") : json(o.correction)},
            {"bias_probe", o.correction > 0.0 ? 0.0 : o.bias_probe},
            {"spp", o.spp},
            {"emission_samples", o.emission_samples},
            {"filter", filter_name(o.filter.filter)},
            {"filter_radius", g.filter_radius},
            {"eps_normal", o.filter.eps_normal},
            {"eps_depth", o.filter.eps_depth},
            {"threads", c.run.threads},
            {"camera_rays", g.camera_rays},
            {"shadow_rays", g.shadow_rays},
            {"gather_rays_total", g.gather_rays},
            {"bias_probe_rays", g.bias_rays},
            {"direct_at_hits_patches", g.direct_at_hits},
            {"lookups", g.lookups},
            {"lookups_across_depth", g.lookups_across},
            {"seconds_guides", g.seconds_guides},
            {"seconds_filter", g.seconds_filter},
            {"seconds_samples", g.seconds_samples}};
}

}  // namespace

json field_run_record(const scenes::Scene& scene, const RunConfig& c, const solver::Transport& transport,
                      const RunResult& r, const FieldRunFacts& facts) {
    json stats = solve_record(scene, c, r.report, transport, facts.coplanar_overlaps);
    const double seconds_solve = r.rounds.seconds_solve, seconds_render = r.rounds.seconds_render;
    stats["chains"] = 2 * facts.members;
    stats["ranks"] = facts.members;
    stats["seconds_total"] = facts.seconds_total;
    stats["seconds_solve"] = seconds_solve;
    stats["seconds_render"] = seconds_render;
    stats["phases"] = facts.phases;
    if (facts.side_by_side) {
        const int t = c.run.threads;
        stats["decisions"]["threads"] =
            "the two chains side by side on " + std::to_string((t + 1) / 2) + " and " + std::to_string(t / 2) +
            " threads (one backend each; a thread free takes either chain's next step where the method allows, "
            "solver/pipeline.h; each chain's light moves in order, so any count gives the same result)" +
            (r.gather ? "; final gather and filters: " + std::to_string(t) : "");
    }
    // This run's steps only (a resumed run's solver counts the steps before it too).
    const long steps_here = r.steps - 2 * facts.resume_steps;
    const double directions_per_step =
        r.report.steps > 0 ? static_cast<double>(r.report.directions) / r.report.steps : 1.0;
    stats["seconds_per_iteration"] = steps_here > 0 ? seconds_solve / steps_here : 0.0;
    stats["seconds_per_direction"] = steps_here > 0 ? seconds_solve / (steps_here * directions_per_step) : 0.0;
    stats["mean_radiance"] = r.mean_radiance;
    if (r.gather) stats["final_gather"] = gather_record(c, *r.gather);
    json estimate = rounds_record(r.rounds, c.rounds);
    estimate["field_estimated_error"] = r.field_estimate;
    stats["estimate"] = estimate;
    stats["decisions"]["diffuse_shot_choice"] = facts.shot_choice;
    stats["decisions"]["image"] = r.gather ? "final gather: direct light per sample, indirect at guide rays, " +
                                                 std::string(filter_name(c.gather.filter.filter)) + " filter"
                                           : std::string("the patch radiance (") + shading_name(c.shading) +
                                                 " shading); --gather N for a final gather";
    stats["decisions"]["rounds"] = r.rounds.stopped;
    if (r.gather) {
        const auto& g = c.gather;
        std::string line;
        if (!r.rounds.correction_choice.empty())
            line = "auto: " + r.rounds.correction_choice + (r.rounds.corrected ? "; the image is corrected" : "; the image reads the field");
        else if (g.correction > 0.0)
            line = "the field as a control variate at q = " + json(g.correction).dump() + " (--correction)";
        else if (c.auto_correction)
            line = "the field read as the answer: auto needs the bias probe (--bias-probe 0)";
        else
            line = "the field read as the answer (--correction 0)";
        stats["decisions"]["correction"] = line;
        const long at = r.gather->direct_at_hits;
        stats["decisions"]["gather_hits"] =
            at > 0 ? "direct light sampled at the hit point on " + std::to_string(at) + " of " +
                         std::to_string(scene.patch_count()) +
                         " patches (the shots' light varies across them: shadows' edges, contacts); elsewhere the field is read"
            : at == 0 ? std::string("the field is read: the shots' light varies across no patch")
            : !g.direct_at_hits ? std::string("the field is read (direct_at_hits off)")
                                : std::string("the field is read: it keeps no direct part apart (no shot, area lights without "
                                              "the diffuse shot, or the linear basis)");
        stats["estimate"]["correction"] = r.rounds.correction;
        stats["estimate"]["corrected"] = r.rounds.corrected || g.correction > 0.0;
    }
    stats["partial"] = r.rounds.interrupted;
    stats["steps_planned"] = r.planned_steps > 0 ? nlohmann::json(r.planned_steps) : nlohmann::json();
    if (c.resume)
        stats["resumed"] = {{"checkpoint", c.resume_file},
                            {"steps_done", 2 * c.resume->steps_done},
                            {"seconds_before", facts.seconds_before}};
    if (!c.checkpoint.empty())
        stats["checkpoint"] = {{"file", c.checkpoint}, {"steps", 2 * std::max(0L, r.checkpointed)}};
    if (facts.exact) {
        stats["exact_radiance"] = *facts.exact;
        stats["relative_l1_error"] = *r.error;
    }
    record_reference(stats, c, r.against);
    return stats;
}

json path_trace_record(const scenes::Scene& scene, const RunConfig& c, const TracedImage& traced,
                       double seconds_total) {
    return {{"scene", scene.name},
            {"patches", scene.patch_count()},
            {"method", "pathtrace"},
            {"seed", c.run.seed},
            {"threads_requested", c.run.threads},
            {"image", {{"width", scene.camera.width}, {"height", scene.camera.height}}},
            {"path_trace", {{"spp", c.path.spp}, {"paths", traced.traced.paths}, {"rays", traced.traced.rays}}},
            {"estimate", rounds_record(traced.rounds, c.rounds)},
            {"seconds_render", traced.traced.seconds},
            {"seconds_total", seconds_total},
            {"decisions",
             {{"image", "brute-force path tracing: next-event estimation and BRDF sampling with the balance "
                        "heuristic, Russian roulette; unbiased (render/path_tracer.h)"},
              {"rounds", traced.rounds.stopped}}}};
}

void record_reference(json& record, const RunConfig& c, const std::optional<ImageError>& against) {
    if (against)
        record["reference"] = {{"file", c.reference_file},
                               {"relative_l1", against->relative_l1},
                               {"mse", against->mse},
                               {"block4_relative_l1", against->block4_l1},
                               {"worst_block16", against->worst_block16}};
}

json stats_record(const RunResult& r, double seconds_scene, int threads) {
    json record = r.record;
    if (record.contains("phases"))
        record["phases"].insert(record["phases"].begin(),
                                json::object({{"phase", "scene"}, {"seconds", seconds_scene}, {"threads", threads}}));
    if (r.signal != 0) record["interrupted_by"] = signal_name(r.signal);
    return record;
}

std::string contacts_line(const scenes::Scene& scene) {
    if (scene.contact_edges == 0) return "none: no surface touches another inside its patches";
    return std::to_string(scene.contact_lines) + " lines where surfaces touch inside others cut their patches (" +
           std::to_string(scene.contact_splits) + " edges split); " + std::to_string(scene.contact_edges) +
           " contact edges keep the light on their sides (scenes/contacts.h; \"cut_contacts\": false keeps the "
           "patches as modelled)";
}

json to_json(const ConvergenceRow& r) {
    json j = {{"steps", r.steps}, {"seconds", r.seconds}, {"round", r.round}};
    for (const auto& [key, value] : kRowValues)
        if (r.*value) j[key] = *(r.*value);
    return j;
}

ConvergenceRow row_from_json(const json& j) {
    ConvergenceRow r;
    r.steps = j.at("steps").get<long>();
    r.seconds = j.at("seconds").get<double>();
    r.round = j.at("round").get<long>();
    for (const auto& [key, value] : kRowValues)
        if (j.contains(key)) r.*value = j.at(key).get<double>();
    return r;
}

void write_convergence_csv(const std::string& path, const std::vector<ConvergenceRow>& rows) {
    write_atomically(path, [&](const std::string& tmp) {
        std::ofstream out(tmp);
        out << "iteration,seconds,relative_l1_error,mean_radiance,estimated_error,round,image_estimated_error,"
               "image_relative_l1,image_mse,image_block4_relative_l1,image_worst_block16\n";
        out.precision(9);
        auto cell = [&](const std::optional<double>& v) {
            out << ',';
            if (v) out << *v;
        };
        for (const auto& r : rows) {
            out << r.steps << ',' << r.seconds;
            for (const auto* v : {&r.error, &r.mean, &r.estimate}) cell(*v);
            out << ',';
            if (r.round > 0) out << r.round;
            for (const auto* v : {&r.image_estimate, &r.image_l1, &r.image_mse, &r.image_block4_l1, &r.image_worst_block16})
                cell(*v);
            out << '\n';
        }
        out.close();
        if (!out) throw std::runtime_error(path + ": write failed");
    });
}

void write_json(const std::string& path, const json& doc) {
    write_atomically(path, [&](const std::string& tmp) {
        std::ofstream out(tmp);
        if (!out) throw std::runtime_error(path + ": cannot open for writing");
        out << doc.dump(2) << '\n';
        out.close();
        if (!out) throw std::runtime_error(path + ": write failed");
    });
}

std::string summary(const scenes::Scene& scene, const RunResult& r) {
    std::string out;
    auto print = [&out](const char* format, auto... values) { out += strprintf(format, values...); };
    if (!r.field) {
        print("%s: %zu patches, path traced %ld paths per pixel in %.2f s", scene.name.c_str(), scene.patch_count(),
              r.record["path_trace"]["paths"].get<long>() / (static_cast<long>(scene.camera.width) * scene.camera.height),
              r.record["seconds_render"].get<double>());
    } else {
        print("%s: %zu patches, %s %ld steps in %.2f s", scene.name.c_str(), scene.patch_count(),
              r.report.method.c_str(), r.report.steps, r.rounds.seconds_solve);
        if (r.gather) print(", final gather %.2f s", r.rounds.seconds_render);
        print(", mean radiance %.6g", r.mean_radiance);
        if (r.error) print(", relative L1 error %.3g", *r.error);
    }
    // A black image has no relative error to estimate (0 / 0): its halves agree, and
    // the probe's block error reads 100 % of nothing. Say what it is.
    const bool black = std::all_of(r.image.rgb.begin(), r.image.rgb.end(), [](float v) { return v == 0.0f; });
    if (black && r.image.width > 0) {
        print(", the image is black (no lit surface in view)");
    } else if (r.rounds.estimate >= 0.0) {
        print(", estimated error %.2g %% (%zu round%s", 100.0 * r.rounds.estimate, r.rounds.rounds.size(),
              r.rounds.rounds.size() == 1 ? "" : "s");
        // Parts, not terms: the halves' rule over pixels, and the 8x8 blocks' error (the
        // field's bias and its noise as the image reads it, the filter's blur; not only
        // bias, which the stats' shared bias is).
        if (r.rounds.parts.bias > 0.0)
            print("; noise %.2g %%, block error %.2g %%", 100.0 * r.rounds.parts.noise, 100.0 * r.rounds.parts.bias);
        if (r.rounds.correction > 0.0)
            print("; corrected at q = %g", r.rounds.correction);
        else if (r.rounds.corrected)
            print("; the probe's corrections");
        print(")");
    }
    if (r.against)
        print(", against the reference: relative L1 %.4g, MSE %.4g, 4x4 blocks %.4g, worst 16x16 block %+.4g",
              r.against->relative_l1, r.against->mse, r.against->block4_l1, r.against->worst_block16);
    return out;
}

std::string build_info() {
    std::string out = strprintf("raybundle %s\n", RAYBUNDLE_VERSION);
#if defined(__clang__)
    out += strprintf("compiler   clang %s\n", __clang_version__);
#elif defined(__GNUC__)
    out += strprintf("compiler   gcc %s\n", __VERSION__);
#endif
    std::string backends;
    for (const auto& b : visibility::backend_infos()) backends += (backends.empty() ? "" : ", ") + b.name;
    out += strprintf("backends   %s (default %s)\n", backends.c_str(), visibility::kDefaultBackend);
    return out + strprintf("kernels    %s (exact painter spans)\n", visibility::best_span_kernels().name);
}

}  // namespace raybundle::render
