#include "scenes/brdf.h"

#include "scenes/frame.h"

#include <cmath>

namespace raybundle::scenes {

Rgb brdf(const scenes::Material& m, const Vec3& normal, const Vec3& w_in, const Vec3& w_out) {
    const double cos_in = -normal.dot(w_in);
    const double cos_out = normal.dot(w_out);
    if (cos_in <= 0.0 || cos_out <= 0.0) return Rgb::Zero();
    Rgb f = m.albedo * (1.0 / M_PI);
    if (m.glossy()) {
        const Vec3 r = w_in + 2.0 * cos_in * normal;
        const double c = r.dot(w_out);
        if (c > 0.0) f += m.specular * ((m.exponent + 2.0) / (2.0 * M_PI) * std::pow(c, m.exponent));
    }
    return f;
}

Rgb directional_albedo(const scenes::Material& m, const Vec3& normal, const Vec3& w_in, int samples) {
    // Stratified midpoints in (cos theta, phi) over the hemisphere around the normal:
    // d omega = d(cos theta) d phi, so each cell has solid angle 2 pi / samples^2.
    Vec3 u, v;
    scenes::orthonormal_basis(normal, u, v);
    Rgb sum = Rgb::Zero();
    for (int a = 0; a < samples; ++a)
        for (int b = 0; b < samples; ++b) {
            const double ct = (a + 0.5) / samples;
            const double st = std::sqrt(1.0 - ct * ct);
            const double phi = 2.0 * M_PI * (b + 0.5) / samples;
            const Vec3 w = st * std::cos(phi) * u + st * std::sin(phi) * v + ct * normal;
            sum += brdf(m, normal, w_in, w) * ct;
        }
    return sum * (2.0 * M_PI / (static_cast<double>(samples) * samples));
}

}  // namespace raybundle::scenes
