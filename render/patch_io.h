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

}  // namespace raybundle::render
