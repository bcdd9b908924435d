#pragma once
// The jittered pixel grid of a discrete visibility map: an R x R map perpendicular to
// the direction w that covers the scene's bounding sphere, shifted by a sub-pixel
// jitter, with every vertex projected and snapped to 1/kSubpixel pixel. Shared by the
// discrete backends so that they rasterise exactly the same pixel sets.
#include "scenes/frame.h"
#include "scenes/scene.h"
#include "visibility/patch_arrays.h"
#include "visibility/raster.h"

#include <Eigen/Core>

#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

namespace raybundle::visibility {

class MapGrid {
public:
    // The patches' vertices and corners are read from `arrays` (shared, read only).
    MapGrid(const scenes::Scene& scene, std::shared_ptr<const PatchArrays> arrays, int resolution, bool jitter)
        : resolution_(resolution),
          jitter_(jitter),
          center_(scene.bounds_center()),
          radius_(scene.bounds_radius()),
          arrays_(std::move(arrays)) {}

    // Projects every vertex for direction w and jitter in [0,1)^2 (ignored without
    // jitter: the grid then sits at half a pixel).
    void project(const scenes::Vec3& w, const Eigen::Vector2d& jitter) {
        jx_ = jitter_ ? jitter.x() : 0.5;
        jy_ = jitter_ ? jitter.y() : 0.5;
        scenes::orthonormal_basis(w, u_, v_);
        const double scale = kSubpixel / pixel();
        const auto& positions = arrays_->positions;
        const std::size_t nv = positions.size();
        px_.resize(nv);
        py_.resize(nv);
        for (std::size_t k = 0; k < nv; ++k) {
            const scenes::Vec3 d = positions[k] - center_;
            // Rounded to the nearest sub-pixel unit (the values are positive: no libm call).
            px_[k] = std::floor((u_.dot(d) + radius_) * scale + jx_ * kSubpixel + 0.5);
            py_[k] = std::floor((v_.dot(d) + radius_) * scale + jy_ * kSubpixel + 0.5);
        }
    }

    int resolution() const { return resolution_; }
    int width() const { return resolution_ + 1; }  // one spare pixel for the jitter shift
    double pixel() const { return 2.0 * radius_ / resolution_; }
    double pixel_area() const { return pixel() * pixel(); }

    // Patch i's projected corners in sub-pixel units.
    void triangle(std::uint32_t i, double X[3], double Y[3]) const {
        const std::uint32_t* t = &arrays_->corners[3 * i];
        for (int k = 0; k < 3; ++k) {
            X[k] = px_[t[k]];
            Y[k] = py_[t[k]];
        }
    }

    // The point on the map's plane (through the scene's centre) under the centre of
    // pixel (x, y); a pixel's ray is this point + t w.
    scenes::Vec3 pixel_point(int x, int y) const {
        return center_ + ((x + 0.5 - jx_) * pixel() - radius_) * u_ + ((y + 0.5 - jy_) * pixel() - radius_) * v_;
    }

    const scenes::Vec3& center() const { return center_; }
    double radius() const { return radius_; }
    // Every vertex's projected position in sub-pixel units (after project()).
    const std::vector<double>& projected_x() const { return px_; }
    const std::vector<double>& projected_y() const { return py_; }
    const scenes::Vec3& u() const { return u_; }
    const scenes::Vec3& v() const { return v_; }

private:
    int resolution_;
    bool jitter_;
    scenes::Vec3 center_;
    double radius_;
    std::shared_ptr<const PatchArrays> arrays_;
    scenes::Vec3 u_ = scenes::Vec3::UnitX(), v_ = scenes::Vec3::UnitY();
    double jx_ = 0.5, jy_ = 0.5;
    std::vector<double> px_, py_;
};

}  // namespace raybundle::visibility
