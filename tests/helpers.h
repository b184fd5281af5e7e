// Shared checks for the tests.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/render/plan.h"

namespace testing_lf {

// Path under ../shared/data.
std::string data_path(const std::string& rel);

// Whether the real dataset ../shared/data/<dataset> is present (a fresh clone
// has none; scripts/get-data.sh fetches it).
bool have_data(const std::string& dataset);

// Skips the current test (or, in SetUpTestSuite, the suite), naming the
// dataset it needs, when that dataset is absent. scripts/test.sh lists the
// skipped tests and fails when anything is skipped while ../shared/data is
// present, so a test never skips silently where the data exists.
#define LF_NEEDS_DATA(dataset)                                                 \
  do {                                                                         \
    if (!testing_lf::have_data(dataset))                                       \
      GTEST_SKIP() << "needs the real data " << testing_lf::data_path(dataset) \
                   << " (absent; scripts/get-data.sh fetches it)";             \
  } while (0)

// A request for the view from `eye` looking at `target` (up +y, vertical
// field of view `vfov` degrees, w x h pixels) focused on `plane`.
lf::ViewRequest look_request(const cv::Vec3d& eye, const cv::Vec3d& target, double vfov,
                             const lf::FocalPlane& plane, int w, int h);
// The plane z = `z`, normal +z.
lf::FocalPlane plane_z(double z);

struct WeightCheck {
  size_t seen = 0;  // pixels whose line meets the camera surface (locate())
  size_t unseen = 0;
  // max |sum of fragment weights - sum of aperture weights of the cameras
  // that see the pixel's focal point| over seen pixels (= |sum - 1| when
  // every camera sees it, i.e. invisible == 0)
  double max_sum_error = 0;
  size_t invisible = 0;                   // (pixel, camera) pairs with weight the camera cannot see
  double max_unseen_sum = 0;              // max sum of weights over unseen pixels
  double min_weight = 1, max_weight = 0;  // over all fragment pixels
  size_t coverage_mismatch = 0;           // pixels where plan runs != (locate weight > 0)
  size_t rect_mismatch = 0;               // fragments whose rect != bbox of nonzero-weight pixels
  size_t overlaps = 0;                    // pixels claimed twice by one camera's runs
  bool finite = true;
  size_t fragment_pixels = 0;
};

// Plans every camera's fragment for the request and checks the weights
// against ViewGeometry::locate() at every output pixel (brute force).
WeightCheck check_weights(const lf::Rig& rig, const lf::ViewRequest& req);

// Asserts the invariants every view must satisfy.
// all_visible: the view is an ordinary one where every camera sees every
// focal point it is weighted for (so weights sum to exactly 1).
void expect_valid(const WeightCheck& c, const std::string& what, bool all_visible = true);

// Leave-one-out: a rig without camera j, its images, and camera j's view
// (W x H) with its real image there, the truth to compare with.
struct Held {
  lf::Rig rig;
  std::vector<cv::Mat> images;
  lf::ViewRequest req;
  cv::Mat truth;
};
Held hold_out(const lf::Rig& rig, const std::vector<cv::Mat>& images, int j, int W, int H);
// PSNR of the held-out view rendered through plane `p` (a border of 2.5 %
// of the height left out).
double psnr_at(const Held& h, const lf::FocalPlane& p);

}  // namespace testing_lf
