// Writes a scene, loaded exactly as `raybundle solve` loads it, as one JSON document
// for other renderers (bench/cycles/import_scene.py builds the Blender scene from it):
//
//   export_scene SCENE.json | --builtin NAME [-D key=value ...] -o OUT.json
//
// The document holds the camera (eye, target, up, fov_y in degrees, vertical; width,
// height), the sky (model, radiance, up) or null, the materials (albedo, emission,
// specular, exponent, two_sided), the directional lights (direction of travel,
// irradiance) and the triangles after loading and refinement
// (positions; index triples; a material per triangle). Front sides are counter-
// clockwise, as in raybundle. A two-sided material's triangles are loaded as twins
// facing both ways; only one of each twin pair is written, and the material says
// two_sided: true. Scenes with glossy materials or point lights are refused: their
// conversion to other renderers is not verified (modified Phong lobes and point
// light units differ between renderers).
#include "scenes/errors.h"
#include "scenes/loader.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

using namespace raybundle;
using json = nlohmann::json;

namespace {

json vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }
json rgb(const scenes::Rgb& c) { return json::array({c[0], c[1], c[2]}); }

// A triangle's corners as a key that is the same for the triangle and its twin (the
// same three points, in the other winding): the sorted exact coordinates.
using Key = std::array<std::array<double, 3>, 3>;
Key corner_key(const scenes::Scene& s, const scenes::Patch& p) {
    Key k;
    for (int c = 0; c < 3; ++c) {
        const auto& v = s.vertex_positions()[p.v[c]];
        k[c] = {v.x(), v.y(), v.z()};
    }
    std::sort(k.begin(), k.end());
    return k;
}

json export_scene(const scenes::Scene& s) {
    if (!s.point_lights.empty())
        throw std::runtime_error("the scene has point lights: their conversion is not verified, refused");
    for (const auto& m : s.materials)
        if (m.glossy())
            throw std::runtime_error("material '" + m.name +
                                     "' is glossy: the modified Phong lobe's conversion is not verified, refused");

    json out;
    out["scene"] = s.name;
    out["camera"] = {{"eye", vec(s.camera.eye)},       {"target", vec(s.camera.target)},
                     {"up", vec(s.camera.up)},         {"fov_y", s.camera.fov_y},
                     {"width", s.camera.width},        {"height", s.camera.height}};
    if (s.sky)
        out["sky"] = {{"model", s.sky->model == scenes::Sky::Model::constant ? "constant" : "overcast"},
                      {"radiance", rgb(s.sky->radiance)},
                      {"up", vec(s.sky->up)}};
    else
        out["sky"] = nullptr;
    // A directional light is a Cycles sun of angle 0 whose strength (W/m^2) is the
    // irradiance of a surface facing it: the same quantity, no unit to convert.
    out["directional_lights"] = json::array();
    for (const auto& l : s.directional_lights)
        out["directional_lights"].push_back({{"direction", vec(l.direction)}, {"irradiance", rgb(l.irradiance)}});
    json mats = json::array();
    for (const auto& m : s.materials)
        mats.push_back({{"name", m.name},
                        {"albedo", rgb(m.albedo)},
                        {"emission", rgb(m.emission)},
                        {"specular", rgb(m.specular)},
                        {"exponent", m.exponent},
                        {"two_sided", m.two_sided}});
    out["materials"] = mats;

    // Pair the twins of two-sided materials: same corners, opposite normals.
    const auto& patches = s.patch_list();
    std::map<Key, std::vector<std::size_t>> open;  // two-sided triangles waiting for their twin
    std::vector<char> keep(patches.size(), 1);
    std::size_t twins = 0;
    for (std::size_t i = 0; i < patches.size(); ++i) {
        if (!s.material_of(i).two_sided) continue;
        auto& waiting = open[corner_key(s, patches[i])];
        const auto twin = std::find_if(waiting.begin(), waiting.end(), [&](std::size_t j) {
            return patches[j].material == patches[i].material && patches[j].normal.dot(patches[i].normal) < 0.0;
        });
        if (twin == waiting.end()) {
            waiting.push_back(i);
        } else {
            keep[i] = 0;  // the twin turned over: the first of the pair stands for both
            waiting.erase(twin);
            ++twins;
        }
    }
    std::size_t unpaired = 0;
    for (const auto& [key, waiting] : open) unpaired += waiting.size();
    if (unpaired > 0)
        throw std::runtime_error(std::to_string(unpaired) +
                                 " triangles of two-sided materials have no twin facing the other way");

    // Only the vertices the written triangles use, renumbered in order of first use.
    std::vector<int> index(s.vertex_positions().size(), -1);
    json positions = json::array(), triangles = json::array(), materials = json::array();
    for (std::size_t i = 0; i < patches.size(); ++i) {
        if (!keep[i]) continue;
        json tri = json::array();
        for (int c = 0; c < 3; ++c) {
            const int v = patches[i].v[c];
            if (index[v] < 0) {
                index[v] = static_cast<int>(positions.size());
                positions.push_back(vec(s.vertex_positions()[v]));
            }
            tri.push_back(index[v]);
        }
        triangles.push_back(tri);
        materials.push_back(patches[i].material);
    }
    out["positions"] = positions;
    out["triangles"] = triangles;
    out["triangle_materials"] = materials;
    out["patches_loaded"] = patches.size();
    out["twin_pairs_merged"] = twins;
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"export_scene: a scene as raybundle loads it (camera, sky, materials, triangles) as JSON"};
    std::string scene_file, builtin, output;
    std::vector<std::string> defines;
    app.add_option("scene", scene_file, "scene file (JSON, see docs/scene-format.md)");
    app.add_option("--builtin", builtin, "a built-in scene instead of a file");
    app.add_option("-D", defines, "set a scene value: -D key=value, as for `raybundle solve`");
    app.add_option("-o,--output", output, "the JSON file to write")->required();
    CLI11_PARSE(app, argc, argv);
    try {
        if (scene_file.empty() == builtin.empty()) throw std::runtime_error("give exactly one of SCENE.json or --builtin NAME");
        scenes::Overrides overrides;
        for (const auto& d : defines) {
            const auto eq = d.find('=');
            if (eq == std::string::npos || eq == 0) throw std::runtime_error("-D " + d + ": expected key=value");
            overrides.push_back({d.substr(0, eq), d.substr(eq + 1)});
        }
        const scenes::Scene scene = builtin.empty() ? scenes::load_scene(scene_file, overrides)
                                                    : scenes::load_builtin(builtin, overrides);
        const json doc = export_scene(scene);
        std::ofstream out(output);
        out << doc.dump() << "\n";
        out.close();
        if (!out) throw std::runtime_error(output + ": cannot write");
        std::printf("%s: %zu triangles (%zu patches loaded, %zu two-sided twins merged), %zu materials, sky: %s\n",
                    output.c_str(), doc["triangles"].size(), scene.patch_count(),
                    doc["twin_pairs_merged"].get<std::size_t>(), scene.materials.size(),
                    scene.sky ? doc["sky"]["model"].get<std::string>().c_str() : "none");
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "export_scene: error: " << e.what() << "\n";
        return 2;
    }
}
