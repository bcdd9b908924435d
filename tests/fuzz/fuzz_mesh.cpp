// libFuzzer harness for one mesh reader (RAYBUNDLE_FUZZ_FORMAT: obj, ply or off; the
// PLY reader has two harnesses, seeded with ASCII and binary files): any input either
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
            std::string_view(reinterpret_cast<const char*>(data), size), RAYBUNDLE_FUZZ_FORMAT, "fuzz");
        // What the loader does next with it: every index in range.
        for (const auto& t : mesh.triangles)
            for (int v : t)
                if (v < 0 || static_cast<std::size_t>(v) >= mesh.vertices.size()) __builtin_trap();
        if (!mesh.normals.empty() && mesh.normals.size() != mesh.triangles.size()) __builtin_trap();
    } catch (const raybundle::scenes::SceneError&) {
    }
    return 0;
}
