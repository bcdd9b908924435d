#pragma once
// The global painter's algorithm (004 section 5.1.3).
//
// Parameters (BackendOptions): resolution (int, pixels per side of the visibility map;
// default: default_resolution(scene)), jitter (bool, default true).
//
// Patches are sorted along w by their centres and scan-converted into one R x R map
// perpendicular to w that covers the scene's bounding sphere. A pixel holds the last
// patch that faces w (a source) or "none" behind a patch facing against w (a
// receiver). A receiver reads the pixels it covers before overwriting them: each
// read of source j adds one pixel's area to A(i, j). The sort is a radix sort on the
// centres' depth quantised to 32 bits, so a direction costs O(n + pixels).
// Centre sorting is exact for non-intersecting patches that are small against their
// distances; interpenetrating patches need the global z-buffer instead.
// With sky entries the map starts as "open sky" (n) instead of "none"; a receiver
// reading it sees the sky, and the sources left in the map at the end see it along -w.
#include "visibility/backend.h"
#include "visibility/map_grid.h"
#include "visibility/patch_arrays.h"

#include <cstdint>
#include <vector>

namespace raybundle::visibility {

class PainterBackend final : public Backend {
public:
    // `arrays`: shared with the other backends of a set (made here where none is given).
    PainterBackend(const scenes::Scene& scene, const BackendOptions& options,
                   std::shared_ptr<const PatchArrays> arrays = nullptr);
    std::string name() const override { return "painter"; }
    int resolution() const override { return grid_.resolution(); }
    void transfer(const Vec3& direction, const Eigen::Vector2d& jitter, GeometryMatrix& out) override;

private:
    std::shared_ptr<const PatchArrays> arrays_;  // read only
    MapGrid grid_;
    bool sky_;

    // Scratch, reused between directions.
    std::vector<std::int8_t> side_;              // sign of n . w per patch
    std::vector<std::uint64_t> keys_, scratch_;  // depth (32 bits) | is source (1) | patch (31)
    std::vector<std::int32_t> map_;
    std::vector<std::uint32_t> counts_;
    std::vector<std::uint32_t> touched_;
};

// The painter's algorithm with a radiance map (004 section 5.3.1), for the piecewise
// linear basis: sources are drawn with their corners' radiance interpolated across
// them (Gouraud), and a receiver reads the map over its own pixels, weighting each
// pixel by the receiver's three hat functions (barycentric coordinates), before it
// blocks them. The map starts at the sky radiance (zero without a sky).
//
// Per receiver corner k the result is  pixel_area * sum_pixels lambda_k L : divided
// by A_i / 3 it estimates the cosine-weighted irradiance at the corner, averaged with
// the hat as weight. (The paper samples the map at the vertex itself: a point on the
// boundary of the patches around it, whose pixel belongs to whichever was drawn last,
// and which a patch smaller than a pixel misses; the hat-weighted read uses every
// pixel of the receiver and has neither problem.)
class GouraudPainter {
public:
    GouraudPainter(const scenes::Scene& scene, const BackendOptions& options,
                   std::shared_ptr<const PatchArrays> arrays = nullptr);
    int resolution() const { return grid_.resolution(); }

    // corner_out[3 j + k]: radiance source j sends along w at its corner k.
    // corner_in[3 i + k] (resized to 3n, overwritten): pixel_area sum lambda_k L over
    // receiver i's pixels; zero for patches that do not face against w.
    void transfer(const Vec3& direction, const Eigen::Vector2d& jitter, const std::vector<scenes::Rgb>& corner_out,
                  const scenes::Rgb& sky, std::vector<scenes::Rgb>& corner_in);

private:
    std::shared_ptr<const PatchArrays> arrays_;  // read only
    MapGrid grid_;
    std::vector<std::uint64_t> keys_, scratch_;
    std::vector<scenes::Rgb> map_;
};

}  // namespace raybundle::visibility
