// `raybundle check SCENE`: validate a scene and print what it holds, without solving.
#include "cli.h"

#include "render/scene_check.h"
#include "scenes/ray_caster.h"

#include <iostream>

namespace raybundle::apps {

int check_scene(const Command& c) {
    const scenes::Scene scene = load_scene(c);
    const scenes::RayCaster caster(scene);
    std::cout << render::describe(scene, render::summarize(scene, caster, c.config.run.threads));
    return 0;
}

}  // namespace raybundle::apps
