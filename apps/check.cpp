// `raybundle check SCENE`: validate a scene and print what it holds, without solving.
#include "cli.h"

#include "render/scene_check.h"
#include "scenes/ray_caster.h"

#include <iostream>

namespace raybundle::apps {

int check_scene(const Command& c) {
    ProgressBar bar(c.quiet);
    const scenes::Scene scene = load_scene(c, scenes::memory_share(), bar);
    const auto summary = [&] {
        PreparationProgress shown(bar);
        shown.step("check");
        const scenes::RayCaster caster(scene);
        return render::summarize(scene, caster, c.config.run.threads);
    }();
    std::cout << render::describe(scene, summary);
    return 0;
}

}  // namespace raybundle::apps
