#include "scenes/brdf.h"

#include "scenes/frame.h"

#include <algorithm>
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

Rgb brdf_glossy(const Material& m, const Vec3& normal, const Vec3& w_in, const Vec3& w_out) {
    const double cos_in = -normal.dot(w_in);
    if (!m.glossy() || cos_in <= 0.0 || normal.dot(w_out) <= 0.0) return Rgb::Zero();
    const double c = (w_in + 2.0 * cos_in * normal).dot(w_out);
    return c > 0.0 ? Rgb(m.specular * ((m.exponent + 2.0) / (2.0 * M_PI) * std::pow(c, m.exponent))) : Rgb::Zero();
}

namespace {

double diffuse_share(const Material& m) {
    const double d = m.albedo.mean(), s = m.glossy() ? m.specular.mean() : 0.0;
    return d + s > 0.0 ? d / (d + s) : 1.0;
}

Vec3 mirror(const Vec3& normal, const Vec3& w_out) { return 2.0 * normal.dot(w_out) * normal - w_out; }

}  // namespace

BrdfSample sample_glossy(const Material& m, const Vec3& normal, const Vec3& w_out, double u1, double u2) {
    const Vec3 r = mirror(normal, w_out);
    Vec3 a, b;
    orthonormal_basis(r, a, b);
    const double c = std::pow(u1, 1.0 / (m.exponent + 1.0));
    const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
    const double phi = 2.0 * M_PI * u2;
    BrdfSample out;
    out.direction = (s * std::cos(phi) * a + s * std::sin(phi) * b + c * r).normalized();
    out.pdf = glossy_pdf(m, normal, w_out, out.direction);
    return out;
}

double glossy_pdf(const Material& m, const Vec3& normal, const Vec3& w_out, const Vec3& w) {
    const double c = mirror(normal, w_out).dot(w);
    return c > 0.0 ? (m.exponent + 1.0) / (2.0 * M_PI) * std::pow(c, m.exponent) : 0.0;
}

BrdfSample sample_brdf(const Material& m, const Vec3& normal, const Vec3& w_out, double u1, double u2, double u3) {
    BrdfSample out;
    if (u1 < diffuse_share(m)) {
        Vec3 a, b;
        orthonormal_basis(normal, a, b);
        const double r = std::sqrt(u2), phi = 2.0 * M_PI * u3;
        out.direction = r * std::cos(phi) * a + r * std::sin(phi) * b + std::sqrt(std::max(0.0, 1.0 - u2)) * normal;
    } else {
        out.direction = sample_glossy(m, normal, w_out, u2, u3).direction;
    }
    out.pdf = brdf_pdf(m, normal, w_out, out.direction);
    return out;
}

double brdf_pdf(const Material& m, const Vec3& normal, const Vec3& w_out, const Vec3& w) {
    const double pd = diffuse_share(m);
    double pdf = pd * std::max(0.0, normal.dot(w)) / M_PI;
    if (pd < 1.0) pdf += (1.0 - pd) * glossy_pdf(m, normal, w_out, w);
    return pdf;
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
