#pragma once
// Per-patch outputs of a radiance field.
#include "solver/radiance_field.h"

#include <string>

namespace raybundle::render {

// CSV with the header  id,cx,cy,cz,nx,ny,nz,area,r,g,b  (centroid, unit normal, area,
// radiance), one row per patch.
void write_patch_csv(const std::string& path, const scenes::Scene& scene, const solver::RadianceField& field);

// Binary little-endian PLY: three vertices per patch, faces with 8-bit sRGB colours
// (the PNG tone map at `exposure`) and the linear radiance as float properties
// radiance_r/g/b. Opens in MeshLab.
void write_patch_ply(const std::string& path, const scenes::Scene& scene, const solver::RadianceField& field,
                     double exposure);

// Whether an output name asks for a baked asset (.glb, case-insensitive).
bool is_baked_asset(const std::string& path);

// The refined mesh with its solved radiance as a binary glTF 2.0 asset (.glb): three
// vertices per patch as in the PLY (POSITION, and NORMAL: the patch's); COLOR_0 the
// patch's radiance L after the PNG's exposure, min(1, 2^exposure L), linear (glTF
// clamps vertex colours to 0..1), and _RADIANCE L itself (float RGB, the PLY's
// radiance_r/g/b); one material with KHR_materials_unlit, so that viewers show the
// colours as they are; the exposure and what the colours are in the asset's `extras`;
// the scene's camera. Valid under the Khronos glTF validator.
void write_patch_glb(const std::string& path, const scenes::Scene& scene, const solver::RadianceField& field,
                     double exposure);

}  // namespace raybundle::render
