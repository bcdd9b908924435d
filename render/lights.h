#pragma once
// The area lights (emissive patches) as the final gather and the path tracer see them:
// sampling a point in proportion to power, the density of that choice, and the exact
// unoccluded light a diffuse point receives from all of them.
//
// Exact unoccluded light (Lambert's polygon formula; Arvo, "Analytic methods for
// simulated light transport", 1995): the projected solid angle of a polygon seen from
// x with normal n is
//   Omega(x) = 1/2 sum_i beta_i  n . (u_i x u_i+1) / |u_i x u_i+1|,
// u_i the unit directions to its vertices, beta_i the angle between u_i and u_i+1, so
// the irradiance from a polygon of radiance Le is Le Omega. The emissive patches are
// grouped into planar lights (same object, material and plane); a light's Omega is the
// sum over its outline alone, since interior edges cancel; a light that the plane of x
// cuts has its outline clipped to that plane and closed along it (the triangles clipped
// one by one give the same). That sum is pi times the form factor of
// solver::point_to_outline, which the diffuse shot's groups of emitters share. The final gather multiplies
// each light's exact value by that light's stochastic shadow ratio (Heitz, Hill,
// McGuire, "Combining analytic direct illumination and stochastic shadows", 2018): noise
// remains only where a light is partly hidden.
#include "scenes/scene.h"

#include <array>
#include <cstdint>
#include <vector>

namespace raybundle::render {

class AreaLights {
public:
    explicit AreaLights(const scenes::Scene& scene);

    bool empty() const { return emitters_.empty(); }
    std::size_t patch_count() const { return emitters_.size(); }
    std::size_t light_count() const { return lights_.size(); }

    struct Sample {
        std::uint32_t patch;
        scenes::Vec3 point;
    };
    // A point on an emissive patch, the patch chosen in proportion to its power with
    // `pick` in [0, 1) (stratify it across samples), uniform on the triangle by (u1, u2).
    Sample sample(double pick, double u1, double u2) const;
    // The probability that sample() picks patch p (0 for a patch that does not emit).
    double probability(std::size_t p) const { return power_[p]; }
    // The solid-angle density of sample() towards patch p's point seen at distance r,
    // its cosine towards the receiver cos_y.
    double pdf_solid_angle(std::size_t p, double r, double cos_y) const {
        return power_[p] / patches_[p].area * r * r / cos_y;
    }

    // The exact unoccluded irradiance at x (unit normal n) from every area light's
    // front side, per channel: sum over lights of Le * Omega(x).
    scenes::Rgb irradiance(const scenes::Vec3& x, const scenes::Vec3& n) const;
    // The same from light l alone (0 <= l < light_count()).
    scenes::Rgb irradiance(std::size_t l, const scenes::Vec3& x, const scenes::Vec3& n) const;
    // A point of light l, uniform over its area (a patch by area with `pick`, uniform on
    // the triangle by (u1, u2)); the density in area is 1 / light_area(l).
    Sample sample_light(std::size_t l, double pick, double u1, double u2) const;
    double light_area(std::size_t l) const { return lights_[l].area; }
    const scenes::Rgb& light_emission(std::size_t l) const { return lights_[l].emission; }
    // The projected solid angle of one triangle (a, b, c counter-clockwise about its
    // front normal) seen from x with normal n: clipped to the hemisphere above x, zero
    // when x is behind it. Exposed for tests.
    static double projected_solid_angle(const scenes::Vec3& x, const scenes::Vec3& n, const scenes::Vec3& a,
                                        const scenes::Vec3& b, const scenes::Vec3& c);

private:
    // A cumulative distribution (non-decreasing, ending at about 1), and for each of
    // size() equal cells of [0, 1) the range of entries where a pick in it can land:
    // index(u) is std::upper_bound's answer (at most size() - 1) from a search of a
    // few entries, not of all (a light of 1,024 patches).
    struct Cdf {
        std::vector<double> values;
        std::vector<std::uint32_t> guide;  // per cell boundary c / size(): upper_bound of it
        void finish();                     // after the values
        std::size_t index(double u) const;
    };
    struct Light {
        scenes::Rgb emission;
        scenes::Vec3 normal;  // unit, front
        double offset;        // plane: normal . y = offset
        std::vector<std::uint32_t> patches;
        std::vector<std::array<scenes::Vec3, 2>> outline;  // directed edges, counter-clockwise about the normal
        Cdf area_cdf;                                      // over its patches, normalised
        std::vector<std::array<scenes::Vec3, 3>> corners;  // its patches', in that order
        double area = 0.0;
    };
    const scenes::Scene& scene_;
    const Buffer<scenes::Patch>& patches_;
    std::vector<std::uint32_t> emitters_;
    Cdf cdf_;                                              // over emitters_, by power
    std::vector<std::array<scenes::Vec3, 3>> corners_;  // emitters_' corners, in that order
    std::vector<double> power_;
    std::vector<Light> lights_;
};

}  // namespace raybundle::render
