// Quilts (lf/render/quilt.h) and their interleaving for lenticular displays
// (lf/render/lenticular.h): layout, eye geometry, the wire format, and the
// interleave against the display's published formula, computed here on
// its own in double precision.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

#include "helpers.h"
#include "lf/geometry/view.h"
#include "lf/quality/synthetic.h"
#include "lf/render/lenticular.h"
#include "lf/render/quilt.h"
#include "lf/wire/wire.h"

using testing_lf::look_request;
using testing_lf::plane_z;

namespace {

lf::ViewRequest quilt_request(int views, int cols, int rows, int w, int h, double baseline) {
  lf::ViewRequest r = look_request({0, 0, -10}, {0, 0, 0}, 30, plane_z(0), w, h);
  r.quilt.views = views, r.quilt.cols = cols, r.quilt.rows = rows, r.quilt.baseline = baseline;
  return r;
}

// Pixel x of world point P in a request's view.
double pixel_x(const lf::ViewRequest& r, const cv::Vec3d& p) {
  const cv::Vec3d c = r.view.R * (p - r.view.position);
  return r.view.intrinsics().fx * c[0] / c[2] + r.view.intrinsics().cx;
}

}  // namespace

TEST(Quilt, TilesRunFromTheBottomLeftAndTheNameSaysTheLayout) {
  lf::Quilt q;
  q.views = 48, q.cols = 8, q.rows = 6;
  EXPECT_EQ(lf::quilt_tile(q, 3360, 3360, 0), cv::Rect(0, 2800, 420, 560));
  EXPECT_EQ(lf::quilt_tile(q, 3360, 3360, 7), cv::Rect(2940, 2800, 420, 560));
  EXPECT_EQ(lf::quilt_tile(q, 3360, 3360, 8), cv::Rect(0, 2240, 420, 560));
  EXPECT_EQ(lf::quilt_tile(q, 3360, 3360, 47), cv::Rect(2940, 0, 420, 560));
  EXPECT_EQ(lf::quilt_suffix(q, 3360, 3360), "_qs8x6a0.75");
  EXPECT_EQ(lf::quilt_suffix(q, 3840, 2160), "_qs8x6a1.333");
}

TEST(Quilt, EyesSpanTheBaselineAndConvergeOnTheFocalPlane) {
  const lf::ViewRequest req = quilt_request(5, 5, 1, 5 * 160, 120, 2.0);  // focal plane 10 ahead
  EXPECT_NEAR(lf::convergence_distance(req), 10.0, 1e-12);
  const cv::Vec3d x(req.view.R(0, 0), req.view.R(0, 1), req.view.R(0, 2));
  const cv::Vec3d on_plane(0, 0, 0), near(0.3, 0.2, -5), far(-0.4, 0.1, 10);
  double last_near = 1e9, last_far = -1e9;
  for (int i = 0; i < 5; ++i) {
    const lf::ViewRequest eye = lf::quilt_eye(req, i);
    EXPECT_TRUE(eye.quilt.empty());
    EXPECT_EQ(eye.view.width, 160);
    EXPECT_EQ(eye.view.height, 120);
    // Eye 0 the leftmost, -b/2 along the view's x axis; evenly spaced.
    EXPECT_NEAR((eye.view.position - req.view.position).dot(x), -1.0 + 0.5 * i, 1e-12) << i;
    EXPECT_NEAR(cv::norm(eye.view.position - req.view.position), std::abs(-1.0 + 0.5 * i), 1e-12);
    // The focal plane's point on the axis is at the same pixel in every eye
    // (the centre of the tile: the request has no lens shift).
    EXPECT_NEAR(pixel_x(eye, on_plane), 0.5 * (160 - 1), 1e-9) << i;
    // Parallax: in front of the focal plane content moves against the eye
    // (out of a display's surface), behind it with the eye.
    const double n = pixel_x(eye, near), f = pixel_x(eye, far);
    if (i > 0) {
      EXPECT_LT(n, last_near - 1.0) << i;
      EXPECT_GT(f, last_far + 1.0) << i;
    }
    last_near = n, last_far = f;
  }
  // Focused at infinity: parallel eyes (no shift).
  lf::ViewRequest inf = req;
  inf.focal_plane = lf::FocalPlane::infinity();
  EXPECT_TRUE(std::isinf(lf::convergence_distance(inf)));
  EXPECT_EQ(lf::quilt_eye(inf, 0).view.shift_x, 0.0);
  EXPECT_EQ(lf::baseline_for_cone(lf::convergence_distance(inf), 40), 0.0);
  EXPECT_NEAR(lf::baseline_for_cone(10, 40), 20 * std::tan(20 * CV_PI / 180), 1e-12);
  EXPECT_THROW(lf::quilt_eye(req, 5), std::invalid_argument);
  EXPECT_THROW(lf::quilt_eye(inf, -1), std::invalid_argument);
}

TEST(Quilt, TheArrayExtentIsItsWidthAlongTheAxis) {
  const lf::Rig rig = lf::synthetic_grid_rig(3, 4, 0.5, 64, 48, 40);  // 4 columns 0.5 apart
  const lf::ViewRequest req =
      look_request({0.75, 0.5, -10}, {0.75, 0.5, 0}, 30, plane_z(0), 64, 48);
  const cv::Vec3d x(req.view.R(0, 0), req.view.R(0, 1), req.view.R(0, 2));
  EXPECT_NEAR(lf::array_extent(rig, x), 1.5, 1e-9);
}

TEST(Quilt, RequestsValidateAndCrossTheWire) {
  lf::ViewRequest req = quilt_request(48, 8, 6, 8 * 80, 6 * 60, 1.25);
  req.viewer_id = 3, req.sequence = 77;
  const std::vector<uint8_t> bytes = lf::serialize_request(req);
  ASSERT_EQ(bytes.size(), lf::kRequestSize + lf::kQuiltBlockSize + 4);
  EXPECT_EQ(bytes[5], 4);  // version 4
  const lf::ViewRequest back = lf::parse_request(bytes.data(), bytes.size());
  EXPECT_EQ(back.quilt.views, 48);
  EXPECT_EQ(back.quilt.cols, 8);
  EXPECT_EQ(back.quilt.rows, 6);
  EXPECT_EQ(back.quilt.baseline, 1.25);
  EXPECT_EQ(back.view.width, 640);
  // Every byte matters (the CRC), and a short or long buffer is refused.
  for (size_t at : {size_t{150}, size_t{152}, size_t{156}, size_t{165}}) {
    std::vector<uint8_t> bad = bytes;
    bad[at] ^= 0x10;
    EXPECT_THROW(lf::parse_request(bad.data(), bad.size()), lf::WireError) << at;
  }
  EXPECT_THROW(lf::parse_request(bytes.data(), bytes.size() - 1), lf::WireError);
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  EXPECT_THROW(lf::parse_request(longer.data(), longer.size()), lf::WireError);
  // Layouts that cannot be.
  auto refused = [&](auto change) {
    lf::ViewRequest r = req;
    change(r);
    EXPECT_THROW(lf::validate(r), std::invalid_argument);
    EXPECT_THROW(lf::serialize_request(r), std::invalid_argument);
  };
  refused([](lf::ViewRequest& r) { r.quilt.views = 49; });  // more views than tiles
  refused([](lf::ViewRequest& r) { r.quilt.views = 1; });
  refused([](lf::ViewRequest& r) { r.quilt.views = lf::Quilt::kMaxViews + 1; });
  refused([](lf::ViewRequest& r) { r.view.width += 1; });  // not whole tiles
  refused([](lf::ViewRequest& r) { r.quilt.baseline = std::nan(""); });
  refused([](lf::ViewRequest& r) { r.quilt.baseline = -1; });
  refused([](lf::ViewRequest& r) { r.quilt.cols = 16, r.quilt.rows = 16; });  // 256 tiles
  refused([](lf::ViewRequest& r) {
    r.surface.tile = 16, r.surface.cols = 40, r.surface.rows = 23;
    r.surface.planes = {plane_z(0)};
    r.surface.plane_of.assign(40 * 23, 0);
  });
}

namespace {

// A calibration of the Looking Glass Portrait's form (values of the same
// magnitude as a real unit's visual.json; nothing here depends on them).
const char* kPortrait =
    R"({"configVersion": "3.0", "pitch": {"value": 52.58}, "slope": {"value": -7.19},
        "center": {"value": 0.565}, "viewCone": {"value": 40.0}, "invView": {"value": 1.0},
        "DPI": {"value": 324.0}, "screenW": {"value": 1536.0}, "screenH": {"value": 2048.0},
        "flipImageX": {"value": 0.0}, "flipSubp": {"value": 0.0}})";

// The published formula (HoloPlay Core's lenticular shader) in double
// precision: the view of sub-pixel c of pixel (x, y), and how far the
// phase a * views lies from a view boundary.
int published_view(const lf::DisplayCalibration& c, int views, int x, int y, int sub,
                   double* margin) {
  const double pitch = c.pitch * c.screen_w / c.dpi * std::cos(std::atan(1.0 / c.slope));
  const double tilt = c.screen_h / (c.screen_w * c.slope);
  const double subp = 1.0 / (3 * c.screen_w);
  double u = (x + 0.5) / c.screen_w;
  if (c.flip_image_x) u = 1 - u;
  const double v = 1 - (y + 0.5) / c.screen_h;  // texture v runs upward
  double a = (u + sub * subp + v * tilt) * pitch - c.center;
  a = std::fmod(a + std::ceil(std::abs(a)), 1.0);  // the shader's mod(a + ceil(|a|), 1)
  if (c.inv_view) a = 1 - a;
  const double z = a * views;
  *margin = std::min(z - std::floor(z), std::ceil(z) - z);
  return std::min(views - 1, static_cast<int>(std::floor(z)));
}

// A quilt whose view i is one constant colour that names it.
cv::Mat constant_quilt(const lf::Quilt& q, int tw, int th) {
  cv::Mat quilt(th * q.rows, tw * q.cols, CV_8UC4, cv::Scalar(0, 0, 0, 0));
  for (int i = 0; i < q.views; ++i)
    quilt(lf::quilt_tile(q, quilt.cols, quilt.rows, i))
        .setTo(cv::Scalar(i * 5 + 1, i * 5 + 2, i * 5 + 3, 255));
  return quilt;
}

}  // namespace

TEST(Lenticular, CalibrationIsReadAndCheckedByField) {
  const lf::DisplayCalibration c = lf::parse_display_calibration(kPortrait);
  EXPECT_DOUBLE_EQ(c.pitch, 52.58);
  EXPECT_DOUBLE_EQ(c.slope, -7.19);
  EXPECT_EQ(c.screen_w, 1536);
  EXPECT_EQ(c.screen_h, 2048);
  EXPECT_TRUE(c.inv_view);
  EXPECT_FALSE(c.flip_subp);
  // Plain numbers work too.
  const lf::DisplayCalibration p = lf::parse_display_calibration(
      R"({"pitch": 50, "slope": 5, "center": 0.1, "DPI": 338, "screenW": 2560, "screenH": 1600})");
  EXPECT_EQ(p.screen_w, 2560);
  EXPECT_FALSE(p.inv_view);
  auto message = [](const std::string& json) {
    try {
      lf::parse_display_calibration(json, "visual.json");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message(R"({"slope": 5, "center": 0, "DPI": 1, "screenW": 9, "screenH": 9})")
                .find("\"pitch\""),
            std::string::npos);
  EXPECT_NE(
      message(R"({"pitch": 5, "slope": 0, "center": 0, "DPI": 1, "screenW": 9, "screenH": 9})")
          .find("slope"),
      std::string::npos);
  EXPECT_NE(
      message(R"({"pitch": 5, "slope": 1, "center": 0, "DPI": 1, "screenW": 0, "screenH": 9})")
          .find("screenW"),
      std::string::npos);
  EXPECT_NE(
      message(R"({"pitch": "x", "slope": 1, "center": 0, "DPI": 1, "screenW": 9, "screenH": 9})")
          .find("not a number"),
      std::string::npos);
  EXPECT_NE(message("{pitch").find("not JSON"), std::string::npos);
  EXPECT_NE(message("[1, 2]").find("not a JSON object"), std::string::npos);
}

TEST(Lenticular, EverySubPixelShowsTheViewThePublishedFormulaGives) {
  lf::Quilt q;
  q.views = 48, q.cols = 8, q.rows = 6;
  const cv::Mat quilt = constant_quilt(q, 64, 48);
  for (int variant = 0; variant < 4; ++variant) {
    lf::DisplayCalibration c = lf::parse_display_calibration(kPortrait);
    c.inv_view = variant != 1;
    c.flip_subp = variant == 2;
    c.flip_image_x = variant == 3;
    cv::Mat panel;
    lf::interleave_quilt(c, q, quilt, panel);
    ASSERT_EQ(panel.cols, c.screen_w);
    ASSERT_EQ(panel.rows, c.screen_h);
    long checked = 0, boundary = 0, wrong = 0;
    std::vector<int> shown(q.views, 0);
    for (int y = 0; y < c.screen_h; ++y)
      for (int x = 0; x < c.screen_w; ++x)
        for (int ch = 0; ch < 3; ++ch) {
          double margin = 0;
          const int sub = c.flip_subp ? 2 - ch : ch;  // where this colour's sub-pixel is
          const int view = published_view(c, q.views, x, y, sub, &margin);
          const int got = (panel.ptr<uint8_t>(y)[4 * x + ch] - (ch + 1)) / 5;
          // Single precision (a ~ 250 lenticules, so ~3e-5 of rounding,
          // x 48 views) may round to the neighbour within 1 % of a view.
          if (margin < 1e-2) {
            boundary++;
            if (std::abs(got - view) != 1 && std::abs(got - view) != q.views - 1 && got != view)
              wrong++;
            continue;
          }
          checked++;
          shown[view]++;
          if (got != view) wrong++;
        }
    EXPECT_EQ(wrong, 0) << "variant " << variant;
    EXPECT_LT(boundary, checked / 20) << "variant " << variant;
    for (int i = 0; i < q.views; ++i) EXPECT_GT(shown[i], 0) << "view " << i << " never shown";
  }
}

TEST(Lenticular, EachViewIsSampledAtThePanelPositionInItsTile) {
  // One view only, a horizontal ramp: every panel pixel shows the ramp's
  // value at its own position (nearest tile pixel).
  lf::Quilt q;
  q.views = 2, q.cols = 2, q.rows = 1;
  cv::Mat quilt(100, 2 * 256, CV_8UC4);
  for (int y = 0; y < quilt.rows; ++y)
    for (int x = 0; x < quilt.cols; ++x) quilt.at<cv::Vec4b>(y, x) = cv::Vec4b(x % 256, y, 0, 255);
  lf::DisplayCalibration c = lf::parse_display_calibration(kPortrait);
  c.screen_w = 512, c.screen_h = 200;
  cv::Mat panel;
  lf::interleave_quilt(c, q, quilt, panel);
  for (int y = 0; y < panel.rows; y += 7)
    for (int x = 0; x < panel.cols; x += 5) {
      const cv::Vec4b px = panel.at<cv::Vec4b>(y, x);
      EXPECT_EQ(px[0], x / 2) << x << "," << y;
      EXPECT_EQ(px[1], y / 2) << x << "," << y;
      EXPECT_EQ(px[3], 255);
    }
  cv::Mat wrong(100, 511, CV_8UC4);  // not two whole tiles
  EXPECT_THROW(lf::interleave_quilt(c, q, wrong, panel), std::invalid_argument);
}
