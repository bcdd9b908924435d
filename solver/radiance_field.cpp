#include "solver/radiance_field.h"

#include <cmath>

namespace raybundle::solver {

double RadianceField::mean_radiance(const scenes::Scene& scene) const {
    double sum = 0.0, area = 0.0;
    const auto& patches = scene.patch_list();
    for (std::size_t i = 0; i < patches.size(); ++i) {
        sum += patches[i].area * radiance[i].mean();
        area += patches[i].area;
    }
    return sum / area;
}

double RadianceField::relative_l1_error(const scenes::Scene& scene, double exact) const {
    double err = 0.0, ref = 0.0;
    const auto& patches = scene.patch_list();
    for (std::size_t i = 0; i < patches.size(); ++i) {
        err += patches[i].area * (radiance[i] - exact).abs().sum();
        ref += patches[i].area * 3.0 * exact;
    }
    return err / ref;
}

}  // namespace raybundle::solver
