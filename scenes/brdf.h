#pragma once
// BRDFs: Lambert plus the physically plausible modified Phong lobe
//   f(w_in, w_out) = albedo / pi + specular (n + 2) / (2 pi) max(0, r . w_out)^n,
// r the mirror direction of w_in. Energy conserving for albedo + specular < 1 and
// reciprocal. Directions: w_in is the direction the light travels (towards the
// surface), w_out the direction it leaves in; both must be on the front side.
#include "scenes/scene.h"

namespace raybundle::scenes {

Rgb brdf(const Material& m, const Vec3& normal, const Vec3& w_in, const Vec3& w_out);

// The glossy lobe alone: specular (n+2)/(2 pi) max(0, r . w_out)^n (zero for a
// diffuse material), with the same conventions as brdf().
Rgb brdf_glossy(const Material& m, const Vec3& normal, const Vec3& w_in, const Vec3& w_out);

// Importance sampling of the BRDF seen from w_out (the direction light leaves in):
// a direction w towards the light (w_in = -w) drawn from the mixture
//   p(w) = P_d cos(theta) / pi + (1 - P_d) (n+1)/(2 pi) cos^n(alpha),
// alpha the angle between w and the mirror direction of w_out, and
// P_d = mean(albedo) / (mean(albedo) + mean(specular)). The lobe may reach below the
// horizon: such w have brdf() = 0 and the estimator stays unbiased. u1 picks the
// component, (u2, u3) the direction.
struct BrdfSample {
    Vec3 direction = Vec3::Zero();  // unit, towards the light
    double pdf = 0.0;               // solid-angle density of the mixture
};
BrdfSample sample_brdf(const Material& m, const Vec3& normal, const Vec3& w_out, double u1, double u2, double u3);
// The mixture's density of w (towards the light) given w_out.
double brdf_pdf(const Material& m, const Vec3& normal, const Vec3& w_out, const Vec3& w);
// The Phong lobe alone: a direction with density (n+1)/(2 pi) cos^n(alpha) about the
// mirror direction of w_out, and that density.
BrdfSample sample_glossy(const Material& m, const Vec3& normal, const Vec3& w_out, double u1, double u2);
double glossy_pdf(const Material& m, const Vec3& normal, const Vec3& w_out, const Vec3& w);

// The directional albedo: the fraction of light arriving along w_in that leaves,
// integrated numerically over the outgoing hemisphere with `samples` x `samples`
// stratified points. For tests and documentation.
Rgb directional_albedo(const Material& m, const Vec3& normal, const Vec3& w_in, int samples);

}  // namespace raybundle::scenes
