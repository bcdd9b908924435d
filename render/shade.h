#pragma once
// Images from a radiance field: flat (one value per patch) and smooth (values at
// patch corners, interpolated barycentrically).
#include "render/gbuffer.h"
#include "render/image.h"
#include "solver/radiance_field.h"

#include <array>
#include <string>
#include <vector>

namespace raybundle::render {

enum class Shading { Flat, Smooth };
// Their names in the enum's order: parsing, messages and the command line's choices.
inline constexpr std::array<const char*, 2> kShadingNames = {"flat", "smooth"};

// Parses "flat" or "smooth"; throws std::invalid_argument otherwise.
Shading parse_shading(const std::string& name);
const char* shading_name(Shading s);

// Per patch, the radiance at its three corners: the area-weighted mean over the
// patches around the corner's vertex that share the patch's material and its shading
// normal there (within 1 degree: the same smooth surface, Scene::corner_normals), so
// that walls meeting at a crease keep their own colours, and light does not bleed
// across materials. Patches split over `threads` (the same result for any count).
Buffer<std::array<scenes::Rgb, 3>> corner_radiance(const scenes::Scene& scene, const solver::RadianceField& field,
                                                   int threads = 1);

// The patch image: the field at each G-buffer sample (Flat: its patch's radiance;
// Smooth: its corners' interpolated). Rows split over `threads`.
Image shade(const scenes::Scene& scene, const solver::RadianceField& field, const GBuffer& gbuffer, Shading mode,
            int threads = 1);

}  // namespace raybundle::render
