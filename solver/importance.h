#pragma once
// The image's importance of a global walk (004 section 7): "the sum of luminances of
// all pixels of the image" its estimate adds. Per patch p a weight w_p (RGB), once per
// scene from the camera, and for a walk whose estimate of patch p is X_p:
//
//   I = sum_p Y(w_p X_p),   Y(rgb) = 0.2126 r + 0.7152 g + 0.0722 b (Rec. 709 luminance)
//
//   w_p = c_p rho_p  diffuse scenes (X the irradiance; rho_p the diffuse reflectance
//                    that turns it into the radiance the camera sees)
//   w_p = c_p        glossy scenes (X already the radiance towards the eye)
//
// c_p is the share of the image where the camera sees patch p's front: a grid of at
// most 128 x 128 camera rays (the image's aspect kept), cast once. A patch the camera
// does not see weighs 0 (solver/walk_source_vegas.cpp and walk_source_metropolis.cpp
// say how its light is still estimated).
#include "solver/transport.h"

#include <vector>

namespace raybundle::solver {

struct ImportanceWeights {
    std::vector<Rgb> weight;  // per patch
    double covered = 0.0;     // the share of the camera's rays that met a patch's front
    int rays = 0;
};

ImportanceWeights importance_weights(const Transport& transport, bool glossy);

inline double luminance(const Rgb& c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }

}  // namespace raybundle::solver
