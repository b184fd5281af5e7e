// GStreamer elements: documentation (properties, pads), pipeline output vs
// the offline renderer, malformed input, a camera dying in a live pipeline.
#include <gst/app/gstappsink.h>
#include <gst/app/gstappsrc.h>
#include <gst/gst.h>
#include <gst/video/navigation.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>
#include <tuple>

#include "gst_init.h"
#include "helpers.h"
#include "lf/focus/focus.h"
#include "lf/geometry/rig_ops.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/datasets.h"
#include "lf/io/parse.h"
#include "lf/io/rig_file.h"
#include "lf/quality/quality.h"
#include "lf/quality/synthetic.h"
#include "lf/render/composite.h"
#include "lf/render/gl_render.h"
#include "lf/render/lenticular.h"
#include "lf/render/render.h"
#include "lf/render/render_view.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"

namespace {

// Waits up to 60 s for the end of a pipeline's stream on `bus`: EOS, with
// no error or warning before it.
void expect_eos(GstBus* bus) {
  GstMessage* m = gst_bus_timed_pop_filtered(
      bus, 60 * GST_SECOND,
      static_cast<GstMessageType>(GST_MESSAGE_EOS | GST_MESSAGE_ERROR | GST_MESSAGE_WARNING));
  ASSERT_NE(m, nullptr) << "no end in 60 s";
  EXPECT_EQ(GST_MESSAGE_TYPE(m), GST_MESSAGE_EOS)
      << (GST_MESSAGE_TYPE(m) == GST_MESSAGE_EOS
              ? ""
              : testing_lf::take_error_debug(gst_message_ref(m)));
  gst_message_unref(m);
}

// Counts the buffers reaching the sink pad of `bin`'s element `name` in
// *count (a pad probe, for as long as the element lives).
void count_buffers(GstBin* bin, const char* name, std::atomic<int>* count) {
  GstElement* e = gst_bin_get_by_name(bin, name);
  ASSERT_NE(e, nullptr) << name;
  GstPad* pad = gst_element_get_static_pad(e, "sink");
  gst_pad_add_probe(
      pad, GST_PAD_PROBE_TYPE_BUFFER,
      +[](GstPad*, GstPadProbeInfo*, gpointer c) {
        ++*static_cast<std::atomic<int>*>(c);
        return GST_PAD_PROBE_OK;
      },
      count, nullptr);
  gst_object_unref(pad);
  gst_object_unref(e);
}

using testing_lf::data_path;

class Gst : public ::testing::Test {
 protected:
  // Every test here renders the Chess cameras: skipped, by name, without them.
  void SetUp() override { LF_NEEDS_DATA("stanford-chess"); }
  static void SetUpTestSuite() {
    if (!testing_lf::have_data("stanford-chess")) return;
    testing_lf::init_gstreamer_with_plugin();
    // A 2x2 block of the real Chess light field at half resolution.
    rig_path_ = (std::filesystem::temp_directory_path() / "lf-test-chess4.json").string();
    lf::Rig rig = lf::scale_rig(
        lf::grid_block(lf::import_dataset(data_path("stanford-chess")), 3, 3, 2, 2), 0.5);
    lf::save_rig(rig, rig_path_);
  }
  static std::string rig_path_;

  // A pipeline with an appsrc "in" and an appsink "out", playing from its
  // construction to its end (pipe null: the description did not parse).
  struct AppPipeline {
    GstElement *pipe = nullptr, *in = nullptr, *out = nullptr;
    explicit AppPipeline(const std::string& desc) : pipe(gst_parse_launch(desc.c_str(), nullptr)) {
      if (!pipe) return;
      in = gst_bin_get_by_name(GST_BIN(pipe), "in");
      out = gst_bin_get_by_name(GST_BIN(pipe), "out");
      gst_element_set_state(pipe, GST_STATE_PLAYING);
    }
    ~AppPipeline() {
      if (!pipe) return;
      gst_element_set_state(pipe, GST_STATE_NULL);
      if (in) gst_object_unref(in);
      if (out) gst_object_unref(out);
      gst_object_unref(pipe);
    }
    AppPipeline(const AppPipeline&) = delete;
    AppPipeline& operator=(const AppPipeline&) = delete;
  };

  // One non-live camera (the rig's first, lfcamsrc "cam", mode=dataset)
  // answering `requests` requests of 160x120 views: lffragment "f" into
  // fakesink "out".
  static GstElement* one_camera_pipeline(int requests) {
    const std::string id = std::to_string(lf::load_rig(rig_path_).cameras[0].id);
    return gst_parse_launch(
        ("lfviewrequest rig=" + rig_path_ + " num-buffers=" + std::to_string(requests) +
         " width=160 height=120 focal-surface=false ! f.request lffragment name=f rig=" +
         rig_path_ + " camera-id=" + id + " ! fakesink name=out lfcamsrc name=cam rig=" +
         rig_path_ + " camera-id=" + id + " mode=dataset ! f.sink")
            .c_str(),
        nullptr);
  }

  // The test rig with every camera's colour correction halving red and
  // adding 10 to green (the rig's 3x4 `colour` matrix), saved as `name` in
  // the temporary folder; returns its path.
  static std::string colour_corrected_rig(const std::string& name) {
    lf::Rig rig = lf::load_rig(rig_path_);
    for (auto& c : rig.cameras) c.colour = {0.5, 0, 0, 0, 0, 1, 0, 10, 0, 0, 1, 0};
    const std::string path = (std::filesystem::temp_directory_path() / name).string();
    lf::save_rig(rig, path);
    return path;
  }

  // An lfarray of the test rig with `props` at READY (its graph built), in
  // *array, and its first camera's lffragment (both new references; null
  // where it failed). The caller sets *array to NULL and unrefs both.
  static GstElement* array_fragment(const std::string& props, GstElement** array) {
    *array = gst_parse_launch(("lfarray rig=" + rig_path_ + " " + props).c_str(), nullptr);
    if (!*array || gst_element_set_state(*array, GST_STATE_READY) == GST_STATE_CHANGE_FAILURE)
      return nullptr;
    const lf::Rig rig = lf::load_rig(rig_path_);
    return gst_bin_get_by_name(GST_BIN(*array),
                               ("fragment" + std::to_string(rig.cameras[0].id)).c_str());
  }

  // Builds lfviewrequest ! tee, per camera lfcamsrc -> lffragment, -> lfcompositor ! appsink.
  static std::string pipeline(const std::string& request_props,
                              const std::string& extra_fragment = "",
                              const std::string& comp_props = "", bool live = false) {
    const lf::Rig rig = lf::load_rig(rig_path_);
    // The paper's focal plane unless request_props says focal-surface=true:
    // these tests compare with renders through one plane.
    std::string d = "lfviewrequest name=req rig=" + rig_path_ + " focal-surface=false " +
                    request_props + (live ? " is-live=true" : "") +
                    " ! tee name=t lfcompositor name=comp rig=" + rig_path_ + " " + comp_props +
                    " ! video/x-raw,format=RGBA ! appsink name=out sync=false";
    for (size_t i = 0; i < rig.cameras.size(); ++i) {
      const std::string id = std::to_string(rig.cameras[i].id), n = std::to_string(i);
      d += " lfcamsrc rig=" + rig_path_ + " camera-id=" + id +
           (live ? " is-live=true framerate=30/1" : " num-buffers=1") + " ! f" + n + ".sink";
      d += " t. ! queue ! lffragment name=f" + n + " rig=" + rig_path_ + " camera-id=" + id + " " +
           extra_fragment + " ! " + (i == 0 ? "valve name=v0 ! " : "") + "comp.sink_" + n;
    }
    return d;
  }

  // Runs a pipeline to EOS (or `max_frames`), collecting RGBA frames.
  // An RGBA sample's picture (a copy); the sample is unreferenced.
  static cv::Mat rgba_of(GstSample* s) {
    GstStructure* st = gst_caps_get_structure(gst_sample_get_caps(s), 0);
    int w = 0, h = 0;
    gst_structure_get_int(st, "width", &w);
    gst_structure_get_int(st, "height", &h);
    GstMapInfo m;
    gst_buffer_map(gst_sample_get_buffer(s), &m, GST_MAP_READ);
    cv::Mat frame = cv::Mat(h, w, CV_8UC4, m.data).clone();
    gst_buffer_unmap(gst_sample_get_buffer(s), &m);
    gst_sample_unref(s);
    return frame;
  }

  static std::vector<cv::Mat> run(const std::string& desc, int max_frames = 1000,
                                  std::vector<std::string>* warnings = nullptr,
                                  std::string* error = nullptr) {
    GError* err = nullptr;
    GstElement* p = gst_parse_launch(desc.c_str(), &err);
    if (!p) {
      if (error) *error = err ? err->message : "parse failed";
      g_clear_error(&err);
      return {};
    }
    GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
    std::vector<cv::Mat> frames;
    gst_element_set_state(p, GST_STATE_PLAYING);
    GstBus* bus = gst_element_get_bus(p);
    bool done = false;
    while (!done && static_cast<int>(frames.size()) < max_frames) {
      GstSample* s =
          sink ? gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 20 * GST_MSECOND) : nullptr;
      if (!sink) g_usleep(20000);
      if (s) frames.push_back(rgba_of(s));
      while (GstMessage* msg = gst_bus_pop(bus)) {
        if (GST_MESSAGE_TYPE(msg) == GST_MESSAGE_EOS) done = true;
        if (GST_MESSAGE_TYPE(msg) == GST_MESSAGE_ERROR) {
          GError* e = nullptr;
          gst_message_parse_error(msg, &e, nullptr);
          if (error && error->empty()) *error = e->message;
          g_clear_error(&e);
          done = true;
        }
        if (GST_MESSAGE_TYPE(msg) == GST_MESSAGE_WARNING && warnings) {
          GError* e = nullptr;
          gchar* dbg = nullptr;
          gst_message_parse_warning(msg, &e, &dbg);
          warnings->push_back(std::string(e->message) + ": " + (dbg ? dbg : ""));
          g_clear_error(&e);
          g_free(dbg);
        }
        gst_message_unref(msg);
      }
      if (sink && gst_app_sink_is_eos(GST_APP_SINK(sink))) done = true;
    }
    gst_element_set_state(p, GST_STATE_NULL);
    gst_object_unref(bus);
    if (sink) gst_object_unref(sink);
    gst_object_unref(p);
    return frames;
  }
};
std::string Gst::rig_path_;

TEST_F(Gst, ElementsAreDocumented) {
  struct E {
    const char* name;
    std::vector<const char*> props;
    std::vector<const char*> pads;
  };
  for (const E& e : std::vector<E>{
           {"lfcamsrc",
            {"rig", "camera-id", "row", "col", "framerate", "phase", "is-live"},
            {"src"}},
           {"lffragment",
            {"rig", "camera-id", "encoding", "jpeg-quality"},
            {"sink", "request", "src"}},
           {"lfcompositor", {"rig", "viewer-id", "framerate", "latency"}, {"sink_%u", "src"}},
           {"lfpartialsum", {"encoding", "jpeg-quality", "latency"}, {"sink_%u", "src"}},
           {"lfrequestmux", {"forwarded", "dropped"}, {"sink_%u", "src"}},
           {"lfviewrequest",
            {"rig", "viewer-id", "width", "height", "position", "look-at", "vfov", "focal-plane",
             "path", "orbit", "dolly", "framerate", "is-live"},
            {"src"}}}) {
    GstElementFactory* f = gst_element_factory_find(e.name);
    ASSERT_NE(f, nullptr) << e.name;
    GstElement* el = gst_element_factory_create(f, nullptr);
    for (const char* p : e.props) {
      GParamSpec* ps = g_object_class_find_property(G_OBJECT_GET_CLASS(el), p);
      ASSERT_NE(ps, nullptr) << e.name << "." << p;
      EXPECT_GT(std::strlen(g_param_spec_get_blurb(ps)), 10u) << e.name << "." << p;
    }
    for (const char* pad : e.pads)
      EXPECT_NE(gst_element_class_get_pad_template(GST_ELEMENT_GET_CLASS(el), pad), nullptr)
          << e.name << " pad " << pad;
    EXPECT_NE(gst_element_factory_get_metadata(f, GST_ELEMENT_METADATA_DESCRIPTION), nullptr);
    gst_object_unref(el);
    gst_object_unref(f);
  }
}

TEST_F(Gst, PipelineOutputEqualsOfflineRenderer) {
  const lf::Rig rig = lf::load_rig(rig_path_);
  const auto images = lf::load_images(rig);  // BGRA; the elements use RGBA
  const cv::Vec3d c = rig.plane().origin;
  // `aperture`: lfviewrequest's, rig units (0: the tent); `sampling` its
  // sampling filter.
  auto check = [&](const std::string& focal, const cv::Vec3d& eye, double aperture,
                   lf::Sampling sampling = lf::Sampling::kBilinear, int ulr = 0) {
    char pos[192];
    std::snprintf(pos, sizeof pos,
                  "\"<%.17g,%.17g,%.17g>\" aperture=%.17g sampling=%s ulr-cameras=%d", eye[0],
                  eye[1], eye[2], aperture,
                  sampling == lf::Sampling::kBicubic ? "bicubic" : "bilinear", ulr);
    std::string err;
    const auto frames = run(pipeline(std::string("num-buffers=2 width=320 height=240 position=") +
                                     pos + " focal-plane=" + focal),
                            100, nullptr, &err);
    ASSERT_EQ(frames.size(), 2u) << err;
    lf::ViewRequest req;
    req.view = lf::view_between_cameras(rig, eye, 320, 240);
    req.focal_plane = lf::parse_focal_plane(focal, rig);
    req.aperture_scale = lf::aperture_scale_for(aperture, rig.typical_spacing());
    req.sampling = sampling;
    if (ulr > 0) req.aperture = lf::Aperture::kUlr, req.ulr_cameras = ulr;
    cv::Mat ref = lf::render_view(rig, images, req);
    cv::cvtColor(ref, ref, cv::COLOR_BGRA2RGBA);
    for (const cv::Mat& f : frames) {
      cv::Mat diff;
      cv::absdiff(f, ref, diff);
      const cv::Scalar mad = cv::mean(diff);
      EXPECT_LE((mad[0] + mad[1] + mad[2]) / 3, 1.0) << focal;
      EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0)
          << "expected bit-identical output (" << focal << ", aperture " << aperture << ")";
    }
  };
  for (const std::string focal : {"param:-0.2", "infinity"})
    for (const cv::Vec3d& eye : {c + cv::Vec3d(1.5, -2.0, 0), c + cv::Vec3d(-2.0, 1.0, 6.0)})
      check(focal, eye, 0);
  // A wider aperture (2.5 tents; a multiple of 1/256, as the wire carries it).
  check("param:-0.2", c + cv::Vec3d(1.5, -2.0, 0),
        lf::aperture_diameter(2.5, rig.typical_spacing()));
  check("param:-0.2", c + cv::Vec3d(-2.0, 1.0, 6.0), 0, lf::Sampling::kBicubic);
  check("param:-0.2", c + cv::Vec3d(1.5, -2.0, 0), 0, lf::Sampling::kBilinear, 4);  // ULR
}

TEST_F(Gst, ColourCorrectionFromTheRigIsApplied) {
  const std::string corrected = colour_corrected_rig("lf-test-chess4-colour.json");
  std::string desc = pipeline("num-buffers=1 width=160 height=120 focal-plane=param:-0.2");
  const auto plain = run(desc);
  for (size_t at = desc.find(rig_path_); at != std::string::npos; at = desc.find(rig_path_, at))
    desc.replace(at, rig_path_.size(), corrected);
  const auto fixed = run(desc);
  ASSERT_EQ(plain.size(), 1u);
  ASSERT_EQ(fixed.size(), 1u);
  std::vector<cv::Mat> a, b;
  cv::split(plain[0], a);
  cv::split(fixed[0], b);
  cv::Mat half, diff;
  a[0].convertTo(half, CV_32F, 0.5);
  b[0].convertTo(diff, CV_32F);
  // Red halved: rounded to 8 bits before warping, then blended: <= 2 LSB.
  EXPECT_LE(cv::norm(diff - half, cv::NORM_INF), 2.0);
  EXPECT_LT(cv::mean(cv::abs(diff - half))[0], 0.5);
  a[1].convertTo(half, CV_32F);
  b[1].convertTo(diff, CV_32F);
  EXPECT_NEAR(cv::mean(diff - half)[0], 10.0, 0.3);  // green + 10 (saturating)
}

// `stereo` changed while playing: the compositor composites the pair from
// the next requests on, twice as wide (the output renegotiated).
TEST_F(Gst, StereoSwitchedOnWhilePlayingWidensTheOutput) {
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(
      pipeline("num-buffers=60 width=160 height=120 stereo-baseline=2", "", "viewer-id=0").c_str(),
      &err);
  ASSERT_NE(p, nullptr) << (err ? err->message : "");
  GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
  GstElement* comp = gst_bin_get_by_name(GST_BIN(p), "comp");
  gst_element_set_state(p, GST_STATE_PLAYING);
  std::vector<int> widths;
  while (GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 10 * GST_SECOND)) {
    int w = 0;
    gst_structure_get_int(gst_caps_get_structure(gst_sample_get_caps(s), 0), "width", &w);
    widths.push_back(w);
    gst_sample_unref(s);
    if (widths.size() == 5) g_object_set(comp, "stereo", TRUE, nullptr);
    if (widths.size() > 5 && w == 320) break;
  }
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(comp);
  gst_object_unref(sink);
  gst_object_unref(p);
  ASSERT_GE(widths.size(), 6u);
  EXPECT_EQ(widths.front(), 160);
  EXPECT_EQ(widths.back(), 320) << "still " << widths.back() << " wide after " << widths.size()
                                << " frames";
}

TEST_F(Gst, StereoPairIsSideBySide) {
  const lf::Rig rig = lf::load_rig(rig_path_);
  const cv::Vec3d eye = rig.plane().origin + cv::Vec3d(0.5, -1.0, 0);
  char pos[128];
  std::snprintf(pos, sizeof pos, "\"<%.17g,%.17g,%.17g>\"", eye[0], eye[1], eye[2]);
  std::string desc = pipeline(std::string("num-buffers=2 width=160 height=120 stereo-baseline=2 "
                                          "focal-plane=param:-0.2 position=") +
                                  pos,
                              "", "stereo=true viewer-id=0");
  const auto frames = run(desc);
  ASSERT_EQ(frames.size(), 2u);
  ASSERT_EQ(frames[0].cols, 320);
  // Each half equals the offline render from that eye (1 unit left/right
  // along the view's x axis).
  const auto images = lf::load_images(rig);
  for (int side = 0; side < 2; ++side) {
    lf::ViewRequest req;
    req.view = lf::view_between_cameras(rig, eye, 160, 120);
    const cv::Vec3d x(req.view.R(0, 0), req.view.R(0, 1), req.view.R(0, 2));
    req.view.position += x * (side == 0 ? -1.0 : 1.0);
    req.focal_plane = lf::parse_focal_plane("param:-0.2", rig);
    cv::Mat ref = lf::render_view(rig, images, req);
    cv::cvtColor(ref, ref, cv::COLOR_BGRA2RGBA);
    cv::Mat diff;
    cv::absdiff(frames[1].colRange(160 * side, 160 * side + 160), ref, diff);
    EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0) << "side " << side;
  }
  // The two eyes differ (parallax).
  cv::Mat d;
  cv::absdiff(frames[0].colRange(0, 160), frames[0].colRange(160, 320), d);
  EXPECT_GT(cv::mean(d)[0], 1.0);
}

// The quilt of the quilt tests: 6 eyes in 3 x 2 tiles of 96 x 72 around
// `eye`, focused on a plane in the scene.
static std::string quilt_test_view(const cv::Vec3d& eye) {
  char pos[128];
  std::snprintf(pos, sizeof pos, "\"<%.17g,%.17g,%.17g>\"", eye[0], eye[1], eye[2]);
  return std::string(
             "num-buffers=2 width=288 height=144 quilt-views=6 quilt-columns=3 quilt-rows=2 "
             "quilt-baseline=3 focal-plane=param:-0.2 position=") +
         pos;
}

// A display calibration (the shape of a small panel's visual.json) in a
// temporary file; its path.
static std::string write_test_calibration() {
  const std::string path =
      (std::filesystem::temp_directory_path() / "lf-test-lenticular.json").string();
  std::ofstream(path) << R"({"pitch": {"value": 49.96}, "slope": {"value": 5.5025},
      "center": {"value": 0.1435}, "DPI": {"value": 355}, "screenW": {"value": 320},
      "screenH": {"value": 200}, "invView": {"value": 1}})";
  return path;
}

TEST_F(Gst, QuiltTilesAreTheEyesRenderedDirectly) {
  // 6 eyes in 3 x 2 tiles of 96 x 72, one request round a frame: each tile
  // equals the offline render of its eye (lf::quilt_eye), so each view's
  // placement (from the bottom-left), order and parallax are the eyes'
  // (test_quilt checks the eyes' geometry); through separate elements and
  // lfarray (CPU and JPEG fragments). The GL backend: the next test.
  const lf::Rig rig = lf::load_rig(rig_path_);
  const auto images = lf::load_images(rig);
  const cv::Vec3d eye = rig.plane().origin + cv::Vec3d(0.5, -1.0, 0);
  const std::string view = quilt_test_view(eye);
  std::string err;
  const auto frames = run(pipeline(view), 100, nullptr, &err);
  ASSERT_EQ(frames.size(), 2u) << err;
  ASSERT_EQ(frames[0].cols, 288);
  ASSERT_EQ(frames[0].rows, 144);
  lf::ViewRequest req;
  req.view = lf::view_between_cameras(rig, eye, 96, 72);
  req.focal_plane = lf::parse_focal_plane("param:-0.2", rig);
  req.view.width = 288, req.view.height = 144;
  req.quilt.views = 6, req.quilt.cols = 3, req.quilt.rows = 2, req.quilt.baseline = 3;
  std::vector<cv::Mat> refs;
  for (int i = 0; i < 6; ++i) {
    cv::Mat ref = lf::render_view(rig, images, lf::quilt_eye(req, i));
    cv::cvtColor(ref, ref, cv::COLOR_BGRA2RGBA);
    refs.push_back(ref);
  }
  auto tile = [&](const cv::Mat& f, int i) { return f(lf::quilt_tile(req.quilt, 288, 144, i)); };
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(cv::norm(tile(frames[1], i), refs[i], cv::NORM_INF), 0) << "eye " << i;
    EXPECT_GT(cv::countNonZero(refs[i].reshape(1)), static_cast<int>(refs[i].total())) << i;
    // Neighbouring eyes differ (the parallax is there to see).
    if (i > 0) {
      EXPECT_GT(cv::norm(refs[i], refs[i - 1], cv::NORM_L1) / refs[i].total(), 1.0) << i;
    }
  }
  EXPECT_EQ(lf::quilt_tile(req.quilt, 288, 144, 0), cv::Rect(0, 72, 96, 72));  // bottom-left
  const std::string out = " ! video/x-raw,format=RGBA ! appsink name=out sync=false";
  const std::string request = "lfviewrequest rig=" + rig_path_ + " " + view;
  const auto array =
      run(request + " ! lfarray rig=" + rig_path_ + " num-buffers=1" + out, 100, nullptr, &err);
  ASSERT_EQ(array.size(), 2u) << err;
  EXPECT_EQ(cv::norm(array[1], frames[1], cv::NORM_INF), 0);
  const auto jpeg =
      run(request + " ! lfarray rig=" + rig_path_ + " num-buffers=1 encoding=jpeg" + out, 100,
          nullptr, &err);
  ASSERT_EQ(jpeg.size(), 2u) << err;
  EXPECT_GT(cv::PSNR(jpeg[1], frames[1]), 30.0);  // quality 90 on 96 x 72 tiles: 34.7 dB
  // lflenticular: the panel is the CPU interleave of the quilt.
  const std::string cal_path = write_test_calibration();
  const lf::DisplayCalibration cal = lf::load_display_calibration(cal_path);
  cv::Mat expected;
  lf::interleave_quilt(cal, req.quilt, array[1], expected);
  const auto panel = run(request + " ! lfarray rig=" + rig_path_ +
                             " num-buffers=1 ! lflenticular calibration=" + cal_path +
                             " quilt-columns=3 quilt-rows=2 backend=cpu" + out,
                         100, nullptr, &err);
  ASSERT_EQ(panel.size(), 2u) << err;
  ASSERT_EQ(panel[1].cols, 320);
  ASSERT_EQ(panel[1].rows, 200);
  EXPECT_EQ(cv::norm(panel[1], expected, cv::NORM_INF), 0);
  // Its errors: a quilt of another layout, a calibration that is not there.
  err.clear();
  run(request + " ! lfarray rig=" + rig_path_ + " num-buffers=1 ! lflenticular calibration=" +
          cal_path + " quilt-columns=5 quilt-rows=2" + out,
      10, nullptr, &err);
  EXPECT_NE(err.find("not a quilt of this layout"), std::string::npos) << err;
  err.clear();
  run("videotestsrc num-buffers=1 ! video/x-raw,format=RGBA ! lflenticular "
      "calibration=/nonexistent/visual.json ! fakesink",
      10, nullptr, &err);
  EXPECT_NE(err.find("Cannot use the display calibration"), std::string::npos) << err;
  // A layout that does not fit the frame is an error at start.
  err.clear();
  run("lfviewrequest rig=" + rig_path_ +
          " num-buffers=1 width=290 height=144 quilt-views=6 quilt-columns=3 quilt-rows=2 ! "
          "fakesink",
      10, nullptr, &err);
  EXPECT_NE(err.find("Invalid view request settings"), std::string::npos) << err;
}

// The quilt and its interleave on the GL backend (llvmpipe in CI) are the
// CPU's, byte for byte. Apart from the test above so that the sanitizer run
// leaves it out with the other GlBackend tests (scripts/test-san.sh: under
// ASan's full malloc stacks llvmpipe's JIT deadlocks in libgcc's unwinder).
TEST_F(Gst, GlBackendQuiltAndInterleaveEqualTheCpus) {
  ASSERT_TRUE(lf::gl_info().available) << lf::gl_info().error;
  const lf::Rig rig = lf::load_rig(rig_path_);
  const std::string view = quilt_test_view(rig.plane().origin + cv::Vec3d(0.5, -1.0, 0));
  std::string err;
  const auto cpu = run(pipeline(view), 100, nullptr, &err);
  ASSERT_EQ(cpu.size(), 2u) << err;
  const auto gl = run(pipeline(view, "backend=gl"), 100, nullptr, &err);
  ASSERT_EQ(gl.size(), 2u) << err;
  EXPECT_EQ(cv::norm(gl[1], cpu[1], cv::NORM_INF), 0);
  const std::string cal_path = write_test_calibration();
  const std::string out = " ! video/x-raw,format=RGBA ! appsink name=out sync=false";
  std::vector<cv::Mat> panels;
  for (const char* backend : {"cpu", "gl"}) {
    const auto panel =
        run("lfviewrequest rig=" + rig_path_ + " " + view + " ! lfarray rig=" + rig_path_ +
                " num-buffers=1 ! lflenticular calibration=" + cal_path +
                " quilt-columns=3 quilt-rows=2 backend=" + backend + out,
            100, nullptr, &err);
    ASSERT_EQ(panel.size(), 2u) << backend << ": " << err;
    panels.push_back(panel[1]);
  }
  EXPECT_EQ(cv::norm(panels[0], panels[1], cv::NORM_INF), 0);
}

TEST_F(Gst, NavigationEventsSteerTheViewOnce) {
  // Events sent from the sink travel upstream through the compositor and
  // every camera branch; lfviewrequest applies each one once.
  const lf::Rig rig = lf::load_rig(rig_path_);
  const std::string desc =
      pipeline("width=160 height=120 focal-plane=infinity framerate=30/1", "", "", true);
  GstElement* p = gst_parse_launch(desc.c_str(), nullptr);
  ASSERT_NE(p, nullptr);
  GstElement* req = gst_bin_get_by_name(GST_BIN(p), "req");
  GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
  struct Seen {
    std::mutex m;
    std::vector<lf::ViewRequest> reqs;
  } seen;
  GstPad* rp = gst_element_get_static_pad(req, "src");
  testing_lf::on_each_buffer(rp, [&seen](const guint8* data, gsize size) {
    std::lock_guard<std::mutex> l(seen.m);
    for (const lf::ViewRequest& r : lf::parse_requests(data, size)) seen.reqs.push_back(r);
  });
  gst_object_unref(rp);
  gst_element_set_state(p, GST_STATE_PLAYING);
  auto pull = [&](int n) {
    for (int k = 0; k < n; ++k)
      if (GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), GST_SECOND))
        gst_sample_unref(s);
  };
  pull(3);
  auto last = [&] {
    std::lock_guard<std::mutex> l(seen.m);
    return seen.reqs.back();
  };
  const lf::ViewRequest before = last();
  gst_element_send_event(
      sink, gst_navigation_event_new_mouse_scroll(80, 60, 0, 1, GST_NAVIGATION_MODIFIER_NONE));
  gst_element_send_event(
      sink, gst_navigation_event_new_mouse_button_press(1, 80, 60, GST_NAVIGATION_MODIFIER_NONE));
  gst_element_send_event(sink,
                         gst_navigation_event_new_mouse_move(90, 60, GST_NAVIGATION_MODIFIER_NONE));
  gst_element_send_event(
      sink, gst_navigation_event_new_mouse_button_release(1, 90, 60, GST_NAVIGATION_MODIFIER_NONE));
  pull(4);
  const lf::ViewRequest after = last();
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(req);
  gst_object_unref(sink);
  gst_object_unref(p);
  // One wheel notch: inverse depth 0 -> 0.25 / (f * spacing), once (not once
  // per camera branch).
  EXPECT_TRUE(before.focal_plane.at_infinity());
  const double q = after.focal_plane.n.dot(rig.plane().normal);
  const double step = 0.25 / (rig.cameras[0].intrinsics.fx * rig.typical_spacing());
  EXPECT_NEAR(q, step, 1e-6 * step);
  // Drag 10 px right: the eye moves 10/40 spacing against the drag along u.
  const cv::Vec3d moved = after.view.position - before.view.position;
  EXPECT_NEAR(moved.dot(rig.plane().u), -0.25 * rig.typical_spacing(),
              1e-6 * rig.typical_spacing());
  EXPECT_NEAR(moved.dot(rig.plane().v), 0.0, 1e-9);
}

TEST_F(Gst, SyntheticCameraRendersTheSceneAtCaptureTime) {
  const lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.05, 96, 72, 40);
  const std::string path =
      (std::filesystem::temp_directory_path() / "lf-test-synthetic.json").string();
  lf::save_rig(rig, path);
  const auto frames = run("lfcamsrc rig=" + path +
                          " camera-id=4 mode=synthetic framerate=10/1 num-buffers=6 ! appsink "
                          "name=out sync=false");
  ASSERT_EQ(frames.size(), 6u);
  const lf::SyntheticScene scene = lf::SyntheticScene::for_rig(rig);
  for (int k : {0, 5}) {
    cv::Mat diff;
    cv::absdiff(frames[k], scene.render(rig.cameras[4], k / 10.0), diff);
    EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0) << "frame " << k;
  }
  cv::Mat d;
  cv::absdiff(frames[0], frames[5], d);
  EXPECT_GT(cv::mean(d)[0], 2.0) << "the disc moves";
  // Ground truth: the disc sits at near_depth, the background at far_depth.
  EXPECT_NEAR(scene.near_depth, 25 * 0.05, 1e-12);
  EXPECT_NEAR(scene.far_depth, 60 * 0.05, 1e-12);
}

// lfcamsrc mode=dataset keeps its decoded still in `still-cache` (one file
// per camera and size): a second start reads it from there (its debug log
// says so), and the frames equal those decoded without a cache.
TEST_F(Gst, DatasetStillsAreCachedAndReadBackIdentically) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("lf-test-still-cache-gst-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const lf::Rig rig = lf::load_rig(rig_path_);
  const std::string id = std::to_string(rig.cameras[1].id);
  auto frames = [&](const std::string& cache) {
    return run("lfcamsrc rig=" + rig_path_ + " camera-id=" + id + " num-buffers=2 still-cache=\"" +
               cache + "\" ! appsink name=out sync=false");
  };
  // The camera source's debug messages, to see where the still came from.
  static std::mutex mu;
  static std::vector<std::string> said;
  gst_debug_set_threshold_for_name("lfcamsrc", GST_LEVEL_DEBUG);
  const GstLogFunction log = [](GstDebugCategory* cat, GstDebugLevel, const gchar*, const gchar*,
                                gint, GObject*, GstDebugMessage* m, gpointer) {
    if (std::string(gst_debug_category_get_name(cat)) != "lfcamsrc") return;
    const std::lock_guard<std::mutex> l(mu);
    said.emplace_back(gst_debug_message_get(m));
  };
  gst_debug_add_log_function(log, nullptr, nullptr);
  auto where = [&] {
    const std::lock_guard<std::mutex> l(mu);
    std::string w;
    for (const auto& m : said)
      if (m.find("still of camera") != std::string::npos) w += m + ";";
    said.clear();
    return w;
  };
  const auto plain = frames("");
  EXPECT_NE(where().find("decoded"), std::string::npos);
  const auto first = frames(dir.string());
  EXPECT_NE(where().find("decoded"), std::string::npos);
  const auto second = frames(dir.string());
  EXPECT_NE(where().find("read from the cache"), std::string::npos);
  gst_debug_remove_log_function(log);
  gst_debug_unset_threshold_for_name("lfcamsrc");
  int stills = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    stills += e.path().extension() == ".still";
  EXPECT_EQ(stills, 1);
  ASSERT_EQ(plain.size(), 2u);
  ASSERT_EQ(first.size(), 2u);
  ASSERT_EQ(second.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(cv::norm(plain[k], first[k], cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(plain[k], second[k], cv::NORM_INF), 0);
  }
  std::filesystem::remove_all(dir);
}

// lfcamsrc noise=S: the frames differ from the noise-free ones by Gaussian
// noise of standard deviation S on the colour channels (alpha untouched),
// fresh in every frame and the same in every run.
TEST_F(Gst, SensorNoiseIsGaussianFreshPerFrameAndReproducible) {
  const lf::Rig rig = lf::synthetic_grid_rig(2, 2, 0.05, 160, 120, 40);
  const std::string path = (std::filesystem::temp_directory_path() / "lf-test-noise.json").string();
  lf::save_rig(rig, path);
  auto frames = [&](double noise) {
    return run("lfcamsrc rig=" + path + " camera-id=1 mode=synthetic framerate=10/1 noise=" +
               std::to_string(noise) + " num-buffers=2 ! appsink name=out sync=false");
  };
  const auto clean = frames(0), noisy = frames(6), again = frames(6);
  ASSERT_EQ(clean.size(), 2u);
  ASSERT_EQ(noisy.size(), 2u);
  ASSERT_EQ(again.size(), 2u);
  std::vector<cv::Mat> d(2);
  for (int k = 0; k < 2; ++k) {
    noisy[k].convertTo(d[k], CV_64FC4);
    cv::Mat c;
    clean[k].convertTo(c, CV_64FC4);
    d[k] -= c;
    cv::Scalar mean, sd;
    cv::meanStdDev(d[k], mean, sd);
    for (int ch = 0; ch < 3; ++ch) {
      // 19200 samples: the standard deviation within 5 % (its standard error
      // is 0.5 %, clipping at 0 and 255 aside), the mean within 0.3 levels.
      EXPECT_NEAR(sd[ch], 6.0, 0.3) << "frame " << k << " channel " << ch;
      EXPECT_NEAR(mean[ch], 0.0, 0.3) << "frame " << k << " channel " << ch;
    }
    EXPECT_EQ(sd[3], 0.0) << "alpha untouched";
    cv::Mat same;
    cv::absdiff(noisy[k], again[k], same);
    EXPECT_EQ(cv::countNonZero(same.reshape(1)), 0) << "the same frame in every run";
  }
  // Fresh noise per frame: the two frames' noise is uncorrelated.
  const double corr = d[0].dot(d[1]) / std::sqrt(d[0].dot(d[0]) * d[1].dot(d[1]));
  EXPECT_LT(std::abs(corr), 0.05);
}

TEST_F(Gst, CameraFromImageSequenceAndVideoFile) {
  const lf::Rig rig = lf::synthetic_grid_rig(2, 2, 0.05, 96, 72, 40);
  const auto dir = std::filesystem::temp_directory_path() / "lf-test-seq";
  std::filesystem::create_directories(dir);
  const std::string rig_file = (dir / "rig.json").string();
  lf::save_rig(rig, rig_file);
  const lf::SyntheticScene scene = lf::SyntheticScene::for_rig(rig);
  std::vector<cv::Mat> truth;
  for (int k = 0; k < 3; ++k) {
    truth.push_back(scene.render(rig.cameras[1], 0.3 * k));  // RGBA
    cv::Mat bgr;
    cv::cvtColor(truth.back(), bgr, cv::COLOR_RGBA2BGR);
    char name[32];
    std::snprintf(name, sizeof name, "%03d.png", k);
    ASSERT_TRUE(cv::imwrite((dir / name).string(), bgr));
  }
  // Image sequence, in order, exactly.
  std::string err;
  const auto frames = run("lfcamsrc rig=" + rig_file + " camera-id=1 mode=file location=" +
                              (dir / "%03d.png").string() + " ! appsink name=out sync=false",
                          100, nullptr, &err);
  ASSERT_EQ(frames.size(), 3u) << err;
  for (int k = 0; k < 3; ++k) {
    cv::Mat diff;
    cv::absdiff(frames[k], truth[k], diff);
    EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0) << "frame " << k;
  }
  // A video file (Motion JPEG AVI made by GStreamer), scaled to the rig's
  // size; ends with the file, or loops.
  const std::string avi = (dir / "clip.avi").string();
  run("videotestsrc num-buffers=10 ! video/x-raw,width=160,height=120 ! jpegenc ! avimux ! "
      "filesink location=" +
      avi);
  ASSERT_TRUE(std::filesystem::exists(avi));
  const auto clip = run("lfcamsrc rig=" + rig_file + " camera-id=0 mode=file location=" + avi +
                        " ! appsink name=out sync=false");
  ASSERT_EQ(clip.size(), 10u);
  EXPECT_EQ(clip[0].cols, 96);
  EXPECT_EQ(clip[0].rows, 72);
  const auto looped =
      run("lfcamsrc rig=" + rig_file + " camera-id=0 mode=file loop=true location=" + avi +
          " num-buffers=15 ! appsink name=out sync=false");
  EXPECT_EQ(looped.size(), 15u);
  // A missing file is a clear error.
  err.clear();
  run("lfcamsrc rig=" + rig_file + " camera-id=0 mode=file location=/nonexistent.avi ! fakesink",
      10, nullptr, &err);
  EXPECT_FALSE(err.empty());
  std::filesystem::remove_all(dir);
}

// Partial sums (lfpartialsum, lfcamerahost partial-sums): a host's cameras
// added up before they leave give the frames of their separate fragments:
// in lfarray, and from two camera hosts of two cameras each into one
// compositor, which counts a sum's cameras towards a complete request.
TEST_F(Gst, PartialSumsGiveTheFramesOfTheCameras) {
  const std::string req = "lfviewrequest rig=" + rig_path_ +
                          " num-buffers=3 width=320 height=240 focal-plane=param:-0.2 orbit=0.5 "
                          "focal-surface=false";
  const std::string out = " ! video/x-raw,format=RGBA ! appsink name=out sync=false";
  auto array = [&](const std::string& props) {
    std::string err;
    const auto frames = run(req + " ! lfarray rig=" + rig_path_ + " num-buffers=1 " + props + out,
                            100, nullptr, &err);
    EXPECT_EQ(frames.size(), 3u) << err;
    return frames;
  };
  const auto want = array("");
  const auto summed = array("partial-sums=true");
  const auto jpeg = array("partial-sums=true encoding=jpeg jpeg-quality=90");
  std::string err;
  const auto hosts = run(req + " ! tee name=t lfcompositor name=c rig=" + rig_path_ + out +
                             " t. ! queue ! lfcamerahost rig=" + rig_path_ +
                             " cameras=0-1 num-buffers=1 partial-sums=true ! c.sink_0"
                             " t. ! queue ! lfcamerahost rig=" +
                             rig_path_ + " cameras=2-3 num-buffers=1 partial-sums=true ! c.sink_1",
                         100, nullptr, &err);
  ASSERT_EQ(hosts.size(), 3u) << err;
  // A host sends one buffer per request: the sum.
  for (const bool sums : {false, true}) {
    GstElement* p = gst_parse_launch(
        (req + " ! lfcamerahost rig=" + rig_path_ + " cameras=0-1 num-buffers=1 partial-sums=" +
         (sums ? "true" : "false") + " ! appsink name=out sync=false")
            .c_str(),
        nullptr);
    ASSERT_NE(p, nullptr);
    GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
    gst_element_set_state(p, GST_STATE_PLAYING);
    size_t buffers = 0;
    while (GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 10 * GST_SECOND)) {
      ++buffers;
      gst_sample_unref(s);
    }
    gst_element_set_state(p, GST_STATE_NULL);
    gst_object_unref(sink);
    gst_object_unref(p);
    EXPECT_EQ(buffers, sums ? 3u : 6u);
  }
  ASSERT_EQ(want.size(), 3u);
  ASSERT_EQ(summed.size(), 3u);
  ASSERT_EQ(jpeg.size(), 3u);
  for (size_t i = 0; i < want.size(); ++i) {
    // Sums over 255 only by the cameras' rounding are scaled at that pixel:
    // a level at most there.
    EXPECT_LE(cv::norm(summed[i], want[i], cv::NORM_INF), 1) << "frame " << i;
    EXPECT_LT(cv::norm(summed[i], want[i], cv::NORM_L1) / want[i].total(), 0.01) << "frame " << i;
    EXPECT_LE(cv::norm(hosts[i], want[i], cv::NORM_INF), 1) << "frame " << i;
    cv::Mat a, b;
    cv::cvtColor(want[i], a, cv::COLOR_RGBA2RGB);
    cv::cvtColor(jpeg[i], b, cv::COLOR_RGBA2RGB);
    EXPECT_GT(cv::PSNR(a, b), 36.0) << "frame " << i;
  }
}

// A camera host's fragment stream carries its caps once: its cameras share
// one caps event, so the funnel joining them, which forwards a camera's
// sticky events whenever it switches cameras, sends nothing new (with a
// caps event per camera, caps went down with most fragments and each made
// a payloader such as rtpgstpay negotiate again). Two view sizes, each
// once.
TEST_F(Gst, CameraHostSendsItsCapsOnce) {
  struct Count {
    std::atomic<int> caps{0}, buffers{0};
  } count;
  for (const char* size : {"width=320 height=240", "width=160 height=120"}) {
    count.caps = 0, count.buffers = 0;
    GstElement* p = gst_parse_launch(
        ("lfviewrequest rig=" + rig_path_ + " num-buffers=12 " + size +
         " focal-plane=param:-0.2 orbit=0.5 focal-surface=false ! lfcamerahost rig=" + rig_path_ +
         " cameras=0-3 num-buffers=1 ! fakesink name=out sync=false")
            .c_str(),
        nullptr);
    ASSERT_NE(p, nullptr);
    GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
    GstPad* pad = gst_element_get_static_pad(sink, "sink");
    gst_pad_add_probe(
        pad,
        static_cast<GstPadProbeType>(GST_PAD_PROBE_TYPE_BUFFER |
                                     GST_PAD_PROBE_TYPE_EVENT_DOWNSTREAM),
        [](GstPad*, GstPadProbeInfo* info, gpointer data) {
          auto* c = static_cast<Count*>(data);
          if (info->type & GST_PAD_PROBE_TYPE_BUFFER) ++c->buffers;
          if ((info->type & GST_PAD_PROBE_TYPE_EVENT_DOWNSTREAM) &&
              GST_EVENT_TYPE(GST_PAD_PROBE_INFO_EVENT(info)) == GST_EVENT_CAPS)
            ++c->caps;
          return GST_PAD_PROBE_OK;
        },
        &count, nullptr);
    gst_element_set_state(p, GST_STATE_PLAYING);
    GstBus* bus = gst_element_get_bus(p);
    GstMessage* m = gst_bus_timed_pop_filtered(
        bus, 30 * GST_SECOND, static_cast<GstMessageType>(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
    ASSERT_NE(m, nullptr);
    EXPECT_EQ(GST_MESSAGE_TYPE(m), GST_MESSAGE_EOS);
    gst_message_unref(m);
    gst_object_unref(bus);
    gst_element_set_state(p, GST_STATE_NULL);
    gst_object_unref(pad);
    gst_object_unref(sink);
    gst_object_unref(p);
    EXPECT_EQ(count.buffers.load(), 48) << size;  // 12 requests x 4 cameras
    EXPECT_EQ(count.caps.load(), 1) << size;
  }
}

TEST_F(Gst, JpegFragmentsStayClose) {
  const auto raw = run(pipeline("num-buffers=1 width=320 height=240 focal-plane=param:-0.2"));
  const auto jpg = run(pipeline("num-buffers=1 width=320 height=240 focal-plane=param:-0.2",
                                "encoding=jpeg jpeg-quality=90"));
  ASSERT_EQ(raw.size(), 1u);
  ASSERT_EQ(jpg.size(), 1u);
  cv::Mat a, b;
  cv::cvtColor(raw[0], a, cv::COLOR_RGBA2RGB);
  cv::cvtColor(jpg[0], b, cv::COLOR_RGBA2RGB);
  EXPECT_GT(cv::PSNR(a, b), 36.0);
}

// The GL backend (lib/lf/render/gl_render.h) in a real pipeline: fragments drawn
// by GL in every lffragment and added by GL in lfcompositor, against the
// CPU pipeline: within the tolerance of tests/test_gl.cpp (mean <= 1 LSB,
// max <= 3, at most 1 % of the pixels differing; on llvmpipe, identical).
TEST_F(Gst, GlBackendPipelineEqualsTheCpuPipeline) {
  ASSERT_TRUE(lf::gl_info().available) << lf::gl_info().error;
  const std::string view = "num-buffers=2 width=320 height=240 focal-plane=param:-0.2";
  std::string err;
  const auto cpu = run(pipeline(view, "backend=cpu", "backend=cpu"), 100, nullptr, &err);
  ASSERT_EQ(cpu.size(), 2u) << err;
  const auto gl = run(pipeline(view, "backend=gl", "backend=gl"), 100, nullptr, &err);
  ASSERT_EQ(gl.size(), 2u) << err;
  for (size_t k = 0; k < gl.size(); ++k) {
    cv::Mat diff;
    cv::absdiff(gl[k], cpu[k], diff);
    double worst = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
    const cv::Scalar mad = cv::mean(diff);
    EXPECT_LE((mad[0] + mad[1] + mad[2] + mad[3]) / 4, 1.0);
    EXPECT_LE(worst, 3.0);
    EXPECT_LE(cv::countNonZero(diff.reshape(1)), static_cast<int>(diff.total()) / 100);
  }
}

// The whole-view mode (lfarray whole-view, lffragment defer): the cameras'
// fragments leave their drawing to the compositor, which draws them all in
// one GL pass sequence from the camera frames, with no fragment read back.
// Its frames equal those of every lffragment drawing with GL, exactly (the
// same whole-number sums; those are within the GL tolerance of the CPU
// pipeline's, above); lfarray uses it when its compositor draws with GL.
// Three requests along an orbit, a stereo pair, a rig with colour
// correction. (Named GlBackend* so that the sanitizer run leaves it out
// with the other GL pipeline tests: scripts/test-san.sh.)
TEST_F(Gst, GlBackendWholeViewModeEqualsEveryFragmentDrawingWithGl) {
  ASSERT_TRUE(lf::gl_info().available) << lf::gl_info().error;
  const std::string view =
      "num-buffers=3 width=320 height=240 focal-plane=param:-0.2 orbit=0.5 "
      "focal-surface=false";
  std::string err;
  const auto gl = run(pipeline(view, "backend=gl", "backend=gl"), 100, nullptr, &err);
  ASSERT_EQ(gl.size(), 3u) << err;
  const auto whole = run(pipeline(view, "defer=true", "backend=gl"), 100, nullptr, &err);
  ASSERT_EQ(whole.size(), 3u) << err;
  const std::string req = "lfviewrequest rig=" + rig_path_ + " " + view;
  const std::string out = " ! video/x-raw,format=RGBA ! appsink name=out sync=false";
  const auto array =
      run(req + " ! lfarray name=a rig=" + rig_path_ + " num-buffers=1 backend=gl" + out, 100,
          nullptr, &err);
  ASSERT_EQ(array.size(), 3u) << err;
  const auto per_fragment =
      run(req + " ! lfarray rig=" + rig_path_ + " num-buffers=1 backend=gl whole-view=false" + out,
          100, nullptr, &err);
  ASSERT_EQ(per_fragment.size(), 3u) << err;
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(cv::norm(whole[k], gl[k], cv::NORM_INF), 0) << "frame " << k;
    EXPECT_EQ(cv::norm(array[k], gl[k], cv::NORM_INF), 0) << "frame " << k;
    EXPECT_EQ(cv::norm(per_fragment[k], gl[k], cv::NORM_INF), 0) << "frame " << k;
    EXPECT_GT(cv::countNonZero(whole[k].reshape(1)), static_cast<int>(whole[k].total()))
        << "frame " << k << " is mostly empty";
  }
  // lfarray sets its fragments to defer (and to no GL of their own) with
  // raw fragments, whatever the backend, unless whole-view=false.
  auto deferred = [&](const std::string& props) {
    GstElement* a = nullptr;
    GstElement* f = array_fragment(props, &a);
    gboolean defer = FALSE;
    gint backend = -1;
    if (f) g_object_get(f, "defer", &defer, "backend", &backend, nullptr);
    if (f) gst_object_unref(f);
    if (a) gst_element_set_state(a, GST_STATE_NULL), gst_object_unref(a);
    return std::make_pair(static_cast<bool>(defer), backend);
  };
  // A stereo pair (two viewers' fragments, one compositor) and a rig with
  // colour correction (the image drawn is the corrected copy): the same.
  const std::string corrected = colour_corrected_rig("lf-test-chess4-colour-gl.json");
  for (const bool stereo : {true, false}) {
    std::string gl_desc = pipeline(view + (stereo ? " stereo-baseline=2" : ""), "backend=gl",
                                   stereo ? "backend=gl stereo=true viewer-id=0" : "backend=gl");
    std::string whole_desc = pipeline(view + (stereo ? " stereo-baseline=2" : ""), "defer=true",
                                      stereo ? "backend=gl stereo=true viewer-id=0" : "backend=gl");
    for (std::string* d : {&gl_desc, &whole_desc})
      for (size_t at = d->find(rig_path_); !stereo && at != std::string::npos;
           at = d->find(rig_path_, at))
        d->replace(at, rig_path_.size(), corrected);
    const auto a = run(gl_desc, 100, nullptr, &err);
    ASSERT_EQ(a.size(), 3u) << err;
    const auto b = run(whole_desc, 100, nullptr, &err);
    ASSERT_EQ(b.size(), 3u) << err;
    for (size_t k = 0; k < 3; ++k) {
      EXPECT_EQ(a[k].cols, stereo ? 640 : 320);
      EXPECT_EQ(cv::norm(a[k], b[k], cv::NORM_INF), 0) << (stereo ? "stereo" : "colour");
      // Not the plain frame: the eyes differ; the colours are corrected.
      if (stereo)
        EXPECT_GT(cv::norm(a[k].colRange(0, 320), a[k].colRange(320, 640), cv::NORM_L1), 0);
      else
        EXPECT_GT(cv::norm(a[k], gl[k], cv::NORM_L1), 0);
    }
  }
  std::filesystem::remove(corrected);
  const int kCpuBackend = static_cast<int>(lf::Backend::kCpu);
  EXPECT_EQ(deferred("backend=gl"), std::make_pair(true, kCpuBackend));
  EXPECT_EQ(deferred("backend=gl whole-view=false").first, false);
  EXPECT_EQ(deferred("backend=cpu"), std::make_pair(true, kCpuBackend));
  EXPECT_EQ(deferred("backend=gl encoding=jpeg").first, false);
}

// Deferred fragments without GL: a CPU compositor draws them with the CPU
// kernels, fused into its compositing (lib/lf/render/composite.h drawings),
// bit-identical to fragments drawn by their lffragments; so does lfarray,
// whose whole-view mode (the default with raw fragments) defers them and
// plans every camera on one request thread, against whole-view=false (a
// request thread and a drawing per camera), in a stereo pair and with
// colour correction too. Their
// drawing never leaves the process: through RTP (rtpgstpay, a copy) they
// arrive as the empty fragments they are on the wire, and the frame is
// empty (no weight anywhere: all zero), never garbage.
TEST_F(Gst, DeferredFragmentsWithoutGlAndOverRtp) {
  const std::string view =
      "num-buffers=2 width=320 height=240 focal-plane=param:-0.2 orbit=0.5 "
      "focal-surface=false";
  std::string err;
  const auto want = run(pipeline(view, "backend=cpu", "backend=cpu"), 100, nullptr, &err);
  ASSERT_EQ(want.size(), 2u) << err;
  const auto cpu = run(pipeline(view, "defer=true", "backend=cpu"), 100, nullptr, &err);
  ASSERT_EQ(cpu.size(), 2u) << err;
  const auto rtp = run(pipeline(view, "defer=true ! rtpgstpay ! rtpgstdepay", "backend=cpu"), 100,
                       nullptr, &err);
  ASSERT_EQ(rtp.size(), 2u) << err;
  const std::string corrected = colour_corrected_rig("lf-test-chess4-colour-cpu.json");
  for (const std::string& r : {rig_path_, corrected})
    for (const std::string stereo : {"", " stereo-baseline=2"}) {
      const std::string req = "lfviewrequest rig=" + r + " " + view + stereo;
      const std::string out = " ! video/x-raw,format=RGBA ! appsink name=out sync=false";
      const std::string array = " ! lfarray rig=" + r + " num-buffers=1 backend=cpu" +
                                (stereo.empty() ? "" : " stereo=true viewer-id=0");
      const auto whole = run(req + array + out, 100, nullptr, &err);
      ASSERT_EQ(whole.size(), 2u) << err;
      const auto each = run(req + array + " whole-view=false" + out, 100, nullptr, &err);
      ASSERT_EQ(each.size(), 2u) << err;
      for (size_t k = 0; k < 2; ++k) {
        EXPECT_EQ(whole[k].cols, stereo.empty() ? 320 : 640);
        EXPECT_EQ(cv::norm(whole[k], each[k], cv::NORM_INF), 0) << r << stereo << ", frame " << k;
        EXPECT_GT(cv::countNonZero(whole[k].reshape(1)), static_cast<int>(whole[k].total()))
            << r << stereo;
        if (!stereo.empty()) continue;
        if (r == rig_path_) {
          EXPECT_EQ(cv::norm(whole[k], want[k], cv::NORM_INF), 0) << "frame " << k;
        } else {  // corrected: not the plain frame
          EXPECT_GT(cv::norm(whole[k], want[k], cv::NORM_L1), 0);
        }
      }
    }
  std::filesystem::remove(corrected);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(cv::norm(cpu[k], want[k], cv::NORM_INF), 0) << "frame " << k;
    EXPECT_GT(cv::countNonZero(want[k].reshape(1)), static_cast<int>(want[k].total()));
    EXPECT_EQ(cv::countNonZero(rtp[k].reshape(1)), 0) << "frame " << k;
  }
}

// One request thread for all cameras (lfarray's whole-view mode: the
// fragments only plan, and a non-live compositor waits for a fragment on
// every pad): every camera answers every request, so the pads stay in step.
// A camera without a frame answers with an empty fragment (a dropped one
// would hold the compositor, and the request thread pushing into it, for
// ever); a request rate over lfarray's max-rate is dropped once for all
// cameras, not by each camera's own limit. Before either, both pipelines
// hung.
TEST_F(Gst, OneRequestThreadKeepsTheCamerasInStep) {
  const lf::Rig rig = lf::load_rig(rig_path_);
  auto covered = [](const cv::Mat& f) {  // pixels with weight (alpha)
    cv::Mat alpha;
    cv::extractChannel(f, alpha, 3);
    return cv::countNonZero(alpha);
  };
  // Camera 0's frames never arrive (valve): every request waits there (ten
  // 5 ms frame-timeouts: the camera never started), then gets its empty
  // fragment: deferred
  // (whole-view), or JPEG with answer-empty (request threads shared by
  // several cameras, as lfarray's request-threads are). 40 requests: more
  // than the compositor's pads hold (17, its run-ahead), so a camera that
  // answered nothing would hold the thread for ever (it did without
  // answer-empty).
  for (const std::string fragment : {"defer=true", "encoding=jpeg answer-empty=true"}) {
    std::string d = "lfviewrequest rig=" + rig_path_ +
                    " num-buffers=40 width=160 height=120 focal-plane=param:-0.2 orbit=0.5"
                    " focal-surface=false ! tee name=t lfcompositor name=comp rig=" +
                    rig_path_ +
                    " backend=cpu ! video/x-raw,format=RGBA ! appsink name=out sync=false";
    for (size_t i = 0; i < rig.cameras.size(); ++i) {
      const std::string id = std::to_string(rig.cameras[i].id), n = std::to_string(i);
      d += " lfcamsrc rig=" + rig_path_ + " camera-id=" + id + " num-buffers=1 ! " +
           (i == 0 ? "valve drop=true ! " : "") + "f" + n + ".sink";
      d += " t. ! lffragment name=f" + n + " rig=" + rig_path_ + " camera-id=" + id + " " +
           fragment + (i == 0 ? " frame-timeout=5000000" : "") + " ! comp.sink_" + n;
    }
    std::vector<std::string> warnings;
    std::string err;
    const auto frames = run(d, 100, &warnings, &err);
    EXPECT_TRUE(err.empty()) << err;
    EXPECT_EQ(frames.size(), 40u) << fragment;
    EXPECT_TRUE(std::any_of(warnings.begin(), warnings.end(), [](const std::string& w) {
      return w.find("No camera frame") != std::string::npos;
    })) << fragment;
    // The other three cameras' pixels are there.
    for (const cv::Mat& f : frames)
      EXPECT_GT(covered(f), static_cast<int>(f.total()) / 4) << fragment;
  }
  std::vector<std::string> warnings;
  std::string err;
  // 2000 requests as fast as the pipeline takes them, at most 50 a second
  // (bursts of 50): some pass, the rest are dropped with a warning, and the
  // run ends; each frame that comes is whole (every camera's weight).
  warnings.clear();
  const gint64 t0 = g_get_monotonic_time();
  const auto limited =
      run("lfviewrequest rig=" + rig_path_ +
              " num-buffers=2000 framerate=1000/1 width=160 height=120 focal-plane=param:-0.2"
              " orbit=0.5 focal-surface=false ! lfarray rig=" +
              rig_path_ +
              " num-buffers=1 max-rate=50 ! video/x-raw,format=RGBA ! appsink name=out "
              "sync=false",
          2000, &warnings, &err);
  const double seconds = (g_get_monotonic_time() - t0) / 1e6;
  EXPECT_TRUE(err.empty()) << err;
  EXPECT_GE(limited.size(), 50u);
  EXPECT_LE(static_cast<double>(limited.size()), 50 + 50 * seconds + 1) << seconds << " s";
  EXPECT_LT(limited.size(), 2000u);
  EXPECT_TRUE(std::any_of(warnings.begin(), warnings.end(), [](const std::string& w) {
    return w.find("max-rate") != std::string::npos;
  }));
  for (const cv::Mat& f : limited) ASSERT_GT(covered(f), static_cast<int>(f.total()) * 9 / 10);
  // Where the limit is kept: the host's own (its fragments have none), on
  // the thread that brings the requests, with one request thread or one per
  // camera (each camera deciding alone dropped a request in some cameras only).
  for (const bool whole : {true, false}) {
    GstElement* a = nullptr;
    GstElement* f =
        array_fragment(std::string("max-rate=100") + (whole ? "" : " whole-view=false"), &a);
    ASSERT_NE(f, nullptr);
    gdouble rate = -1;
    g_object_get(f, "max-rate", &rate, nullptr);
    EXPECT_EQ(rate, 0.0) << (whole ? "whole-view" : "whole-view=false");
    gst_object_unref(f);
    gst_element_set_state(a, GST_STATE_NULL);
    gst_object_unref(a);
  }
}

// request-threads: K threads answer the requests, each a queue and a tee
// for every K-th camera (0: one per core and one more), or a queue per camera where
// there are at least as many threads as cameras (and wherever frames are
// picked by capture time): the same frames either way. Not live, the
// compositor lets every pad hold 16 requests' fragments (its
// min-upstream-latency set to 16 periods; fewer for large views); live, or
// when the user set it, it leaves it alone.
TEST_F(Gst, RequestThreadsShareTheCamerasAndNonLiveCamerasRunAhead) {
  const lf::Rig rig = lf::load_rig(rig_path_);
  ASSERT_EQ(rig.cameras.size(), 4u);
  const std::string req = "lfviewrequest rig=" + rig_path_ +
                          " num-buffers=3 width=160 height=120 focal-plane=param:-0.2 orbit=0.5"
                          " focal-surface=false framerate=30/1";
  const std::string out = " ! video/x-raw,format=RGBA ! appsink name=out sync=false";
  // The request threads' queues of an lfarray built with `props`.
  auto queues = [&](const std::string& props) {
    GstElement* a = nullptr;
    GstElement* f = array_fragment(props, &a);
    std::vector<std::string> names;
    if (f) gst_object_unref(f);
    if (!a) return names;
    GstIterator* it = gst_bin_iterate_elements(GST_BIN(a));
    GValue v = G_VALUE_INIT;
    while (gst_iterator_next(it, &v) == GST_ITERATOR_OK) {
      GstElement* e = GST_ELEMENT(g_value_get_object(&v));
      GstElementFactory* made_by = gst_element_get_factory(e);  // none: lfarray's bundles
      const gchar* factory = made_by ? GST_OBJECT_NAME(made_by) : "";
      gchar* name = gst_element_get_name(e);
      if (g_str_equal(factory, "queue")) names.push_back(name);
      g_free(name);
      g_value_reset(&v);
    }
    g_value_unset(&v);
    gst_iterator_free(it);
    gst_element_set_state(a, GST_STATE_NULL);
    gst_object_unref(a);
    std::sort(names.begin(), names.end());
    return names;
  };
  EXPECT_EQ(queues("encoding=jpeg request-threads=2"),
            (std::vector<std::string>{"requests-0", "requests-1"}));
  EXPECT_EQ(queues("encoding=jpeg request-threads=1"), (std::vector<std::string>{"requests-0"}));
  // 0 (the default): one per core and one more (on 2 cores 3 threads for the
  // 4 cameras; with 3 cores or more a queue per camera).
  const size_t cores = g_get_num_processors();
  EXPECT_EQ(queues("encoding=jpeg").size(), std::min<size_t>(4, cores + 1));
  EXPECT_EQ(queues("encoding=jpeg")[0].rfind("requests-", 0) == 0, cores + 1 < 4);
  EXPECT_EQ(queues("encoding=jpeg request-threads=4").size(), 4u);  // a queue per camera
  EXPECT_EQ(queues("encoding=jpeg request-threads=4")[0].rfind("requests-", 0), std::string::npos);
  EXPECT_EQ(queues("encoding=jpeg request-threads=1 frame-select=capture-time").size(), 4u);
  EXPECT_TRUE(queues("").empty());  // whole-view: one request thread, no queue
  std::string err;
  const auto each = run(
      req + " ! lfarray rig=" + rig_path_ + " num-buffers=1 encoding=jpeg request-threads=4" + out,
      100, nullptr, &err);
  ASSERT_EQ(each.size(), 3u) << err;
  for (const char* threads : {"1", "2", "3"}) {
    const auto shared = run(req + " ! lfarray rig=" + rig_path_ +
                                " num-buffers=1 encoding=jpeg request-threads=" + threads + out,
                            100, nullptr, &err);
    ASSERT_EQ(shared.size(), 3u) << threads << " threads: " << err;
    for (size_t k = 0; k < each.size(); ++k)
      EXPECT_EQ(cv::norm(each[k], shared[k], cv::NORM_INF), 0)
          << threads << " threads, frame " << k;
  }
  // The compositor's run-ahead once the stream has run (to EOS, not torn
  // down): 16 periods of 30 fps not live, none live, the user's kept.
  auto run_ahead = [&](const std::string& desc, const char* comp) {
    GstElement* p = gst_parse_launch(desc.c_str(), nullptr);
    if (!p) return G_MAXUINT64;
    gst_element_set_state(p, GST_STATE_PLAYING);
    GstBus* bus = gst_element_get_bus(p);
    GstMessage* m = gst_bus_timed_pop_filtered(
        bus, 20 * GST_SECOND, static_cast<GstMessageType>(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
    const bool eos = m && GST_MESSAGE_TYPE(m) == GST_MESSAGE_EOS;
    if (m) gst_message_unref(m);
    GstElement* c = gst_bin_get_by_name(GST_BIN(p), comp);
    guint64 v = G_MAXUINT64;
    if (c && eos) g_object_get(c, "min-upstream-latency", &v, nullptr);
    if (c) gst_object_unref(c);
    gst_element_set_state(p, GST_STATE_NULL);
    gst_object_unref(bus);
    gst_object_unref(p);
    return v;
  };
  const std::string sink = " ! fakesink sync=false";
  EXPECT_EQ(
      run_ahead(req + " ! lfarray name=a rig=" + rig_path_ + " num-buffers=1" + sink, "compositor"),
      16 * gst_util_uint64_scale_int(GST_SECOND, 1, 30));
  EXPECT_EQ(run_ahead(req + " is-live=true ! lfarray rig=" + rig_path_ + " num-buffers=1" + sink,
                      "compositor"),
            0u);
  std::string own = pipeline("num-buffers=3 width=160 height=120 focal-plane=param:-0.2",
                             "encoding=jpeg", "min-upstream-latency=5000000");
  own.replace(own.find(" ! video/x-raw"), own.find(" lfcamsrc") - own.find(" ! video/x-raw"), sink);
  EXPECT_EQ(run_ahead(own, "comp"), 5000000u);
}

// A request thread's fragments reach the compositor bundled (gst/lfbundle.h):
// one buffer a request for up to 16 cameras, one more for each 16 after, and
// the frames are those of a thread per camera (no bundles); whole-view
// mode's deferred drawings alike.
TEST_F(Gst, RequestThreadsBundleTheirFragmentsForTheCompositor) {
  struct Counts {
    std::atomic<int> buffers{0}, parts{0};
  };
  // The frames of `desc`, counting the buffers (and their memories: the
  // bundles' parts) that reach the sink pads of its element "compositor".
  auto counted = [](const std::string& desc, Counts* c, std::string* err) {
    std::vector<cv::Mat> frames;
    GstElement* p = gst_parse_launch(desc.c_str(), nullptr);
    if (!p) return frames;
    gst_element_set_state(p, GST_STATE_READY);  // lfarray builds its graph
    GstElement* comp = gst_bin_get_by_name(GST_BIN(p), "compositor");
    for (GList* l = comp ? GST_ELEMENT(comp)->sinkpads : nullptr; l; l = l->next)
      gst_pad_add_probe(
          GST_PAD(l->data), GST_PAD_PROBE_TYPE_BUFFER,
          [](GstPad*, GstPadProbeInfo* info, gpointer data) {
            auto* c = static_cast<Counts*>(data);
            c->buffers++;
            c->parts += static_cast<int>(gst_buffer_n_memory(GST_PAD_PROBE_INFO_BUFFER(info)));
            return GST_PAD_PROBE_OK;
          },
          c, nullptr);
    if (comp) gst_object_unref(comp);
    GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
    gst_element_set_state(p, GST_STATE_PLAYING);
    while (GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 30 * GST_SECOND))
      frames.push_back(rgba_of(s));
    GstBus* bus = gst_element_get_bus(p);
    if (GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR)) {
      GError* e = nullptr;
      gst_message_parse_error(m, &e, nullptr);
      *err = e->message;
      g_clear_error(&e);
      gst_message_unref(m);
    }
    gst_object_unref(bus);
    gst_object_unref(sink);
    gst_element_set_state(p, GST_STATE_NULL);
    gst_object_unref(p);
    return frames;
  };
  // 20 cameras (a 5 x 4 block of Chess at a quarter resolution): one thread
  // bundles 16 and 4.
  const std::string rig20 =
      (std::filesystem::temp_directory_path() / "lf-test-chess20.json").string();
  lf::save_rig(
      lf::scale_rig(lf::grid_block(lf::import_dataset(data_path("stanford-chess")), 1, 2, 5, 4),
                    0.25),
      rig20);
  constexpr int kRequests = 4;
  // (rig, cameras, eyes): in stereo each eye's requests are bundled apart.
  for (const auto& [rig, cameras, eyes] :
       {std::tuple{rig_path_, 4, 1}, std::tuple{rig20, 20, 1}, std::tuple{rig_path_, 4, 2}}) {
    const std::string desc =
        "lfviewrequest rig=" + rig + " num-buffers=" + std::to_string(kRequests) +
        " width=96 height=72 focal-plane=param:-0.2 orbit=0.5 focal-surface=false" +
        (eyes == 2 ? " stereo-baseline=2" : "") + " ! lfarray rig=" + rig +
        (eyes == 2 ? " stereo=true viewer-id=0" : "") +
        " num-buffers=1 encoding=jpeg request-threads=";
    const std::string out = " ! video/x-raw,format=RGBA ! appsink name=out sync=false";
    const std::string what =
        std::to_string(cameras) + " cameras, " + std::to_string(eyes) + " eyes";
    Counts one, each;
    std::string err;
    const auto bundled = counted(desc + "1" + out, &one, &err);
    ASSERT_EQ(bundled.size(), static_cast<size_t>(kRequests)) << what << ": " << err;
    const auto apart = counted(desc + std::to_string(cameras) + out, &each, &err);
    ASSERT_EQ(apart.size(), static_cast<size_t>(kRequests)) << what << ": " << err;
    EXPECT_EQ(bundled[0].cols, 96 * eyes);
    // A thread per camera: a buffer per fragment.
    EXPECT_EQ(each.buffers.load(), kRequests * eyes * cameras) << what;
    EXPECT_EQ(each.parts.load(), kRequests * eyes * cameras) << what;
    // One thread: every fragment in a bundle of at most 16.
    EXPECT_EQ(one.parts.load(), kRequests * eyes * cameras) << what;
    EXPECT_EQ(one.buffers.load(), kRequests * eyes * ((cameras + 15) / 16)) << what;
    for (int k = 0; k < kRequests; ++k)
      EXPECT_EQ(cv::norm(bundled[k], apart[k], cv::NORM_INF), 0) << what << ", frame " << k;
  }
  // Whole-view mode (raw fragments): the one request thread's plans are
  // bundled too, each part still carrying its drawing, and the frames are
  // those of a thread per camera each drawing its own fragment.
  const std::string desc = "lfviewrequest rig=" + rig20 +
                           " num-buffers=" + std::to_string(kRequests) +
                           " width=96 height=72 focal-plane=param:-0.2 orbit=0.5 "
                           "focal-surface=false ! lfarray rig=" +
                           rig20 + " num-buffers=1 ";
  const std::string out = " ! video/x-raw,format=RGBA ! appsink name=out sync=false";
  Counts whole, drawn;
  std::string err;
  const auto deferred = counted(desc + "whole-view=true" + out, &whole, &err);
  ASSERT_EQ(deferred.size(), static_cast<size_t>(kRequests)) << err;
  const auto own = counted(desc + "whole-view=false request-threads=20" + out, &drawn, &err);
  ASSERT_EQ(own.size(), static_cast<size_t>(kRequests)) << err;
  EXPECT_EQ(whole.parts.load(), kRequests * 20);
  EXPECT_EQ(whole.buffers.load(), kRequests * 2);  // 16 and 4
  EXPECT_EQ(drawn.buffers.load(), kRequests * 20);
  for (int k = 0; k < kRequests; ++k) {
    EXPECT_GT(cv::norm(own[k], cv::NORM_L1), 0) << "frame " << k;
    EXPECT_EQ(cv::norm(deferred[k], own[k], cv::NORM_INF), 0) << "frame " << k;
  }
}

// Non-live: a still camera makes one or two frames a request, not as many as
// the CPU allows (64 such cameras took 37 s for 60 requests of one viewer,
// 0.5 s now), requests are never dropped on the wall clock, and the end of
// the requests ends the camera's stream too.
TEST_F(Gst, NonLiveCamerasFollowTheRequests) {
  constexpr int kRequests = 20;
  GstElement* p = one_camera_pipeline(kRequests);
  ASSERT_NE(p, nullptr);
  std::atomic<int> frames{0}, fragments{0};
  GstElement* cam = gst_bin_get_by_name(GST_BIN(p), "cam");
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  GstPad* cam_src = gst_element_get_static_pad(cam, "src");
  GstPad* out_sink = gst_element_get_static_pad(out, "sink");
  auto count = +[](GstPad*, GstPadProbeInfo*, gpointer n) {
    ++*static_cast<std::atomic<int>*>(n);
    return GST_PAD_PROBE_OK;
  };
  gst_pad_add_probe(cam_src, GST_PAD_PROBE_TYPE_BUFFER, count, &frames, nullptr);
  gst_pad_add_probe(out_sink, GST_PAD_PROBE_TYPE_BUFFER, count, &fragments, nullptr);
  gst_element_set_state(p, GST_STATE_PLAYING);
  GstBus* bus = gst_element_get_bus(p);
  expect_eos(bus);
  // The camera's stream ended too (its task stopped on EOS from lffragment).
  // A push already on its way when the end of stream reached the bus is
  // refused and counted (the probe counts before the push is answered):
  // once, under load (2 runs in 20 with two busy loops on 2 cores).
  const int frames_at_eos = frames.load();
  g_usleep(300000);
  const int frames_after = frames.load();
  g_usleep(300000);
  EXPECT_LE(frames_after, frames_at_eos + 1) << "the camera went on after the requests ended";
  EXPECT_EQ(frames.load(), frames_after) << "the camera went on after the requests ended";
  EXPECT_EQ(fragments.load(), kRequests);
  // The camera is held two frames ahead of the requests: at most two new
  // frames a request, and the first two (the old code: thousands).
  EXPECT_LE(frames_at_eos, 2 * kRequests + 3) << "a non-live still camera flooded the pipeline";
  gst_object_unref(bus);
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(cam_src);
  gst_object_unref(out_sink);
  gst_object_unref(cam);
  gst_object_unref(out);
  gst_object_unref(p);
}

// A non-live camera that is slow to start (its caps 1.5 s after the first
// request, as 64 still cameras decoding their images on a busy machine):
// the requests wait for it (it is asked whether it is live), no request is
// dropped on frame-timeout (1 s) and nothing is warned about. Before, a
// request before the caps waited a live camera's second and was dropped:
// the demo's "No camera frame" stall, 1 run in 5.
TEST_F(Gst, ASlowStartingNonLiveCameraIsWaitedFor) {
  constexpr int kRequests = 3;
  GstElement* p = one_camera_pipeline(kRequests);
  ASSERT_NE(p, nullptr);
  std::atomic<int> fragments{0};
  GstElement* cam = gst_bin_get_by_name(GST_BIN(p), "cam");
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  GstPad* cam_src = gst_element_get_static_pad(cam, "src");
  GstPad* out_sink = gst_element_get_static_pad(out, "sink");
  auto slow_caps = +[](GstPad*, GstPadProbeInfo* info, gpointer) {
    if (GST_EVENT_TYPE(GST_PAD_PROBE_INFO_EVENT(info)) == GST_EVENT_CAPS) g_usleep(1500000);
    return GST_PAD_PROBE_OK;
  };
  auto count = +[](GstPad*, GstPadProbeInfo*, gpointer n) {
    ++*static_cast<std::atomic<int>*>(n);
    return GST_PAD_PROBE_OK;
  };
  gst_pad_add_probe(cam_src, GST_PAD_PROBE_TYPE_EVENT_DOWNSTREAM, slow_caps, nullptr, nullptr);
  gst_pad_add_probe(out_sink, GST_PAD_PROBE_TYPE_BUFFER, count, &fragments, nullptr);
  gst_element_set_state(p, GST_STATE_PLAYING);
  GstBus* bus = gst_element_get_bus(p);
  expect_eos(bus);  // no warning before the end
  EXPECT_EQ(fragments.load(), kRequests);
  gst_object_unref(bus);
  gst_element_set_state(p, GST_STATE_NULL);
  for (GstPad* pad : {cam_src, out_sink}) gst_object_unref(pad);
  for (GstElement* e : {cam, out, p}) gst_object_unref(e);
}

// Two viewers of different view sizes sharing a camera host through
// lfrequestmux, not live and live: each compositor gets its own viewer's
// caps (its view size), so neither drops the other's fragments as "for
// another output size". Before, lfrequestqueue sent caps ahead of the
// queued requests and lffragmentdemux sent every caps to every viewer, so
// each compositor's view size flipped with the other viewer's requests (a
// 4K flood left a 640x480 viewer 56 % of its frames).
TEST_F(Gst, ViewersOfDifferentSizesEachGetTheirOwnCaps) {
  constexpr int kFrames = 20;
  const std::string rig = " rig=" + rig_path_ + " ";
  for (const bool live : {false, true}) {
    const std::string common = " num-buffers=" + std::to_string(kFrames) +
                               " focal-surface=false is-live=" + (live ? "true " : "false ");
    // Live, each branch leaks (docs/steering.md: a plain queue behind a sink
    // that prerolled first can stop the shared stream for good).
    const std::string branch_queue = live ? "queue leaky=downstream " : "queue ";
    GstElement* p = gst_parse_launch(
        ("lfrequestmux name=reqs ! lfcamerahost" + rig + "is-live=" + (live ? "true" : "false") +
         " ! lffragmentdemux name=d lfviewrequest viewer-id=0 width=160 height=120" + rig + common +
         "! reqs. lfviewrequest viewer-id=1 width=320 height=240 orbit=0.5" + rig + common +
         "! reqs. d.src_0 ! " + branch_queue + "! lfcompositor viewer-id=0" + rig +
         "! fakesink name=s0 d.src_1 ! " + branch_queue + "! lfcompositor viewer-id=1" + rig +
         "! fakesink name=s1")
            .c_str(),
        nullptr);
    ASSERT_NE(p, nullptr);
    std::atomic<int> frames[2] = {{0}, {0}};
    GstPad* pads[2];
    for (int v = 0; v < 2; ++v) {
      count_buffers(GST_BIN(p), v ? "s1" : "s0", &frames[v]);
      GstElement* sink = gst_bin_get_by_name(GST_BIN(p), v ? "s1" : "s0");
      pads[v] = gst_element_get_static_pad(sink, "sink");
      gst_object_unref(sink);
    }
    gst_element_set_state(p, GST_STATE_PLAYING);
    GstBus* bus = gst_element_get_bus(p);
    expect_eos(bus);  // no warning (no fragment dropped for another size)
    for (int v = 0; v < 2; ++v) {
      GstCaps* caps = gst_pad_get_current_caps(pads[v]);
      ASSERT_NE(caps, nullptr);
      gint w = 0;
      gst_structure_get_int(gst_caps_get_structure(caps, 0), "width", &w);
      EXPECT_EQ(w, v ? 320 : 160) << (live ? "live" : "not live");
      gst_caps_unref(caps);
      // Not live: every request; live: at least half (a busy machine drops
      // stale requests) (measured: 20 of 20).
      if (live)
        EXPECT_GE(frames[v].load(), kFrames / 2) << "viewer " << v;
      else
        EXPECT_EQ(frames[v].load(), kFrames) << "viewer " << v;
      gst_object_unref(pads[v]);
    }
    gst_object_unref(bus);
    gst_element_set_state(p, GST_STATE_NULL);
    gst_object_unref(p);
  }
}

// A live camera host keeps its pixel budget (max-pixel-rate) once for all
// its cameras, on the thread that brings the requests: a request over it is
// dropped by every camera or answered by every one. Before, each camera
// decided alone, so a flood's requests were answered by some cameras and not
// by others (frames composited incomplete, the work for them wasted).
TEST_F(Gst, ACameraHostDropsARequestOverItsBudgetInEveryCamera) {
  const lf::Rig rig = lf::load_rig(rig_path_);
  const double budget = 10.0 * 1280 * 960;  // ten 1280x960 requests a second
  const AppPipeline a(
      "appsrc name=in is-live=true do-timestamp=true format=time "
      "caps=application/x-lf-view-request ! lfcamerahost rig=" +
      rig_path_ + " is-live=true max-pixel-rate=" + std::to_string(budget) +
      " ! appsink name=out sync=false max-buffers=0");
  ASSERT_NE(a.pipe, nullptr);
  GstElement *in = a.in, *out = a.out;
  std::this_thread::sleep_for(std::chrono::seconds(1));  // the cameras' first frames
  constexpr int kRequests = 40;
  const auto t0 = std::chrono::steady_clock::now();
  for (int seq = 1; seq <= kRequests; ++seq) {
    lf::ViewRequest req;
    req.sequence = static_cast<uint64_t>(seq);
    req.view = lf::view_between_cameras(rig, rig.plane().origin, 1280, 960);
    req.focal_plane = lf::FocalPlane::infinity();
    const auto bytes = lf::serialize_request(req);
    gst_app_src_push_buffer(GST_APP_SRC(in), gst_buffer_new_memdup(bytes.data(), bytes.size()));
    // 50 a second, five times the budget: each camera's bucket refilled at
    // the moment its own thread took the request, so near empty they differed.
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::map<uint64_t, size_t> fragments;  // request sequence -> fragments
  while (GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(out), 2 * GST_SECOND)) {
    GstMapInfo m;
    gst_buffer_map(gst_sample_get_buffer(s), &m, GST_MAP_READ);
    ++fragments[lf::peek_fragment_header(m.data, m.size).sequence];
    gst_buffer_unmap(gst_sample_get_buffer(s), &m);
    gst_sample_unref(s);
  }
  for (const auto& [seq, n] : fragments)
    EXPECT_EQ(n, rig.cameras.size()) << "request " << seq << ": answered by some cameras only";
  // Some pass: the budget's burst of ten and its refill where the host keeps
  // up (measured: 17-18 in 0.8 s), fewer where it cannot and sheds stale
  // requests too (9 in the sanitizer build); never more than the budget.
  EXPECT_GE(fragments.size(), 3u);
  EXPECT_LE(fragments.size(), 10u + static_cast<size_t>(10 * secs) + 1) << "cut at the budget";
  EXPECT_LT(fragments.size(), static_cast<size_t>(kRequests));
}

// A live lfrequestmux forwards a viewer's requests while another viewer
// sends none (lf-web: a browser connected and silent). Before, the mux (a
// GstAggregator without get_next_time) waited for a request on every pad,
// live or not: one silent viewer held every other viewer's requests, and
// their video, for ever (0 of 10 forwarded here).
TEST_F(Gst, ALiveRequestMuxDoesNotWaitForASilentViewer) {
  constexpr int kRequests = 10;
  GstElement* p = gst_parse_launch(
      ("appsrc name=silent is-live=true format=time caps=application/x-lf-view-request ! m. "
       "lfviewrequest rig=" +
       rig_path_ +
       " viewer-id=1 is-live=true focal-surface=false width=160 height=120 num-buffers=" +
       std::to_string(kRequests) + " ! m. lfrequestmux name=m ! fakesink name=out sync=false")
          .c_str(),
      nullptr);
  ASSERT_NE(p, nullptr);
  std::atomic<int> forwarded{0};
  count_buffers(GST_BIN(p), "out", &forwarded);
  gst_element_set_state(p, GST_STATE_PLAYING);
  // The requests come at 30 a second: all of them within 0.33 s; 20 s is
  // for a busy machine.
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (forwarded.load() < kRequests && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  // Every one (a request is dropped only behind three newer ones of its
  // viewer in one round: a mux thread starved for 0.1 s); at least half.
  EXPECT_GE(forwarded.load(), kRequests / 2) << "the silent viewer held the other's requests";
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(p);
}

// A viewer added to a playing live pipeline through lfrequestmux (as
// lf-web adds one per browser) gets its frames, and the first viewer keeps
// its own. Before, linking the new pad made GstAggregator renegotiate: the
// mux sent caps fixated from its template (no view size), every compositor
// downstream lost its size, and the new viewer got 0 frames in 3 s.
TEST_F(Gst, AViewerAddedWhilePlayingThroughTheRequestMuxGetsFrames) {
  GstElement* p = gst_pipeline_new("p");
  GstElement* mux = gst_element_factory_make("lfrequestmux", "m");
  GstElement* cams = gst_parse_bin_from_description(
      ("lfcamerahost is-live=true rig=" + rig_path_).c_str(), TRUE, nullptr);
  GstElement* demux = gst_element_factory_make("lffragmentdemux", "d");
  ASSERT_TRUE(mux && cams && demux);
  gst_bin_add_many(GST_BIN(p), mux, cams, demux, nullptr);
  ASSERT_TRUE(gst_element_link_many(mux, cams, demux, nullptr));
  std::atomic<int> frames[2] = {{0}, {0}};
  auto add_viewer = [&](int id) {
    GstElement* bin = gst_parse_bin_from_description(
        ("lfviewrequest name=req is-live=true focal-surface=false width=160 height=120 rig=" +
         rig_path_ + " viewer-id=" + std::to_string(id) +
         " ! queue name=qr queue name=ql ! lfcompositor rig=" + rig_path_ +
         " viewer-id=" + std::to_string(id) + " ! fakesink name=out sync=false async=false")
            .c_str(),
        FALSE, nullptr);
    ASSERT_NE(bin, nullptr);
    auto ghost = [&](const char* el, const char* pad, const char* name) {
      GstElement* e = gst_bin_get_by_name(GST_BIN(bin), el);
      GstPad* target = gst_element_get_static_pad(e, pad);
      GstPad* g = gst_ghost_pad_new(name, target);
      gst_element_add_pad(bin, g);
      gst_object_unref(target);
      gst_object_unref(e);
      return g;
    };
    GstPad* src = ghost("qr", "src", "src");
    GstPad* sink = ghost("ql", "sink", "sink");
    count_buffers(GST_BIN(bin), "out", &frames[id]);
    gst_bin_add(GST_BIN(p), bin);
    GstPad* mux_pad = gst_element_request_pad_simple(mux, "sink_%u");
    GstPad* demux_pad =
        gst_element_request_pad_simple(demux, ("src_" + std::to_string(id)).c_str());
    EXPECT_EQ(gst_pad_link(src, mux_pad), GST_PAD_LINK_OK);
    EXPECT_EQ(gst_pad_link(demux_pad, sink), GST_PAD_LINK_OK);
    gst_object_unref(mux_pad);
    gst_object_unref(demux_pad);
    gst_element_sync_state_with_parent(bin);
  };
  add_viewer(0);
  gst_element_set_state(p, GST_STATE_PLAYING);
  // Frames at 30 a second: waits of up to 20 s are for a busy machine.
  auto wait_for = [&](int id, int n) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (frames[id].load() < n && std::chrono::steady_clock::now() < until)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  };
  wait_for(0, 10);
  ASSERT_GE(frames[0].load(), 10) << "the first viewer";
  add_viewer(1);
  wait_for(1, 10);
  const int first_then = frames[0].load();
  wait_for(0, first_then + 10);
  EXPECT_GE(frames[1].load(), 10) << "the viewer added while playing";
  EXPECT_GE(frames[0].load(), first_then + 10) << "the first viewer after the second came";
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(p);
}

// Several non-live viewers through lfrequestmux (the line of docs/steering.md made non-live, with
// fakesink and num-buffers): every viewer gets all its frames, in seconds
// and without a warning. Through a funnel one viewer could run ahead and the
// pipeline stalled in preroll (1 run in 3 of the 64-camera line).
TEST_F(Gst, SeveralNonLiveViewersThroughTheRequestMux) {
  constexpr int kFrames = 30;
  const std::string rig = " rig=" + rig_path_ + " ";
  const std::string n =
      " num-buffers=" + std::to_string(kFrames) + " width=160 height=120 focal-surface=false ";
  for (int run = 0; run < 3; ++run) {
    GstElement* p = gst_parse_launch(("lfrequestmux name=reqs ! lfcamerahost" + rig +
                                      "! lffragmentdemux name=d "
                                      "lfviewrequest viewer-id=0" +
                                      rig + n +
                                      "! reqs. "
                                      "lfviewrequest viewer-id=1 orbit=0.5" +
                                      rig + n +
                                      "! reqs. "
                                      "d.src_0 ! queue ! lfcompositor viewer-id=0" +
                                      rig +
                                      "! fakesink name=s0 "
                                      "d.src_1 ! queue ! lfcompositor viewer-id=1" +
                                      rig + "! fakesink name=s1")
                                         .c_str(),
                                     nullptr);
    ASSERT_NE(p, nullptr);
    std::atomic<int> frames[2] = {{0}, {0}};
    for (int v = 0; v < 2; ++v) count_buffers(GST_BIN(p), v ? "s1" : "s0", &frames[v]);
    gst_element_set_state(p, GST_STATE_PLAYING);
    GstBus* bus = gst_element_get_bus(p);
    GstMessage* m = gst_bus_timed_pop_filtered(
        bus, 60 * GST_SECOND,
        static_cast<GstMessageType>(GST_MESSAGE_EOS | GST_MESSAGE_ERROR | GST_MESSAGE_WARNING));
    ASSERT_NE(m, nullptr) << "run " << run << ": no end in 60 s";
    EXPECT_EQ(GST_MESSAGE_TYPE(m), GST_MESSAGE_EOS)
        << (GST_MESSAGE_TYPE(m) == GST_MESSAGE_EOS
                ? ""
                : testing_lf::take_error_debug(gst_message_ref(m)));
    gst_message_unref(m);
    EXPECT_EQ(frames[0].load(), kFrames) << "run " << run;
    EXPECT_EQ(frames[1].load(), kFrames) << "run " << run;
    GstElement* mux = gst_bin_get_by_name(GST_BIN(p), "reqs");
    guint64 forwarded = 0;
    g_object_get(mux, "forwarded", &forwarded, nullptr);
    EXPECT_EQ(forwarded, 2u * kFrames);
    gst_object_unref(mux);
    gst_object_unref(bus);
    gst_element_set_state(p, GST_STATE_NULL);
    gst_object_unref(p);
  }
}

// With no focus property, lfviewrequest ! lfarray focuses on a focal
// surface (the best picture by default, docs/rendering.md): the compositor
// answers the surface probes, the requests carry several planes, and no
// warning is posted (non-live: the first probe's answer is waited for).
TEST_F(Gst, TheDefaultPipelineFocusesOnASurface) {
  GstElement* p = gst_parse_launch(("lfviewrequest name=req rig=" + rig_path_ +
                                    " num-buffers=8 width=160 height=120 orbit=0.3 ! lfarray "
                                    "rig=" +
                                    rig_path_ + " ! fakesink")
                                       .c_str(),
                                   nullptr);
  ASSERT_NE(p, nullptr);
  gst_element_set_state(p, GST_STATE_PLAYING);
  GstBus* bus = gst_element_get_bus(p);
  expect_eos(bus);
  GstElement* req = gst_bin_get_by_name(GST_BIN(p), "req");
  gboolean surface = FALSE;
  guint planes = 0;
  g_object_get(req, "focal-surface", &surface, "surface-planes", &planes, nullptr);
  EXPECT_TRUE(surface);
  std::printf("default pipeline: %u planes in the last request's focal surface\n", planes);
  EXPECT_GE(planes, 2u) << "the Chess block has depth: a surface, not one plane";
  gst_object_unref(req);
  gst_object_unref(bus);
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(p);
}

// A focal surface with second planes (the default) in lfarray's whole-view
// mode: a camera's layer pair is deferred like a single fragment (both
// plans on its empty fragment), and the compositor draws the pairs on every
// core. The frames equal whole-view=false's, where each lffragment draws its
// own pair, exactly; the view has two-plane tiles, so pairs were drawn.
TEST_F(Gst, WholeViewModeDefersLayerPairs) {
  // The 8 x 8 Chess block at full size, whose 640x480 surfaces have
  // two-plane tiles (the fixture's 2 x 2 block at half size had none).
  const std::string rig_path =
      (std::filesystem::temp_directory_path() / "lf-test-chess64.json").string();
  lf::save_rig(lf::grid_block(lf::import_dataset(data_path("stanford-chess")), 0, 0, 8, 8),
               rig_path);
  const std::string req = "lfviewrequest name=req rig=" + rig_path +
                          " num-buffers=6 width=640 height=480 orbit=0.3 surface-interval=2";
  const std::string out = " ! video/x-raw,format=RGBA ! appsink name=out sync=false";
  std::string err;
  std::vector<std::string> warnings;
  const auto whole = run(req + " ! lfarray rig=" + rig_path + out, 100, &warnings, &err);
  ASSERT_EQ(whole.size(), 6u) << err;
  const auto each =
      run(req + " ! lfarray rig=" + rig_path + " whole-view=false" + out, 100, &warnings, &err);
  ASSERT_EQ(each.size(), 6u) << err;
  // Every surface the compositor sent back was taken (a tile that kept the
  // prior's depth once got its neighbour's new plane, its own, as its
  // second, and lfviewrequest ignored the whole surface).
  for (const std::string& w : warnings) ADD_FAILURE() << w;
  for (size_t k = 0; k < whole.size(); ++k) {
    EXPECT_EQ(cv::norm(whole[k], each[k], cv::NORM_INF), 0) << "frame " << k;
    EXPECT_GT(cv::countNonZero(whole[k].reshape(1)), static_cast<int>(whole[k].total()))
        << "frame " << k << " is mostly empty";
  }
  // The same requests, for their surfaces' two-plane tiles.
  GstElement* p =
      gst_parse_launch((req + " ! lfarray rig=" + rig_path + " ! fakesink").c_str(), nullptr);
  ASSERT_NE(p, nullptr);
  gst_element_set_state(p, GST_STATE_PLAYING);
  GstBus* bus = gst_element_get_bus(p);
  expect_eos(bus);
  GstElement* r = gst_bin_get_by_name(GST_BIN(p), "req");
  guint two = 0, planes = 0;
  g_object_get(r, "surface-two-plane-tiles", &two, "surface-planes", &planes, nullptr);
  std::printf("whole-view layer pairs: %u planes, %u two-plane tiles in the last request\n", planes,
              two);
  EXPECT_GT(two, 0u) << "no second planes: the pairs were not exercised";
  gst_object_unref(r);
  gst_object_unref(bus);
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(p);
  std::filesystem::remove(rig_path);
}

TEST_F(Gst, BadPropertiesGiveClearErrors) {
  std::string err;
  run("lfviewrequest num-buffers=1 ! fakesink", 1, nullptr, &err);
  EXPECT_NE(err.find("rig"), std::string::npos) << err;
  err.clear();
  run("lfviewrequest rig=" + rig_path_ + " focal-plane=sideways num-buffers=1 ! fakesink", 1,
      nullptr, &err);
  EXPECT_NE(err.find("settings"), std::string::npos) << err;
  err.clear();
  run("lfcamsrc rig=/nonexistent.json camera-id=0 num-buffers=1 ! fakesink", 1, nullptr, &err);
  EXPECT_FALSE(err.empty());
  err.clear();
  run("lfcamsrc rig=" + rig_path_ + " camera-id=999999 num-buffers=1 ! fakesink", 1, nullptr, &err);
  EXPECT_NE(err.find("camera"), std::string::npos) << err;
  // One bad value, one error (not its own and then GstBaseSrc's "Failed to
  // start"); a focal plane behind the cameras, a warning naming it.
  auto messages = [&](const std::string& desc, GstMessageType type, std::string* first) {
    GstElement* p = gst_parse_launch(desc.c_str(), nullptr);
    gst_element_set_state(p, GST_STATE_PLAYING);
    gst_element_get_state(p, nullptr, nullptr, 5 * GST_SECOND);
    g_usleep(200000);
    GstBus* bus = gst_element_get_bus(p);  // read before NULL, which flushes it
    int n = 0;
    while (GstMessage* m = gst_bus_pop_filtered(bus, type)) {
      const std::string t = testing_lf::take_error_debug(m);
      if (n++ == 0) *first = t;
    }
    gst_object_unref(bus);
    gst_element_set_state(p, GST_STATE_NULL);
    gst_object_unref(p);
    return n;
  };
  std::string text;
  EXPECT_EQ(messages("lfviewrequest rig=" + rig_path_ + " focal-plane=banana ! fakesink",
                     GST_MESSAGE_ERROR, &text),
            1);
  EXPECT_NE(text.find("'banana'"), std::string::npos) << text;
  EXPECT_EQ(messages("lfviewrequest rig=" + rig_path_ + " focal-plane=depth:-5 ! fakesink",
                     GST_MESSAGE_WARNING, &text),
            1);
  EXPECT_NE(text.find("'depth:-5' lies 5 rig units behind"), std::string::npos) << text;
  EXPECT_EQ(messages("lfviewrequest rig=" + rig_path_ + " focal-plane=depth:5 ! fakesink",
                     GST_MESSAGE_WARNING, &text),
            0);
}

TEST_F(Gst, MalformedRequestsAndFragmentsAreDroppedWithAWarning) {
  // Garbage view requests into lffragment, then a valid one.
  const lf::Rig rig = lf::load_rig(rig_path_);
  {
    const AppPipeline a(
        "appsrc name=in caps=application/x-lf-view-request format=time ! f.request lffragment "
        "rig=" +
        rig_path_ + " camera-id=" + std::to_string(rig.cameras[0].id) +
        " name=f ! appsink name=out sync=false  lfcamsrc rig=" + rig_path_ +
        " camera-id=" + std::to_string(rig.cameras[0].id) + " num-buffers=1 ! f.sink");
    ASSERT_NE(a.pipe, nullptr);
    GstElement *in = a.in, *out = a.out;
    std::vector<uint8_t> garbage(lf::kRequestSize, 0x41);
    std::memcpy(garbage.data(), "LFVR", 4);
    gst_app_src_push_buffer(GST_APP_SRC(in), gst_buffer_new_memdup(garbage.data(), garbage.size()));
    gst_app_src_push_buffer(GST_APP_SRC(in), gst_buffer_new_memdup("x", 1));
    lf::ViewRequest req;
    req.sequence = 7;
    req.view = lf::view_between_cameras(rig, rig.plane().origin, 160, 120);
    req.focal_plane = lf::FocalPlane::infinity();
    const auto good = lf::serialize_request(req);
    gst_app_src_push_buffer(GST_APP_SRC(in), gst_buffer_new_memdup(good.data(), good.size()));
    gst_app_src_end_of_stream(GST_APP_SRC(in));
    GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(out), 5 * GST_SECOND);
    ASSERT_NE(s, nullptr) << "the valid request after the malformed ones must be answered";
    GstMapInfo m;
    gst_buffer_map(gst_sample_get_buffer(s), &m, GST_MAP_READ);
    const lf::Fragment f = lf::parse_fragment(m.data, m.size);
    EXPECT_EQ(f.sequence, 7u);
    gst_buffer_unmap(gst_sample_get_buffer(s), &m);
    gst_sample_unref(s);
    int warnings = 0;
    GstBus* bus = gst_element_get_bus(a.pipe);
    while (GstMessage* msg = gst_bus_pop_filtered(bus, GST_MESSAGE_WARNING)) {
      ++warnings;
      gst_message_unref(msg);
    }
    EXPECT_EQ(warnings, 2);
    gst_object_unref(bus);
  }

  // Garbage fragments into lfcompositor next to real ones: output continues.
  std::vector<std::string> warns;
  const std::string desc =
      pipeline("num-buffers=3 width=160 height=120 focal-plane=param:-0.2") +
      " appsrc name=junk caps=application/x-lf-fragment,encoding=raw format=time ! comp.sink_9";
  GstElement* q = gst_parse_launch(desc.c_str(), nullptr);
  ASSERT_NE(q, nullptr);
  GstElement* junk = gst_bin_get_by_name(GST_BIN(q), "junk");
  GstElement* sink = gst_bin_get_by_name(GST_BIN(q), "out");
  gst_element_set_state(q, GST_STATE_PLAYING);
  for (int k = 0; k < 3; ++k) {
    GstBuffer* b = gst_buffer_new_memdup("LFFRgarbage-garbage-garbage", 27);
    GST_BUFFER_PTS(b) = k * GST_SECOND / 30;
    gst_app_src_push_buffer(GST_APP_SRC(junk), b);
  }
  gst_app_src_end_of_stream(GST_APP_SRC(junk));
  int frames = 0;
  while (GstSample* s2 = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 5 * GST_SECOND)) {
    ++frames;
    gst_sample_unref(s2);
    if (frames == 3) break;
  }
  EXPECT_EQ(frames, 3);
  gst_element_set_state(q, GST_STATE_NULL);
  gst_object_unref(junk);
  gst_object_unref(sink);
  gst_object_unref(q);
}

TEST_F(Gst, DeadCameraDoesNotStopLiveOutput) {
  // Live pipeline at 30 requests/s; after 10 frames camera 0's fragments
  // stop (valve). The compositor's deadline (latency 50 ms) keeps frames
  // coming, renormalised from the remaining cameras.
  GError* err = nullptr;
  const std::string desc = pipeline("width=160 height=120 focal-plane=param:-0.2 framerate=30/1",
                                    "", "latency=50000000", true);
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  ASSERT_NE(p, nullptr) << (err ? err->message : "");
  GstElement* sink = gst_bin_get_by_name(GST_BIN(p), "out");
  GstElement* valve = gst_bin_get_by_name(GST_BIN(p), "v0");
  gst_element_set_state(p, GST_STATE_PLAYING);
  std::vector<cv::Mat> before, after;
  const gint64 t0 = g_get_monotonic_time();
  while (g_get_monotonic_time() - t0 < 3 * G_USEC_PER_SEC && after.size() < 30) {
    GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 200 * GST_MSECOND);
    if (!s) continue;
    GstMapInfo m;
    gst_buffer_map(gst_sample_get_buffer(s), &m, GST_MAP_READ);
    cv::Mat f = cv::Mat(120, 160, CV_8UC4, m.data).clone();
    gst_buffer_unmap(gst_sample_get_buffer(s), &m);
    gst_sample_unref(s);
    if (before.size() < 10) {
      before.push_back(f);
      if (before.size() == 10) g_object_set(valve, "drop", TRUE, nullptr);
    } else {
      after.push_back(f);
    }
  }
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(valve);
  gst_object_unref(sink);
  gst_object_unref(p);
  ASSERT_EQ(before.size(), 10u);
  EXPECT_GE(after.size(), 30u) << "output must keep coming after a camera dies";
  // Where neighbours cover the region it stays filled (alpha 255).
  std::vector<cv::Mat> ch;
  cv::split(after.back(), ch);
  EXPECT_GT(cv::countNonZero(ch[3]), 0.95 * 160 * 120);
}

}  // namespace
