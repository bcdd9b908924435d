#pragma once
// The JSON scene loader (format: docs/scene-format.md).
#include "scenes/scene.h"
#include "scenes/subdivide.h"
#include "scenes/team.h"

#include <functional>
#include <string>
#include <vector>

namespace raybundle::scenes {

// A setting given on the command line (-D key=value): `key` is a path into the scene's
// JSON ("patch_size", "camera.width", "materials.white.albedo", "objects[2].material")
// and `value` is JSON ("800", "[1, 0.5, 0.5]", "true") or else a plain string
// ("overcast"). Overrides are applied to the document before it is checked, so they
// are validated exactly like the file, and win over its values.
struct Override {
    std::string key, value;
    std::string given = {};  // as the user gave it, for messages ("--fov 200"); empty: -D key=value
};
using Overrides = std::vector<Override>;

// Loads, validates, refines (to patch_size) and finalizes a scene. Every problem
// throws SceneError with one line naming the file, the object and the value. An OBJ
// file is a scene alone: its materials (usemtl and its MTL files), a camera on the +z
// side of its bounds looking at their centre and framing their x and y extents in 40°,
// and a patch size of 1/25 of their largest extent; the overrides apply to that
// document ("camera.eye", "patch_size", "materials.NAME" to replace an MTL material).
// Its preparation runs on `threads` threads and, given a team (scenes/team.h), splits
// the contact search among its members: the same scene for any count of either.
Scene load_scene(const std::string& path, const Overrides& overrides = {}, int threads = 1,
                 const PreparationTeam* team = nullptr);

// Bounds on what a scene may grow to on load (the fuzzing harnesses lower them so that
// every input stays within their memory and time limits: tests/fuzz/), the threads
// that prepare it, and who hears of its steps.
struct LoadLimits {
    double max_patches = kMaxPatches;  // after refinement (scenes/subdivide.h)
    MemoryShare memory = memory_share();  // what the preparation may hold (bytes 0: no bound)
    int threads = 1;                   // the preparation (refinement, contacts)
    const PreparationTeam* team = nullptr;  // the processes sharing the contact search
    // Told, on the calling thread, as each step of a scene file's or model's preparation
    // begins: "reading" (the files, their welds), "normals", "refining", "contacts". For a
    // progress display (apps/progress.h); a built-in scene tells nothing.
    std::function<void(const char* step)> on_step;
};

// load_scene() with the limits above.
Scene load_scene(const std::string& path, const Overrides& overrides, const LoadLimits& limits);

// The same from JSON text; mesh paths resolve against base_dir, errors name `shown`.
Scene parse_scene(const std::string& text, const std::string& shown, const std::string& base_dir,
                  const Overrides& overrides = {}, const LoadLimits& limits = {});

// A built-in scene (scenes/builtin.h) with overrides of its camera ("camera.*") and
// "patch_size", validated as in a file.
Scene load_builtin(const std::string& name, const Overrides& overrides = {}, int threads = 1,
                   const PreparationTeam* team = nullptr, const MemoryShare& memory = memory_share());

}  // namespace raybundle::scenes
