#include "calib/tracking.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <stdexcept>

namespace lf::calib {

Spot find_spot(const cv::Mat& frame, const SpotOptions& o) {
  Spot s;
  cv::Mat grey;
  if (frame.channels() == 1) {
    grey = frame;
  } else {  // the brightest channel: a coloured light counts fully
    std::vector<cv::Mat> ch;
    cv::split(frame, ch);
    grey = ch[0];
    for (int i = 1; i < std::min(3, frame.channels()); ++i) cv::max(grey, ch[i], grey);
  }
  if (grey.depth() != CV_8U) throw std::invalid_argument("find_spot: 8-bit frames only");
  double lo, hi;
  cv::minMaxLoc(grey, &lo, &hi);
  if (hi < o.min_peak) {
    s.why = "no spot (peak " + std::to_string(static_cast<int>(hi)) + ")";
    return s;
  }
  const double thr = o.threshold > 0 ? o.threshold : std::max(o.min_peak, 0.5 * hi);
  cv::Mat mask, labels, stats, centroids;
  cv::threshold(grey, mask, thr - 1, 255, cv::THRESH_BINARY);
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<int> blobs;
  for (int i = 1; i < n; ++i)
    if (stats.at<int>(i, cv::CC_STAT_AREA) >= o.min_area) blobs.push_back(i);
  if (blobs.empty()) {
    s.why = "no spot of " + std::to_string(o.min_area) + " pixels";
    return s;
  }
  if (blobs.size() > 1) {
    s.status = SpotStatus::kSeveral;
    s.why = std::to_string(blobs.size()) + " spots";
    return s;
  }
  const int b = blobs[0];
  s.area = stats.at<int>(b, cv::CC_STAT_AREA);
  const cv::Rect box(stats.at<int>(b, cv::CC_STAT_LEFT), stats.at<int>(b, cv::CC_STAT_TOP),
                     stats.at<int>(b, cv::CC_STAT_WIDTH), stats.at<int>(b, cv::CC_STAT_HEIGHT));
  if (s.area > o.max_area) {
    s.status = SpotStatus::kStreak;
    s.why = "spot of " + std::to_string(s.area) + " pixels (not a point)";
    return s;
  }
  // Shape: saturation and elongation of the thresholded blob.
  int saturated = 0;
  cv::Moments m = cv::moments(labels(box) == b, true);
  for (int y = box.y; y < box.y + box.height; ++y)
    for (int x = box.x; x < box.x + box.width; ++x)
      saturated += labels.at<int>(y, x) == b && grey.at<uint8_t>(y, x) >= o.saturated_level;
  const double a = m.mu20 / m.m00, c = m.mu02 / m.m00, d = m.mu11 / m.m00;
  const double root = std::sqrt(std::max(0.0, (a - c) * (a - c) + 4 * d * d));
  const double l1 = 0.5 * (a + c + root), l2 = 0.5 * (a + c - root);
  const double elong = std::sqrt(l1 / std::max(l2, 1e-3));
  if (saturated > o.max_saturated || (s.area >= 6 && elong > o.max_elongation)) {
    s.status = SpotStatus::kStreak;
    s.why = saturated > o.max_saturated
                ? std::to_string(saturated) + " saturated pixels (a saturated streak)"
                : "elongated spot (axis ratio " + std::to_string(elong) + ": motion streak)";
    return s;
  }
  // Intensity centroid over the box grown by 2 pixels, background removed.
  const cv::Rect roi =
      (box + cv::Size(4, 4) - cv::Point(2, 2)) & cv::Rect(0, 0, grey.cols, grey.rows);
  std::vector<uint8_t> border;
  for (int x = roi.x; x < roi.x + roi.width; ++x)
    border.push_back(grey.at<uint8_t>(roi.y, x)),
        border.push_back(grey.at<uint8_t>(roi.y + roi.height - 1, x));
  std::nth_element(border.begin(), border.begin() + border.size() / 2, border.end());
  const double bg = border[border.size() / 2];
  double sw = 0, sx = 0, sy = 0;
  for (int y = roi.y; y < roi.y + roi.height; ++y)
    for (int x = roi.x; x < roi.x + roi.width; ++x) {
      const double w = std::max(0.0, grey.at<uint8_t>(y, x) - bg);
      sw += w, sx += w * x, sy += w * y;
    }
  if (sw <= 0) {
    s.why = "flat spot";
    return s;
  }
  s.status = SpotStatus::kFound;
  s.centre = {sx / sw, sy / sw};
  return s;
}

namespace {

// Frames of one source, one at a time.
class FrameReader {
 public:
  explicit FrameReader(const std::string& src) : src_(src) {
    if (src.rfind("gst:", 0) == 0) {  // a live (or any) GStreamer source
      std::string desc = src.substr(4);
      if (desc.find("appsink") == std::string::npos)
        desc += " ! videoconvert ! video/x-raw,format=BGR ! appsink sync=false";
      if (!cap_.open(desc, cv::CAP_GSTREAMER))
        throw std::runtime_error("track: cannot start GStreamer source '" + desc + "'");
    } else if (std::filesystem::is_directory(src)) {
      for (const auto& e : std::filesystem::directory_iterator(src)) {
        const std::string ext = e.path().extension().string();
        if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff" ||
            ext == ".bmp" || ext == ".pgm")
          files_.push_back(e.path().string());
      }
      std::sort(files_.begin(), files_.end());
      if (files_.empty()) throw std::runtime_error("track: folder '" + src + "' has no images");
    } else if (!cap_.open(src)) {
      throw std::runtime_error("track: cannot open '" + src + "' (not a folder or a video)");
    }
  }
  bool next(cv::Mat& frame) {
    if (!files_.empty()) {
      if (i_ >= files_.size()) return false;
      frame = cv::imread(files_[i_++], cv::IMREAD_UNCHANGED);
      if (frame.empty()) throw std::runtime_error("track: cannot read '" + files_[i_ - 1] + "'");
      return true;
    }
    return cap_.read(frame);
  }

 private:
  std::string src_;
  std::vector<std::string> files_;
  size_t i_ = 0;
  cv::VideoCapture cap_;
};

}  // namespace

std::vector<PointObservation> track_point_light(const std::vector<std::string>& sources,
                                                std::vector<TrackStats>* stats,
                                                const SpotOptions& options,
                                                void (*progress)(int, int)) {
  std::vector<PointObservation> obs;
  std::vector<TrackStats> st(sources.size());
  for (size_t c = 0; c < sources.size(); ++c) {
    FrameReader reader(sources[c]);
    st[c].source = sources[c];
    cv::Mat frame;
    while (reader.next(frame)) {
      if (st[c].image_size.area() == 0) st[c].image_size = frame.size();
      if (frame.size() != st[c].image_size)
        throw std::runtime_error("track: '" + sources[c] + "': frame " +
                                 std::to_string(st[c].frames) + " changes size");
      if (frame.depth() == CV_16U) frame.convertTo(frame, CV_8U, 1.0 / 256);
      const Spot s = find_spot(frame, options);
      switch (s.status) {
        case SpotStatus::kFound:
          ++st[c].found;
          obs.push_back({static_cast<int>(c), st[c].frames, {s.centre.x, s.centre.y}});
          break;
        case SpotStatus::kNone:
          ++st[c].none;
          break;
        case SpotStatus::kSeveral:
          ++st[c].several;
          break;
        case SpotStatus::kStreak:
          ++st[c].streak;
          break;
      }
      ++st[c].frames;
    }
    if (progress) progress(static_cast<int>(c + 1), static_cast<int>(sources.size()));
  }
  if (stats) *stats = st;
  return obs;
}

cv::Mat render_point_light(const Camera& cam, const cv::Vec3d& light, double sigma_px, double peak,
                           double noise, uint64_t seed) {
  cv::Mat f(cam.height, cam.width, CV_32F, cv::Scalar(6));
  cv::RNG rng(seed);
  cv::Mat n(f.size(), CV_32F);
  rng.fill(n, cv::RNG::NORMAL, 0, noise);
  f += n;
  if (const auto p = cam.project(light)) {
    const int r = static_cast<int>(std::ceil(4 * sigma_px));
    const int x0 = static_cast<int>(std::lround((*p)[0])),
              y0 = static_cast<int>(std::lround((*p)[1]));
    for (int y = y0 - r; y <= y0 + r; ++y)
      for (int x = x0 - r; x <= x0 + r; ++x) {
        if (x < 0 || y < 0 || x >= cam.width || y >= cam.height) continue;
        const double dx = x - (*p)[0], dy = y - (*p)[1];
        f.at<float>(y, x) +=
            static_cast<float>(peak * std::exp(-(dx * dx + dy * dy) / (2 * sigma_px * sigma_px)));
      }
  }
  cv::Mat out;
  f.convertTo(out, CV_8U);
  return out;
}

}  // namespace lf::calib
