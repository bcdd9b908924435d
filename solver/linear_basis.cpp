#include "solver/linear_basis.h"

#include "sampling/directions.h"
#include "sampling/streams.h"
#include "scenes/errors.h"
#include "scenes/threads.h"

#include <chrono>
#include <cmath>
#include <stdexcept>

namespace raybundle::solver {

using Clock = std::chrono::steady_clock;

namespace {

const Transport& diffuse_only(const Transport& t) {
    if (t.glossy()) throw scenes::OptionError("basis", "linear supports diffuse scenes only (this scene has glossy materials)");
    return t;
}

}  // namespace

LinearIteration::LinearIteration(const Transport& transport, const SolverOptions& options,
                                 const sampling::RunOptions& run)
    : Solver(options.steps),
      t_(diffuse_only(transport)),
      scene_(transport.scene()),
      options_(options),
      run_(run),
      painter_(transport.scene(), options.map),
      directions_(run.seed, run.chain),
      jitter_(run.seed, sampling::streams::kMapJitters(run.chain, run.jitter_stream, 16)) {
    const auto& patches = scene_.patch_list();
    const std::size_t n = patches.size();

    const scenes::VertexCorners star = scenes::vertex_corners(scene_);
    const std::size_t nv = star.start.size() - 1;
    // Cluster each vertex's corners into nodes: same material, normal within 30 degrees
    // of the node's first patch.
    const double crease = std::cos(30.0 * M_PI / 180.0);
    node_of_corner_.assign(3 * n, 0);
    std::vector<std::uint32_t> seeds;  // the first corner of each node at this vertex
    for (std::size_t v = 0; v < nv; ++v) {
        seeds.clear();
        const std::size_t first_node = mass_.size();
        for (std::size_t e = star.start[v]; e < star.start[v + 1]; ++e) {
            const std::uint32_t c = star.corners[e];
            const auto& p = patches[c / 3];
            std::size_t node = mass_.size();
            for (std::size_t s = 0; s < seeds.size(); ++s) {
                const auto& q = patches[seeds[s] / 3];
                if (q.material == p.material && q.normal.dot(p.normal) >= crease) {
                    node = first_node + s;
                    break;
                }
            }
            if (node == mass_.size()) {
                seeds.push_back(c);
                mass_.push_back(0.0);
                emission_.push_back(Rgb::Zero());
                display_.push_back(Rgb::Zero());
                reflect_.push_back(t_.diffuse_reflectance(c / 3));
            }
            node_of_corner_[c] = static_cast<std::uint32_t>(node);
            const double a = p.area / 3.0;
            mass_[node] += a;
            emission_[node] += a * t_.emitted(c / 3, p.normal);
            display_[node] += a * t_.displayed(c / 3, p.normal);
        }
    }
    for (std::size_t k = 0; k < mass_.size(); ++k) {
        emission_[k] /= mass_[k];
        display_[k] /= mass_[k];
    }
    irradiance_.assign(mass_.size(), Rgb::Zero());
    next_.assign(mass_.size(), Rgb::Zero());
    sum_.assign(mass_.size(), Rgb::Zero());
    corner_out_.assign(3 * n, Rgb::Zero());
    report_.method = "iteration";
    report_.visibility = {"painter", "centre-sorted Gouraud radiance map (the linear basis)", false, resolution(), 1};
    report_.bytes_per_patch = (3 * sizeof(Rgb) * mass_.size() + 6 * sizeof(Rgb) * n) / n;
    report_.details = {{"basis", "linear"}, {"nodes", mass_.size()}, {"both_ways", options_.both_ways}};
    report_.decisions["shading"] = "linear basis: vertex values interpolated (Gouraud), no smoothing pass";
    report_.decisions["visibility"] = "the centre-sorted painter's radiance map (the basis lives in its rasteriser)";
}

void LinearIteration::pass(const Vec3& w, const Eigen::Vector2d& jitter, double weight) {
    const Rgb sky = scene_.sky ? scene_.sky->arriving_along(w) : Rgb::Zero();
    const auto t0 = Clock::now();
    painter_.transfer(w, jitter, corner_out_, sky, corner_in_);
    const auto t1 = Clock::now();
    for (std::size_t c = 0; c < corner_in_.size(); ++c) next_[node_of_corner_[c]] += weight * corner_in_[c];
    report_.seconds_visibility += std::chrono::duration<double>(t1 - t0).count();
    report_.seconds_transport += std::chrono::duration<double>(Clock::now() - t1).count();
    ++report_.directions;
}

void LinearIteration::advance(long total) {
    const bool both = options_.both_ways;
    const auto start = Clock::now();
    for (long m = 0; m < total; ++m) {
        const Vec3 w = directions_.next();
        const double y = jitter_.uniform(), x = jitter_.uniform();  // y first: see sampling/rng.h
        const Eigen::Vector2d offset(x, y);
        // Radiance at every corner: its node's emission and reflection of the last step.
        for (std::size_t c = 0; c < corner_out_.size(); ++c) {
            const std::uint32_t k = node_of_corner_[c];
            corner_out_[c] = emission_[k] + reflect_[k] * irradiance_[k];
        }
        std::fill(next_.begin(), next_.end(), Rgb::Zero());
        pass(w, offset, both ? 0.5 : 1.0);
        if (both) pass(-w, offset, 0.5);
        for (std::size_t k = 0; k < mass_.size(); ++k) {
            irradiance_[k] = next_[k] / mass_[k];
            sum_[k] += irradiance_[k];
        }
        ++steps_;
        ++report_.steps;
        run_.report("solve", m + 1, total, std::chrono::duration<double>(Clock::now() - start).count());
    }
}

void LinearIteration::save(StateWriter& out) const {
    out.tag("iteration-linear");
    out.put(steps_);
    out.put(irradiance_);
    out.put(sum_);
    out.put(directions_.generator());
    out.put(jitter_);
    save_counters(out, report_);
}

void LinearIteration::restore(StateReader& in) {
    in.expect("iteration-linear");
    in.get(steps_);
    in.get(irradiance_);
    in.get(sum_);
    in.get(directions_.generator());
    in.get(jitter_);
    restore_counters(in, report_);
}

RadianceField LinearIteration::field(int threads) const {
    RadianceField f;
    const std::size_t n = scene_.patch_count();
    f.radiance.resize(n);  // neither written here: by the threads below
    f.corners.resize(n);
    const double inv_m = steps_ > 0 ? 1.0 / static_cast<double>(steps_) : 0.0;
    parallel_chunks(static_cast<int>(n), threads > 0 ? threads : run_.threads, [&](int i0, int i1) {
        for (auto i = static_cast<std::size_t>(i0); i < static_cast<std::size_t>(i1); ++i) {
            Rgb mean = Rgb::Zero();
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t node = node_of_corner_[3 * i + k];
                f.corners[i][k] = display_[node] + reflect_[node] * sum_[node] * inv_m;
                mean += f.corners[i][k] / 3.0;
            }
            // The patch's mean radiance: the mean of a linear function over a triangle.
            f.radiance[i] = mean;
        }
    });
    return f;
}

}  // namespace raybundle::solver
