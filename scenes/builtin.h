#pragma once
// Built-in scenes, made by name.
#include "scenes/machine.h"
#include "scenes/scene.h"
#include "scenes/team.h"

#include <optional>
#include <string>
#include <vector>

namespace raybundle::scenes {

struct BuiltinInfo {
    std::string name;
    std::string description;
    double default_patch_size;
};

// The built-in scenes with one line each, for `raybundle scenes`.
std::vector<BuiltinInfo> builtin_scenes();

// Makes a built-in scene, refined to patch_size (its default when absent), finalized;
// prepared on `threads` threads, its contact search split among `team` where given
// (scenes/team.h), its patches bounded by `memory` (scenes/subdivide.h, patch_budget).
// Throws SceneError for an unknown name or a patch size <= 0.
Scene make_builtin(const std::string& name, std::optional<double> patch_size = std::nullopt, int threads = 1,
                   const PreparationTeam* team = nullptr, const MemoryShare& memory = memory_share());

// Appends a convex planar quad as two triangles sharing an edge; the corners go
// round the quad, and the front side faces `towards` (a point in front of it).
void add_quad(Scene& scene, const Vec3 corners[4], int material, const Vec3& towards, const std::string& name = "quad");

}  // namespace raybundle::scenes
