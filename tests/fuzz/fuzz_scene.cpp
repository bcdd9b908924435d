// libFuzzer harness for the scene loader: JSON text (with mesh objects that name the
// small meshes written beside it at start-up, one with its own MTL materials) is loaded, validated, refined and cut at
// contacts, or refused with SceneError. The patch limit is lowered to 2,000 so that
// no valid input outgrows the run's memory and time limits (what a large limit costs
// is the memory guard's business, apps/memory.h); everything else is the loader as the
// command line runs it.
#include "scenes/errors.h"
#include "scenes/loader.h"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

namespace {

std::string g_dir;

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    char name[] = "/tmp/raybundle-fuzz-XXXXXX";
    if (!::mkdtemp(name)) std::abort();
    g_dir = name;
    const char* square = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n";
    std::ofstream(g_dir + "/square.obj") << square;
    std::ofstream(g_dir + "/square.off") << "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
    std::ofstream(g_dir + "/square.ply") << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                                            "property float y\nproperty float z\nelement face 1\n"
                                            "property list uchar int vertex_indices\nend_header\n"
                                            "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
    // An OBJ that brings its materials (usemtl, an MTL beside it).
    std::ofstream(g_dir + "/lamp.obj") << "mtllib lamp.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\ng lamp\n"
                                          "usemtl glow\nf 1 2 3\nusemtl wall\nf 1 3 4\n";
    std::ofstream(g_dir + "/lamp.mtl") << "newmtl glow\nKd 0 0 0\nKe 5 4 3\nnewmtl wall\nKd 0.5 0.5 0.5\n"
                                          "Ks 0.2 0.2 0.2\nNs 10\nillum 2\n";
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    raybundle::scenes::LoadLimits limits;
    limits.max_patches = 2e3;
    try {
        const auto scene = raybundle::scenes::parse_scene(std::string(reinterpret_cast<const char*>(data), size),
                                                          "fuzz.json", g_dir, {}, limits);
        if (scene.patch_count() == 0) __builtin_trap();  // the loader refuses a scene without patches
    } catch (const raybundle::scenes::SceneError&) {
    }
    return 0;
}
