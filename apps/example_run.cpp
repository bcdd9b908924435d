// raybundle as a library (README, "As a library"): a scene in, an image and its
// estimated error out. RunConfig holds every default the command line has, so this
// program's image is the one `raybundle solve SCENE --iterations 500 -o OUT.png` writes
// (tests/cli/test_cli_outputs.sh compares them byte for byte).
//
//   raybundle_example SCENE OUT.png [key=value ...]
//
// SCENE: a scene file, an OBJ or glTF model, or builtin:NAME; key=value as -D sets it.
#include "render/image_io.h"
#include "render/output_set.h"
#include "render/run.h"
#include "scenes/errors.h"
#include "scenes/loader.h"

#include <cstdio>
#include <exception>
#include <iostream>
#include <string>

namespace rb = raybundle;

int main(int argc, char** argv) {
    if (argc < 3) {
        std::cerr << "usage: raybundle_example SCENE|builtin:NAME OUT.png [key=value ...]\n";
        return 2;
    }
    try {
        // The scene: loaded, checked, refined to its patch size and cut at its contacts.
        rb::scenes::Overrides overrides;
        for (int i = 3; i < argc; ++i) {
            const std::string setting = argv[i];
            const auto equals = setting.find('=');
            if (equals == std::string::npos) throw std::invalid_argument("'" + setting + "': expected key=value");
            overrides.push_back({setting.substr(0, equals), setting.substr(equals + 1), ""});
        }
        const std::string source = argv[1], out = argv[2];
        if (out.size() < 4 || out.compare(out.size() - 4, 4, ".png") != 0)
            throw rb::render::OutputError(out + ": this example writes PNG only (a name ending in .png)");
        const rb::scenes::Scene scene = source.rfind("builtin:", 0) == 0
                                            ? rb::scenes::load_builtin(source.substr(8), overrides)
                                            : rb::scenes::load_scene(source, overrides);
        // Before any work: the output is writable, and none of the files the scene was
        // read from (its meshes, the scene file itself).
        rb::render::check_outputs({{out, "OUT.png"}}, rb::render::with_scene_files({}, scene));

        // The run: the defaults (stochastic iteration, the final gather with its guided
        // filter, every core), 500 steps over both chains.
        rb::render::RunConfig config;
        config.solver.steps = 500;
        rb::render::RunHooks hooks;
        hooks.warn = [](const std::string& line) { std::cerr << "warning: " << line << "\n"; };
        const rb::render::RunResult result = rb::render::run(scene, config, hooks);

        // Written whole or not at all: a hidden temporary, renamed into place.
        rb::render::OutputSet files;
        files.stage(out, [&](const std::string& tmp) { rb::render::write_png(tmp, result.image, 0.0); });
        files.commit();
        std::printf("%s: %ld steps, mean radiance %.6g, estimated error %.2g %%\n", scene.name.c_str(), result.steps,
                    result.mean_radiance, 100.0 * result.rounds.estimate);
        return 0;
    } catch (const rb::scenes::SceneError& e) {  // the input: one line naming the file, object, value
        std::cerr << "raybundle_example: " << e.what() << "\n";
        return 2;
    } catch (const rb::render::OutputError& e) {  // an output that must not be written
        std::cerr << "raybundle_example: " << e.what() << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "raybundle_example: " << e.what() << "\n";
        return 1;
    }
}
