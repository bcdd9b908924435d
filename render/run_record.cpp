#include "stats.h"

#include "render/image_io.h"

#include <fstream>
#include <stdexcept>

namespace raybundle::apps {

using json = nlohmann::json;

json run_record(const scenes::Scene& scene, const Command& c, const solver::SolverReport& report,
                const solver::Transport& transport, std::size_t coplanar_overlaps) {
    const auto& v = report.visibility;
    std::string sky = "none: the scene has no sky (no sky entries in the maps)";
    if (scene.sky)
        sky = std::string(scene.sky->model == scenes::Sky::Model::constant ? "constant" : "CIE overcast") +
              " sky: map pixels that no patch covers upstream carry the sky radiance";
    json decisions = transport.decisions();
    decisions["sky"] = sky;
    decisions["contacts"] = contacts_line(scene);
    decisions["threads"] = "visibility: " + std::to_string(v.threads) +
                           (v.threads < c.run.threads ? " (this backend runs one at a time)" : "") +
                           " (one backend each; the light moves in order, so any count gives the same result)" +
                           (c.gather_rays > 0 ? "; final gather and filters: " + std::to_string(c.run.threads) : "");
    for (const auto& [key, value] : report.decisions.items()) decisions[key] = value;
    json stats = {
        {"scene", scene.name},
        {"patches", scene.patch_count()},
        {"dropped_degenerate_triangles", scene.dropped_degenerate},
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
        {"image", {{"width", scene.camera.width}, {"height", scene.camera.height}, {"shading", c.shading}}},
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

std::string contacts_line(const scenes::Scene& scene) {
    if (scene.contact_edges == 0) return "none: no surface touches another inside its patches";
    return std::to_string(scene.contact_lines) + " lines where surfaces touch inside others cut their patches (" +
           std::to_string(scene.contact_splits) + " edges split); " + std::to_string(scene.contact_edges) +
           " contact edges keep the light on their sides (scenes/contacts.h; \"cut_contacts\": false keeps the "
           "patches as modelled)";
}

json gather_record(const Command& c, const render::GatherResult& g) {
    const auto& o = c.gather;
    return {{"gather_rays", o.gather_rays},
            {"direct_samples", o.direct_samples},
            {"direct", render::direct_light_name(o.direct)},
            {"glossy_rays", o.glossy_rays},
            {"spp", o.spp},
            {"emission_samples", o.emission_samples},
            {"filter", render::filter_name(o.filter.filter)},
            {"filter_radius", g.filter_radius},
            {"eps_normal", o.filter.eps_normal},
            {"eps_depth", o.filter.eps_depth},
            {"threads", c.run.threads},
            {"camera_rays", g.camera_rays},
            {"shadow_rays", g.shadow_rays},
            {"gather_rays_total", g.gather_rays},
            {"lookups", g.lookups},
            {"lookups_across_depth", g.lookups_across},
            {"seconds_guides", g.seconds_guides},
            {"seconds_filter", g.seconds_filter},
            {"seconds_samples", g.seconds_samples}};
}

void write_json(const std::string& path, const json& doc) {
    render::write_atomically(path, [&](const std::string& tmp) {
        std::ofstream out(tmp);
        if (!out) throw std::runtime_error(path + ": cannot open for writing");
        out << doc.dump(2) << '\n';
        out.close();
        if (!out) throw std::runtime_error(path + ": write failed");
    });
}

}  // namespace raybundle::apps
