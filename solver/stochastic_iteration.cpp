#include "solver/stochastic_iteration.h"

#include "sampling/directions.h"
#include "solver/brdf.h"

#include <chrono>
#include <cmath>

namespace raybundle::solver {

using scenes::Rgb;
using scenes::Vec3;
using Clock = std::chrono::steady_clock;

StochasticIteration::StochasticIteration(const scenes::Scene& scene, visibility::Backend& backend,
                                         IterationOptions options)
    : scene_(scene), backend_(backend), options_(options), glossy_(scene.has_glossy()) {
    const std::size_t n = scene.patch_count();
    inv_area_.resize(n);
    emission_.resize(n);
    reflect_.resize(n);
    patch_glossy_.resize(n);
    const auto& patches = scene.patch_list();
    for (std::size_t i = 0; i < n; ++i) {
        const auto& m = scene.material_of(i);
        inv_area_[i] = 1.0 / patches[i].area;
        emission_[i] = m.emission;
        reflect_[i] = 4.0 * m.albedo;
        patch_glossy_[i] = m.glossy();
    }
    irradiance_.assign(n, Rgb::Zero());
    next_.assign(n, Rgb::Zero());
    outgoing_.assign(n, Rgb::Zero());
    sum_.assign(n, Rgb::Zero());
    if (glossy_) {
        to_eye_.resize(n);
        for (std::size_t i = 0; i < n; ++i) to_eye_[i] = (scene.camera.eye - patches[i].centroid).normalized();
        stats_.shading = "every step, towards the eye (the scene has glossy materials)";
    } else {
        stats_.shading = "once at the end (purely diffuse scene)";
    }
}

void StochasticIteration::step(const Vec3& w) {
    const std::size_t n = inv_area_.size();
    const auto& patches = scene_.patch_list();
    const bool both = options_.bidirectional;
    // The direction the irradiance of patch i arrived along in the previous step: w_prev,
    // or with both directions, whichever of +-w_prev the patch faced.
    auto arrived = [&](std::size_t i) {
        return both && patches[i].normal.dot(previous_) > 0.0 ? Vec3(-previous_) : previous_;
    };
    // Radiance every patch sends along w (with both directions: along whichever of +-w
    // it faces): emission plus the reflection of the irradiance of the previous step.
    for (std::size_t j = 0; j < n; ++j) {
        if (patch_glossy_[j] && steps_ > 0) {
            const Vec3 out = both && patches[j].normal.dot(w) < 0.0 ? Vec3(-w) : w;
            outgoing_[j] = emission_[j] +
                           4.0 * M_PI * brdf(scene_.material_of(j), patches[j].normal, arrived(j), out) * irradiance_[j];
        } else {
            outgoing_[j] = emission_[j] + reflect_[j] * irradiance_[j];
        }
    }
    std::fill(next_.begin(), next_.end(), Rgb::Zero());
    if (both) {
        // Every entry also carries light along -w, from the receiver back to the source.
        // Each patch faces exactly one of +-w, so it receives once; weight 1/2 keeps the
        // expectation: the pair (w, -w) is sampled with twice the density of w alone.
        for (const auto& e : matrix_.entries) {
            next_[e.receiver] += (0.5 * e.area * inv_area_[e.receiver]) * outgoing_[e.source];
            next_[e.source] += (0.5 * e.area * inv_area_[e.source]) * outgoing_[e.receiver];
        }
    } else {
        for (const auto& e : matrix_.entries) next_[e.receiver] += (e.area * inv_area_[e.receiver]) * outgoing_[e.source];
    }
    irradiance_.swap(next_);
    previous_ = w;
    ++steps_;
    if (glossy_) {
        for (std::size_t i = 0; i < n; ++i) {
            if ((irradiance_[i] == 0.0).all()) continue;
            sum_[i] += 4.0 * M_PI * brdf(scene_.material_of(i), patches[i].normal, arrived(i), to_eye_[i]) * irradiance_[i];
        }
    } else {
        for (std::size_t i = 0; i < n; ++i) sum_[i] += irradiance_[i];
    }
}

void StochasticIteration::run(const Callback& progress) {
    sampling::RandomDirections directions(options_.seed);
    sampling::Rng jitter(options_.seed, /*stream=*/0x717e4 + options_.jitter_stream);
    const long total = options_.iterations;
    const long every = options_.progress_every > 0 ? options_.progress_every : std::max(1L, total / 100);
    const auto start = Clock::now();
    for (long m = 0; m < total; ++m) {
        const Vec3 w = directions.next();
        const Eigen::Vector2d offset(jitter.uniform(), jitter.uniform());
        const auto t0 = Clock::now();
        backend_.transfer(w, offset, matrix_);
        const auto t1 = Clock::now();
        step(w);
        const auto t2 = Clock::now();
        stats_.seconds_visibility += std::chrono::duration<double>(t1 - t0).count();
        stats_.seconds_transport += std::chrono::duration<double>(t2 - t1).count();
        stats_.entries_total += matrix_.entries.size();
        ++stats_.directions;
        ++stats_.iterations;
        if (progress && ((m + 1) % every == 0 || m + 1 == total))
            progress({m + 1, total, std::chrono::duration<double>(Clock::now() - start).count()});
    }
}

RadianceField StochasticIteration::field() const {
    RadianceField f;
    f.view_dependent = glossy_;
    const std::size_t n = inv_area_.size();
    f.radiance.resize(n);
    const double inv_m = steps_ > 0 ? 1.0 / static_cast<double>(steps_) : 0.0;
    const auto& patches = scene_.patch_list();
    for (std::size_t i = 0; i < n; ++i) {
        if (glossy_) {
            // Emission leaves the front side only.
            const bool front = patches[i].normal.dot(to_eye_[i]) > 0.0;
            f.radiance[i] = (front ? emission_[i] : Rgb::Zero()) + sum_[i] * inv_m;
        } else {
            f.radiance[i] = emission_[i] + reflect_[i] * sum_[i] * inv_m;
        }
    }
    return f;
}

}  // namespace raybundle::solver
