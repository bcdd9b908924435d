#pragma once
// The pinhole camera of a scene: primary rays through pixel centres.
#include "scenes/scene.h"

namespace raybundle::render {

class PinholeCamera {
public:
    explicit PinholeCamera(const scenes::Camera& c);
    int width() const { return width_; }
    int height() const { return height_; }
    const scenes::Vec3& eye() const { return eye_; }
    // Unit direction through image point (x, y) in pixels; (0,0) is the top-left
    // corner, (x + 0.5, y + 0.5) the centre of pixel (x, y).
    scenes::Vec3 direction(double x, double y) const;

private:
    scenes::Vec3 eye_, forward_, right_, up_;
    double tan_half_;
    int width_, height_;
};

}  // namespace raybundle::render
