// libFuzzer harness for one mesh reader (RAYBUNDLE_FUZZ_FORMAT: obj, ply, off, gltf or
// glb; the PLY reader has two harnesses, seeded with ASCII and binary files; a glTF's
// node tree may place at most 10^5 triangles, a bound within the run's memory and
// time, as the scene harness lowers the patch limit): any input either
// reads or throws SceneError; a crash, a sanitizer report, another exception, or more
// than the run's memory or time limits is a finding (scripts/fuzz.sh).
#include "scenes/errors.h"
#include "scenes/mesh_file.h"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        const auto mesh = raybundle::scenes::parse_mesh(
            std::string_view(reinterpret_cast<const char*>(data), size), RAYBUNDLE_FUZZ_FORMAT, "fuzz", 100'000);
        // What the loader does next with it: every index in range.
        for (const auto& t : mesh.triangles)
            for (int v : t)
                if (v < 0 || static_cast<std::size_t>(v) >= mesh.vertices.size()) __builtin_trap();
        if (!mesh.normals.empty() && mesh.normals.size() != mesh.triangles.size()) __builtin_trap();
        // A glTF's materials: one definition per name, every triangle's in range.
        if (!mesh.material_defs.empty()) {
            if (mesh.material_defs.size() != mesh.materials.size()) __builtin_trap();
            if (mesh.triangle_material.size() != mesh.triangles.size()) __builtin_trap();
            for (int m : mesh.triangle_material)
                if (m < 0 || static_cast<std::size_t>(m) >= mesh.materials.size()) __builtin_trap();
        }
    } catch (const raybundle::scenes::SceneError&) {
    }
    return 0;
}
