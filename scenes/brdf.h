#pragma once
// BRDFs: Lambert plus the physically plausible modified Phong lobe
//   f(w_in, w_out) = albedo / pi + specular (n + 2) / (2 pi) max(0, r . w_out)^n,
// r the mirror direction of w_in. Energy conserving for albedo + specular < 1 and
// reciprocal. Directions: w_in is the direction the light travels (towards the
// surface), w_out the direction it leaves in; both must be on the front side.
#include "scenes/scene.h"

namespace raybundle::scenes {

Rgb brdf(const Material& m, const Vec3& normal, const Vec3& w_in, const Vec3& w_out);

// The directional albedo: the fraction of light arriving along w_in that leaves,
// integrated numerically over the outgoing hemisphere with `samples` x `samples`
// stratified points. For tests and documentation.
Rgb directional_albedo(const Material& m, const Vec3& normal, const Vec3& w_in, int samples);

}  // namespace raybundle::scenes
