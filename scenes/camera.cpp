#include "scenes/camera.h"

#include <cmath>

namespace raybundle::scenes {

PinholeCamera::PinholeCamera(const Camera& c)
    : eye_(c.eye), tan_half_(std::tan(0.5 * c.fov_y * M_PI / 180.0)), width_(c.width), height_(c.height) {
    forward_ = (c.target - c.eye).normalized();
    right_ = forward_.cross(c.up).normalized();
    up_ = right_.cross(forward_);
}

Vec3 PinholeCamera::direction(double x, double y) const {
    const double aspect = static_cast<double>(width_) / height_;
    const double sx = (2.0 * x / width_ - 1.0) * tan_half_ * aspect;
    const double sy = (1.0 - 2.0 * y / height_) * tan_half_;
    return (forward_ + sx * right_ + sy * up_).normalized();
}

bool PinholeCamera::project(const Vec3& p, double& x, double& y) const {
    const Vec3 d = p - eye_;
    const double depth = d.dot(forward_);
    if (!(depth > 0.0)) return false;
    const double aspect = static_cast<double>(width_) / height_;
    x = 0.5 * width_ * (1.0 + d.dot(right_) / (depth * tan_half_ * aspect));
    y = 0.5 * height_ * (1.0 - d.dot(up_) / (depth * tan_half_));
    return true;
}

}  // namespace raybundle::scenes
