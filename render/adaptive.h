#pragma once
// Refinement driven by the solution: where the solved radiance varies across a patch (a
// shadow's edge, the dark band along a contact line, a corner), a constant per patch is
// wrong, and the image's gather rays read that error as light. The run (render/run.h)
// solves the scene as given briefly (a pilot: two short independent chains), measures
// per patch how much its radiance differs from its neighbours' beyond the chains' noise,
// and cuts the patches where that costs the field most, as many as the growth allows;
// then it solves the refined scene.
//
//   variation(scene, a, b): per patch, the RMS difference of its radiance from its
//     neighbours' on the same surface (edge neighbours within 30 degrees: contact edges
//     and creases are not crossed, the radiance may jump there), less the noise the two
//     chains' disagreement shows (pooled over the patch and its neighbours).
//   plan_refinement(scene, variation, growth): a patch of area A whose radiance varies by
//     v across it holds about A v of the field's L1 error, and cutting it in four halves
//     that for three new patches; the next level of cutting halves it again for four
//     times the patches. Greedily, the cut with the most error removed per new patch
//     first, until growth x patches are added; at most kMaxLevels levels per patch.
#include "scenes/scene.h"
#include "solver/radiance_field.h"

#include <cstddef>
#include <string>
#include <vector>

namespace raybundle::render {

struct RefineOptions {
    bool on = false;
    double growth = 1.0;    // the patches added, as a share of the scene's
    long pilot_steps = 32;  // per chain of the pilot
    static constexpr int kMaxLevels = 3;  // a patch is cut into at most about 4^3 pieces
};

std::vector<double> variation(const scenes::Scene& scene, const solver::RadianceField& a,
                              const solver::RadianceField& b);

struct RefinePlan {
    std::vector<double> max_edge;  // per patch: the longest edge its pieces may have (infinity: kept)
    std::size_t marked = 0;        // patches to be cut
    std::size_t planned = 0;       // patches the cuts add, as planned (conformity adds some)
    int deepest = 0;               // the most levels a patch is cut
    double covered = 0.0;          // the share of the sum of area x variation on the marked patches
};
RefinePlan plan_refinement(const scenes::Scene& scene, const std::vector<double>& variation, double growth);

}  // namespace raybundle::render
