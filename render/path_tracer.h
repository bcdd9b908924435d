#pragma once
// A brute-force reference: unidirectional path tracing with the project's BRDFs
// (scenes/brdf.h), area lights, point and directional lights and the sky, unbiased, so that any image
// of the final gather can be checked against it on any scene.
//
// Per camera sample (on a jittered grid over the pixel, sampling/strata.h):
// at every vertex next-event estimation towards a power-chosen point of an area light
// and towards every point and directional light, and a direction drawn from the BRDF (scenes/brdf.h
// sample_brdf) that continues the path; an emitter met by that direction counts with
// the balance heuristic against light sampling, the sky with weight 1 (it is never
// sampled directly). Russian roulette from the fourth vertex on (survival probability
// the path throughput's largest channel, at most 0.95) keeps it unbiased without a
// depth limit; a hard limit of 10,000 vertices only stops pathological scenes. The back
// of a one-sided patch absorbs everything and shows black, as everywhere in raybundle.
//
// Reproducible: pixel p draws from its own stream (sampling/streams.h kPathPixels).
#include "render/camera.h"
#include "render/image.h"
#include "sampling/run.h"
#include "scenes/ray_caster.h"

#include <cstdint>

namespace raybundle::render {

struct PathTraceOptions {
    int spp = 256;  // camera samples (paths) per pixel
    // Which pass of a run in rounds (render/progressive.h): its own random streams.
    std::uint64_t pass = 0;
};

struct PathTraceResult {
    Image image;
    long paths = 0, rays = 0;
    double seconds = 0.0;
};

// Progress ("path trace", by rows), seed and threads come from `run`. Throws OptionError
// for spp < 1.
PathTraceResult path_trace(const scenes::Scene& scene, const scenes::RayCaster& caster, const PinholeCamera& camera,
                           const PathTraceOptions& options, const sampling::RunOptions& run);

}  // namespace raybundle::render
