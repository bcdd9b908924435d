#pragma once
// Stochastic iteration with the piecewise-linear basis (004 section 5.3): the unknowns
// are irradiances at mesh vertices ("nodes"), the visibility map interpolates each
// source's corner radiances across it (Gouraud), and the image is smooth without a
// smoothing pass.
//
// A node is a vertex together with the patches around it that share a material and
// whose normals lie within 30 degrees of each other: a crease (a box's corner) or a
// material boundary splits a vertex into several nodes, so walls keep their own
// values, as in render/shade.h. A node's value is the hat-weighted irradiance
// (visibility/painter.h, GouraudPainter): the mean over its patches of
// sum lambda_k L pixel_area / (A/3), an unbiased estimate of the irradiance averaged
// with the hat function as weight.
//
// Diffuse scenes only (a glossy BRDF would need the arrival direction per node); the
// painter's map only (the basis lives in the rasteriser). With `bidirectional` the
// map is painted for w and for -w (two passes, weight 1/2 each). Point and directional lights enter
// through the first shot (patch-averaged, then averaged per node); the sky through
// the map's initial value.
//
// Options read: steps, both_ways (w and -w: two passes, weight 1/2 each), map.
// Call order: see solver.h.
#include "solver/solver.h"
#include "sampling/directions.h"
#include "visibility/painter.h"

#include <array>
#include <vector>

namespace raybundle::solver {

class LinearIteration final : public Solver {
public:
    // Throws OptionError("basis") for a scene with glossy materials.
    LinearIteration(const Transport& transport, const SolverOptions& options, const sampling::RunOptions& run);

    void advance(long steps) override;
    RadianceField field(int threads = 0) const override;
    long averaged() const override { return steps_; }
    SolverReport report() const override { return report_; }
    void save(StateWriter& out) const override;
    void restore(StateReader& in) override;
    int resolution() const { return painter_.resolution(); }
    std::size_t nodes() const { return mass_.size(); }

private:
    void pass(const Vec3& w, const Eigen::Vector2d& jitter, double weight);

    const Transport& t_;
    const scenes::Scene& scene_;
    SolverOptions options_;
    sampling::RunOptions run_;
    visibility::GouraudPainter painter_;
    std::vector<std::uint32_t> node_of_corner_;  // 3 per patch
    std::vector<double> mass_;                    // sum of A/3 over the node's corners
    std::vector<Rgb> emission_, display_, reflect_;  // per node: into the maps, shown, 4 albedo
    std::vector<Rgb> irradiance_, next_, sum_;    // per node
    std::vector<Rgb> corner_out_, corner_in_;     // 3 per patch
    long steps_ = 0;
    sampling::RandomDirections directions_;
    sampling::Rng jitter_;
    SolverReport report_;
};

}  // namespace raybundle::solver
