#pragma once
// The pinhole camera of a scene: primary rays through pixel centres (the renderer's,
// and the solver's where it weighs walks by what the camera sees: solver/importance.h).
#include "scenes/scene.h"

namespace raybundle::scenes {

class PinholeCamera {
public:
    explicit PinholeCamera(const Camera& c);
    int width() const { return width_; }
    int height() const { return height_; }
    const Vec3& eye() const { return eye_; }
    // Unit direction through image point (x, y) in pixels; (0,0) is the top-left
    // corner, (x + 0.5, y + 0.5) the centre of pixel (x, y).
    Vec3 direction(double x, double y) const;
    // The image point (x, y) in pixels that `p` projects to, the inverse of
    // direction(); false for a point not in front of the eye.
    bool project(const Vec3& p, double& x, double& y) const;

private:
    Vec3 eye_, forward_, right_, up_;
    double tan_half_;
    int width_, height_;
};

}  // namespace raybundle::scenes
