// libFuzzer harness for the MTL reader (scenes/mesh_file.h parse_mtl): any input either
// reads or throws SceneError; every material read has finite, non-negative colours
// and exponent, and a name. A crash, a sanitizer report, another exception, or more
// than the run's memory or time limits is a finding (scripts/fuzz.sh).
#include "scenes/errors.h"
#include "scenes/mesh_file.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        const auto materials =
            raybundle::scenes::parse_mtl(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.mtl");
        for (const auto& m : materials) {
            if (m.name.empty() || !(m.ns >= 0.0) || !std::isfinite(m.ns)) __builtin_trap();
            for (const auto* c : {&m.kd, &m.ke, &m.ks})
                if (!(c->minCoeff() >= 0.0) || !c->isFinite().all()) __builtin_trap();
        }
    } catch (const raybundle::scenes::SceneError&) {
    }
    return 0;
}
