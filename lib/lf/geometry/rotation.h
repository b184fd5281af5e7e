// Rotation matrices <-> unit quaternions (w, x, y, z), as the view request's
// wire format carries orientations (lf/wire/wire.h).
#pragma once

#include <opencv2/core.hpp>

namespace lf {

// Shepperd's method; the result has unit norm and w >= 0 is not enforced.
cv::Vec4d quaternion_from_rotation(const cv::Matx33d& R);
// Normalises q first.
cv::Matx33d rotation_from_quaternion(const cv::Vec4d& q);

}  // namespace lf
