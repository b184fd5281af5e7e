#include "lf/render/lenticular.h"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <sstream>
#include <stdexcept>

namespace lf {

namespace {

// A field as a number, from {"value": x} or x; `required` or NaN.
double field(const nlohmann::json& j, const char* name, bool required, const std::string& what) {
  if (!j.contains(name)) {
    if (required) throw std::invalid_argument(what + ": missing field \"" + name + "\"");
    return std::nan("");
  }
  const nlohmann::json& v =
      j[name].is_object() && j[name].contains("value") ? j[name]["value"] : j[name];
  if (!v.is_number())
    throw std::invalid_argument(what + ": field \"" + name + "\" is not a number");
  const double x = v.get<double>();
  if (!std::isfinite(x))
    throw std::invalid_argument(what + ": field \"" + name + "\" is not finite");
  return x;
}

bool flag(const nlohmann::json& j, const char* name, const std::string& what) {
  const double x = field(j, name, false, what);
  return !std::isnan(x) && x != 0;
}

}  // namespace

DisplayCalibration parse_display_calibration(const std::string& text, const std::string& what) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(what + ": not JSON (" + e.what() + ")");
  }
  if (!j.is_object()) throw std::invalid_argument(what + ": not a JSON object");
  DisplayCalibration c;
  c.pitch = field(j, "pitch", true, what);
  c.slope = field(j, "slope", true, what);
  c.center = field(j, "center", true, what);
  c.dpi = field(j, "DPI", true, what);
  const double w = field(j, "screenW", true, what), h = field(j, "screenH", true, what);
  if (!(c.pitch > 0)) throw std::invalid_argument(what + ": pitch must be > 0");
  if (!(c.dpi > 0)) throw std::invalid_argument(what + ": DPI must be > 0");
  if (c.slope == 0) throw std::invalid_argument(what + ": slope must not be 0");
  if (!(w >= 1 && w <= 16384 && h >= 1 && h <= 16384) || w != std::floor(w) || h != std::floor(h))
    throw std::invalid_argument(what + ": screenW and screenH must be whole numbers in 1..16384");
  c.screen_w = static_cast<int>(w), c.screen_h = static_cast<int>(h);
  c.inv_view = flag(j, "invView", what);
  c.flip_image_x = flag(j, "flipImageX", what);
  c.flip_subp = flag(j, "flipSubp", what);
  const double cone = field(j, "viewCone", false, what);
  if (!std::isnan(cone)) c.view_cone = cone;
  return c;
}

DisplayCalibration load_display_calibration(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("cannot read display calibration " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return parse_display_calibration(s.str(), path);
}

LenticularConstants lenticular_constants(const DisplayCalibration& c) {
  LenticularConstants k;
  k.pitch = static_cast<float>(c.pitch * c.screen_w / c.dpi * std::cos(std::atan(1.0 / c.slope)));
  k.tilt = static_cast<float>(static_cast<double>(c.screen_h) / (c.screen_w * c.slope));
  k.subp = static_cast<float>(1.0 / (3.0 * c.screen_w));
  k.center = static_cast<float>(c.center);
  return k;
}

int lenticular_view(const DisplayCalibration& cal, const LenticularConstants& k, int views, int x,
                    int y, int c) {
  float u = (static_cast<float>(x) + 0.5f) / static_cast<float>(cal.screen_w);
  if (cal.flip_image_x) u = 1.0f - u;
  const float v = 1.0f - (static_cast<float>(y) + 0.5f) / static_cast<float>(cal.screen_h);
  float a = (u + static_cast<float>(c) * k.subp + v * k.tilt) * k.pitch - k.center;
  a = a - std::floor(a);
  if (cal.inv_view) a = 1.0f - a;
  const int view = static_cast<int>(std::floor(a * static_cast<float>(views)));
  return view < 0 ? 0 : view >= views ? views - 1 : view;
}

void interleave_quilt(const DisplayCalibration& cal, const Quilt& layout, const cv::Mat& quilt,
                      cv::Mat& out) {
  if (quilt.type() != CV_8UC4 || quilt.empty())
    throw std::invalid_argument("interleave_quilt: the quilt must be RGBA (CV_8UC4)");
  validate_quilt(layout, quilt.cols, quilt.rows);
  out.create(cal.screen_h, cal.screen_w, CV_8UC4);
  const LenticularConstants k = lenticular_constants(cal);
  const int tw = quilt.cols / layout.cols, th = quilt.rows / layout.rows;
  cv::parallel_for_(cv::Range(0, cal.screen_h), [&](const cv::Range& r) {
    for (int y = r.start; y < r.end; ++y) {
      uint8_t* o = out.ptr<uint8_t>(y);
      const float v = 1.0f - (static_cast<float>(y) + 0.5f) / static_cast<float>(cal.screen_h);
      // The tile row's pixel: nearest sample, row 0 of a tile at its top.
      const int ty = std::min(th - 1, static_cast<int>(std::floor((1.0f - v) * th)));
      for (int x = 0; x < cal.screen_w; ++x) {
        float u = (static_cast<float>(x) + 0.5f) / static_cast<float>(cal.screen_w);
        if (cal.flip_image_x) u = 1.0f - u;
        const int tx = std::min(tw - 1, static_cast<int>(std::floor(u * tw)));
        for (int ch = 0; ch < 3; ++ch) {  // R, G, B: at sub-pixel ch, or 2 - ch (BGR)
          const int view = lenticular_view(cal, k, layout.views, x, y, cal.flip_subp ? 2 - ch : ch);
          const cv::Rect t = quilt_tile(layout, quilt.cols, quilt.rows, view);
          o[4 * x + ch] = quilt.ptr<uint8_t>(t.y + ty)[4 * (t.x + tx) + ch];
        }
        o[4 * x + 3] = 255;
      }
    }
  });
}

}  // namespace lf
