#pragma once
// The JSON scene loader (format: docs/scene-format.md).
#include "scenes/scene.h"

#include <optional>
#include <string>

namespace raybundle::scenes {

// Loads, validates, refines (to patch_size; the override wins over the file's value)
// and finalizes a scene. Every problem throws SceneError with one line naming the
// file, the object and the value.
Scene load_scene(const std::string& path, std::optional<double> patch_size_override = std::nullopt);

// The same from JSON text; mesh paths resolve against base_dir, errors name `shown`.
Scene parse_scene(const std::string& text, const std::string& shown, const std::string& base_dir,
                  std::optional<double> patch_size_override = std::nullopt);

}  // namespace raybundle::scenes
