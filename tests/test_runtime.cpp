// Steering while playing (issue 14): view properties changed in PLAYING,
// the lf-view upstream event, events reaching only their viewer, several
// viewers sharing one set of cameras, and the compositor following a
// downstream size. Outputs are checked bit for bit against the offline
// renderer (lf::render_view) for the view that the settings describe.
#include <gst/app/gstappsink.h>
#include <gst/gst.h>
#include <gst/video/navigation.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "gst_init.h"
#include "helpers.h"
#include "lf/focus/focus.h"
#include "lf/geometry/rig_ops.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/datasets.h"
#include "lf/io/parse.h"
#include "lf/io/rig_file.h"
#include "lf/render/render_view.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"

namespace {

using testing_lf::data_path;

// Requests seen on an lfviewrequest's src pad, by (viewer, sequence).
struct Seen {
  std::mutex m;
  std::map<std::pair<uint32_t, uint64_t>, lf::ViewRequest> reqs;
  uint64_t last = 0;
  static GstPadProbeReturn probe(GstPad*, GstPadProbeInfo* info, gpointer data) {
    auto* s = static_cast<Seen*>(data);
    auto add = [s](GstBuffer* b) {
      GstMapInfo m;
      gst_buffer_map(b, &m, GST_MAP_READ);
      const std::vector<lf::ViewRequest> rs = lf::parse_requests(m.data, m.size);
      gst_buffer_unmap(b, &m);
      std::lock_guard<std::mutex> l(s->m);
      for (const lf::ViewRequest& r : rs) {
        s->reqs[{r.viewer_id, r.sequence}] = r;
        s->last = std::max(s->last, r.sequence);
      }
    };
    if (info->type & GST_PAD_PROBE_TYPE_BUFFER) add(GST_PAD_PROBE_INFO_BUFFER(info));
    if (info->type & GST_PAD_PROBE_TYPE_BUFFER_LIST) {
      GstBufferList* l = GST_PAD_PROBE_INFO_BUFFER_LIST(info);
      for (guint i = 0; i < gst_buffer_list_length(l); ++i) add(gst_buffer_list_get(l, i));
    }
    return GST_PAD_PROBE_OK;
  }
  bool get(uint32_t viewer, uint64_t seq, lf::ViewRequest* r) {
    std::lock_guard<std::mutex> l(m);
    auto it = reqs.find({viewer, seq});
    if (it == reqs.end()) return false;
    *r = it->second;
    return true;
  }
  uint64_t newest() {
    std::lock_guard<std::mutex> l(m);
    return last;
  }
};

struct Frame {
  cv::Mat rgba;
  uint64_t sequence = 0;
};

// A running pipeline with request probes on every viewer.
struct Running {
  GstElement* p = nullptr;
  std::vector<GstElement*> reqs, sinks;
  Seen seen;
  std::vector<std::string> warnings;
  Running(const std::string& desc, int viewers) {
    GError* err = nullptr;
    p = gst_parse_launch(desc.c_str(), &err);
    EXPECT_NE(p, nullptr) << (err ? err->message : "");
    g_clear_error(&err);
    if (!p) return;
    for (int v = 0; v < viewers; ++v) {
      reqs.push_back(gst_bin_get_by_name(GST_BIN(p), ("req" + std::to_string(v)).c_str()));
      sinks.push_back(gst_bin_get_by_name(GST_BIN(p), ("out" + std::to_string(v)).c_str()));
      GstPad* pad = gst_element_get_static_pad(reqs.back(), "src");
      gst_pad_add_probe(
          pad,
          static_cast<GstPadProbeType>(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_BUFFER_LIST),
          Seen::probe, &seen, nullptr);
      gst_object_unref(pad);
    }
    gst_element_set_state(p, GST_STATE_PLAYING);
  }
  ~Running() {
    if (!p) return;
    gst_element_set_state(p, GST_STATE_NULL);
    for (GstElement* e : reqs) gst_object_unref(e);
    for (GstElement* e : sinks) gst_object_unref(e);
    gst_object_unref(p);
  }
  // Warnings posted so far.
  const std::vector<std::string>& bus_warnings() {
    GstBus* bus = gst_element_get_bus(p);
    while (GstMessage* msg = gst_bus_pop_filtered(bus, GST_MESSAGE_WARNING)) {
      GError* e = nullptr;
      gchar* dbg = nullptr;
      gst_message_parse_warning(msg, &e, &dbg);
      warnings.push_back(std::string(e->message) + ": " + (dbg ? dbg : ""));
      g_clear_error(&e);
      g_free(dbg);
      gst_message_unref(msg);
    }
    gst_object_unref(bus);
    return warnings;
  }
};

// What the test expects the view settings to be (mirrors the properties).
struct Expected {
  lf::ViewSettings vs;
  double s = 0, t = 0, w = 0;
  std::string focal = "infinity";
  double focal_depth = 0;
  lf::ViewRequest request(const lf::Rig& rig, uint64_t seq) const {
    lf::ViewRequest r;
    r.sequence = seq;
    r.view = lf::build_views(rig, vs).at(seq, rig, lf::camera_plane_offset(rig, s, t, w));
    r.focal_plane = focal_depth > 0 ? lf::plane_at_inverse_depth(rig, 1.0 / focal_depth)
                                    : lf::parse_focal_plane(focal, rig);
    return r;
  }
};

bool same_view(const lf::ViewRequest& a, const lf::ViewRequest& b) {
  const double tol = 1e-9;
  return cv::norm(a.view.position - b.view.position) < tol && cv::norm(a.view.R, b.view.R) < tol &&
         std::fabs(a.view.vfov_deg - b.view.vfov_deg) < tol &&
         std::fabs(a.view.shift_x - b.view.shift_x) < 1e-6 &&
         cv::norm(a.focal_plane.n - b.focal_plane.n) < tol &&
         std::fabs(a.focal_plane.d - b.focal_plane.d) < 1e-9 * (1 + std::fabs(b.focal_plane.d));
}

class Runtime : public ::testing::Test {
 protected:
  // Every test here renders the Chess cameras: skipped, by name, without them.
  void SetUp() override { LF_NEEDS_DATA("stanford-chess"); }
  static void SetUpTestSuite() {
    if (!testing_lf::have_data("stanford-chess")) return;
    testing_lf::init_gstreamer_with_plugin();
    // A 2x2 block of the real Chess light field at half resolution.
    rig_path_ = (std::filesystem::temp_directory_path() / "lf-test-runtime-chess4.json").string();
    rig_ = lf::scale_rig(
        lf::grid_block(lf::import_dataset(data_path("stanford-chess")), 3, 3, 2, 2), 0.5);
    lf::save_rig(rig_, rig_path_);
    rig_ = lf::load_rig(rig_path_);
    images_ = lf::load_images(rig_);
  }
  static std::string rig_path_;
  static lf::Rig rig_;
  static std::vector<cv::Mat> images_;

  // V viewers (lfviewrequest req<v> viewer-id=v -> funnel -> tee) share the
  // cameras; each camera's fragments go through lffragmentdemux ft<i> (its
  // pad src_<v> to compositor c<v> viewer-id=v ! appsink out<v>), or with
  // `tee` every fragment to every compositor. `props(v)` gives viewer v's
  // lfviewrequest properties.
  // The sinks do not preroll (async=false): a sink waiting in preroll would
  // stop its compositor while the other viewers' fragments queue up behind
  // its own in the shared fragment streams.
  static std::string pipeline(int viewers, const std::function<std::string(int)>& props, bool live,
                              const std::string& sink_caps = "format=RGBA", bool tee = false) {
    std::string d = "funnel name=reqs ! tee name=t";
    for (int v = 0; v < viewers; ++v) {
      // The paper's focal plane (the outputs are compared with lf-render
      // of the requests), unless props(v) sets focal-surface.
      d += " lfviewrequest name=req" + std::to_string(v) + " rig=" + rig_path_ +
           " viewer-id=" + std::to_string(v) + " focal-surface=false " + props(v) +
           (live ? " is-live=true" : "") + " ! reqs.";
      // Live: complete frames leave at once; the deadline (300 ms instead
      // of one 33 ms period) is only for fragments late on a busy machine,
      // which would otherwise be composited without them.
      d += " lfcompositor name=c" + std::to_string(v) + " rig=" + rig_path_ +
           " viewer-id=" + std::to_string(v) + (live ? " latency=300000000" : "") +
           " ! video/x-raw," + sink_caps + " ! appsink name=out" + std::to_string(v) +
           " sync=false async=false max-buffers=64";
    }
    for (size_t i = 0; i < rig_.cameras.size(); ++i) {
      const std::string id = std::to_string(rig_.cameras[i].id), n = std::to_string(i);
      d += " lfcamsrc rig=" + rig_path_ + " camera-id=" + id +
           (live ? " is-live=true framerate=30/1" : " num-buffers=1") + " ! f" + n + ".sink";
      d += " t. ! queue ! lffragment name=f" + n + " rig=" + rig_path_ + " camera-id=" + id +
           (tee ? " ! tee name=ft" : " ! lffragmentdemux name=ft") + n;
      for (int v = 0; v < viewers; ++v)
        d += " ft" + n + (tee ? "." : ".src_" + std::to_string(v)) + " ! queue ! c" +
             std::to_string(v) + ".sink_" + n;
    }
    return d;
  }

  static bool pull(GstElement* sink, Frame* f, double seconds = 5) {
    GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(sink),
                                                static_cast<GstClockTime>(seconds * GST_SECOND));
    if (!s) return false;
    GstStructure* st = gst_caps_get_structure(gst_sample_get_caps(s), 0);
    int w = 0, h = 0;
    gst_structure_get_int(st, "width", &w);
    gst_structure_get_int(st, "height", &h);
    GstBuffer* b = gst_sample_get_buffer(s);
    GstMapInfo m;
    gst_buffer_map(b, &m, GST_MAP_READ);
    f->rgba = cv::Mat(h, w, CV_8UC4, m.data).clone();
    f->sequence = GST_BUFFER_OFFSET(b);
    gst_buffer_unmap(b, &m);
    gst_sample_unref(s);
    return true;
  }

  static cv::Mat render(const lf::ViewRequest& req) {
    cv::Mat ref = lf::render_view(rig_, images_, req);
    cv::cvtColor(ref, ref, cv::COLOR_BGRA2RGBA);
    return ref;
  }
  // Live viewers at 160x120, 30 requests/s (the steering tests).
  static std::string live_pipeline(int viewers) {
    return pipeline(
        viewers, [](int) { return std::string("width=160 height=120 framerate=30/1"); }, true);
  }
  // The first output of a request after `before` + 1 (one request may be in
  // flight when a setting changes) is the request `want` describes, and its
  // picture is lf-render's for that request, bit for bit.
  static void expect_next_output(Running& r, uint64_t before, const Expected& want,
                                 const std::string& what) {
    Frame f;
    for (int tries = 0; tries < 60; ++tries) {
      ASSERT_TRUE(pull(r.sinks[0], &f)) << what;
      if (f.sequence <= before + 1) continue;
      lf::ViewRequest got;
      ASSERT_TRUE(r.seen.get(0, f.sequence, &got)) << what;
      const lf::ViewRequest exp = want.request(rig_, f.sequence);
      EXPECT_TRUE(same_view(got, exp)) << what << ": request " << f.sequence;
      // The picture is lf-render's for its request, bit for bit. A live
      // frame composited at the deadline without a fragment that a busy
      // machine delayed (by design; CI's sanitizer build, once) differs, so
      // up to 10 later outputs of the same settings may show it instead.
      int diff = differing(f.rgba, render(exp));
      for (int more = 0; diff != 0 && more < 10; ++more) {
        ASSERT_TRUE(pull(r.sinks[0], &f)) << what;
        diff = differing(f.rgba, render(want.request(rig_, f.sequence)));
      }
      EXPECT_EQ(diff, 0) << what << ": output != lf-render in 11 outputs";
      return;
    }
    ADD_FAILURE() << what << ": no output after request " << before + 1;
  }
  static int differing(const cv::Mat& a, const cv::Mat& b) {
    if (a.size() != b.size()) return -1;
    cv::Mat d;
    cv::absdiff(a, b, d);
    return cv::countNonZero(d.reshape(1));
  }
};
std::string Runtime::rig_path_;
lf::Rig Runtime::rig_;
std::vector<cv::Mat> Runtime::images_;

TEST_F(Runtime, ViewPropertiesAreMutableInPlayingAndTyped) {
  GstElement* e = gst_element_factory_make("lfviewrequest", nullptr);
  ASSERT_NE(e, nullptr);
  for (const char* name : {"position", "look-at", "eye-s", "eye-t", "eye-w", "vfov", "focal-plane",
                           "focal-depth", "stereo-baseline", "orbit", "dolly", "path"}) {
    GParamSpec* ps = g_object_class_find_property(G_OBJECT_GET_CLASS(e), name);
    ASSERT_NE(ps, nullptr) << name;
    EXPECT_TRUE(ps->flags & GST_PARAM_MUTABLE_PLAYING) << name;
  }
  for (const char* name : {"eye-s", "eye-t", "eye-w", "vfov", "focal-depth"}) {
    GParamSpec* ps = g_object_class_find_property(G_OBJECT_GET_CLASS(e), name);
    EXPECT_EQ(ps->value_type, G_TYPE_DOUBLE) << name;
    EXPECT_TRUE(ps->flags & GST_PARAM_CONTROLLABLE) << name;
  }
  EXPECT_EQ(g_object_class_find_property(G_OBJECT_GET_CLASS(e), "position")->value_type,
            GST_TYPE_ARRAY);
  // gst-launch syntax: position="<x, y, z>".
  gst_util_set_object_arg(G_OBJECT(e), "position", "<0.5, -1, 2>");
  GValue v = G_VALUE_INIT;
  g_value_init(&v, GST_TYPE_ARRAY);
  g_object_get_property(G_OBJECT(e), "position", &v);
  ASSERT_EQ(gst_value_array_get_size(&v), 3u);
  EXPECT_DOUBLE_EQ(g_value_get_double(gst_value_array_get_value(&v, 1)), -1.0);
  g_value_unset(&v);
  gst_object_unref(e);
}

TEST_F(Runtime, EveryViewPropertyChangedWhilePlayingReachesTheNextOutput) {
  Running r(live_pipeline(1), 1);
  ASSERT_NE(r.p, nullptr);
  GstElement* req = r.reqs[0];
  Expected want;
  want.vs.width = 160, want.vs.height = 120;
  const cv::Vec3d c = rig_.plane().origin;
  const double sp = rig_.typical_spacing();
  struct Step {
    const char* what;
    std::function<void()> set;
  };
  const cv::Vec3d eye = c + cv::Vec3d(0.3 * sp, -0.2 * sp, 0);
  const cv::Vec3d target = c + rig_.plane().normal * 40.0 * sp;
  std::vector<Step> steps = {
      {"position",
       [&] {
         gchar* s = g_strdup_printf("<%.17g, %.17g, %.17g>", eye[0], eye[1], eye[2]);
         gst_util_set_object_arg(G_OBJECT(req), "position", s);
         g_free(s);
         want.vs.position = eye;
       }},
      {"focal-plane",
       [&] {
         g_object_set(req, "focal-plane", "param:-0.2", nullptr);
         want.focal = "param:-0.2";
       }},
      {"eye-s",
       [&] {
         g_object_set(req, "eye-s", 0.1 * sp, nullptr);
         want.s = 0.1 * sp;
       }},
      {"eye-t",
       [&] {
         g_object_set(req, "eye-t", -0.15 * sp, nullptr);
         want.t = -0.15 * sp;
       }},
      {"eye-w",
       [&] {
         g_object_set(req, "eye-w", 2.0 * sp, nullptr);
         want.w = 2.0 * sp;
       }},
      {"focal-depth",
       [&] {
         g_object_set(req, "focal-depth", 30.0 * sp, nullptr);
         want.focal_depth = 30.0 * sp;
       }},
      {"look-at",
       [&] {
         gchar* s = g_strdup_printf("<%.17g, %.17g, %.17g>", target[0], target[1], target[2]);
         gst_util_set_object_arg(G_OBJECT(req), "look-at", s);
         g_free(s);
         want.vs.look_at = target;
       }},
      {"vfov",
       [&] {
         g_object_set(req, "vfov", 35.0, nullptr);
         want.vs.vfov_deg = 35.0;
       }},
  };
  Frame f;
  ASSERT_TRUE(pull(r.sinks[0], &f));
  for (const Step& step : steps) {
    const uint64_t before = r.seen.newest();
    step.set();
    expect_next_output(r, before, want, step.what);
  }
  // stereo-baseline: from the next tick, left and right eyes (viewer 0, 1).
  const uint64_t before = r.seen.newest();
  g_object_set(req, "stereo-baseline", 0.5 * sp, nullptr);
  // Up to 10 s, draining the sink meanwhile (frames queued there return at
  // once, so a count of pulls is no time bound), until both eyes' requests
  // of the third tick were seen: the right eye's leaves after the left's
  // (on a busy machine the left alone was once seen at the check).
  const gint64 end = g_get_monotonic_time() + 10 * G_USEC_PER_SEC;
  lf::ViewRequest left, right;
  auto both = [&] { return r.seen.get(0, before + 3, &left) && r.seen.get(1, before + 3, &right); };
  while (!both() && g_get_monotonic_time() < end) pull(r.sinks[0], &f, 0.1);
  ASSERT_TRUE(r.seen.get(0, before + 3, &left));
  ASSERT_TRUE(r.seen.get(1, before + 3, &right));
  EXPECT_NEAR(cv::norm(right.view.position - left.view.position), 0.5 * sp, 1e-9);
}

TEST_F(Runtime, ViewEventSetsTheWholeViewOnceAndRefusesBadFields) {
  Running r(live_pipeline(1), 1);
  ASSERT_NE(r.p, nullptr);
  Frame f;
  ASSERT_TRUE(pull(r.sinks[0], &f));
  const double sp = rig_.typical_spacing();
  const cv::Vec3d eye = rig_.plane().origin + cv::Vec3d(-0.25 * sp, 0.2 * sp, 0);
  // Sent at the sink (as an app or a remote viewer would), it travels up
  // through the compositor and all four camera branches.
  GValue pos = G_VALUE_INIT;
  gst_value_array_init(&pos, 3);
  for (int i = 0; i < 3; ++i) {
    GValue d = G_VALUE_INIT;
    g_value_init(&d, G_TYPE_DOUBLE);
    g_value_set_double(&d, eye[i]);
    gst_value_array_append_and_take_value(&pos, &d);
  }
  GstStructure* s = gst_structure_new("lf-view", "focal-depth", G_TYPE_DOUBLE, 25.0 * sp, "eye-w",
                                      G_TYPE_DOUBLE, 1.5 * sp, nullptr);
  gst_structure_take_value(s, "position", &pos);
  const uint64_t before = r.seen.newest();
  ASSERT_TRUE(
      gst_element_send_event(r.sinks[0], gst_event_new_custom(GST_EVENT_CUSTOM_UPSTREAM, s)));
  double depth = 0, w = 0;
  g_object_get(r.reqs[0], "focal-depth", &depth, "eye-w", &w, nullptr);
  EXPECT_DOUBLE_EQ(depth, 25.0 * sp);
  EXPECT_DOUBLE_EQ(w, 1.5 * sp);  // once, not once per camera branch
  Expected want;
  want.vs.width = 160, want.vs.height = 120;
  want.vs.position = eye;
  want.w = 1.5 * sp;
  want.focal_depth = 25.0 * sp;
  // The first request after the event has all of its fields (they are
  // applied under one lock).
  expect_next_output(r, before, want, "lf-view event");
  // Bad events: refused whole, with a warning; nothing changes.
  const double nan = std::nan("");
  for (GstStructure* bad : {gst_structure_new("lf-view", "eye-s", G_TYPE_DOUBLE, 0.1, "eye-t",
                                              G_TYPE_DOUBLE, nan, nullptr),
                            gst_structure_new("lf-view", "eye-s", G_TYPE_DOUBLE, 0.1, "zoom",
                                              G_TYPE_DOUBLE, 2.0, nullptr),
                            gst_structure_new("lf-view", "vfov", G_TYPE_DOUBLE, 500.0, nullptr),
                            gst_structure_new("lf-view", "eye-s", G_TYPE_STRING, "left", nullptr),
                            gst_structure_new("lf-view", "width", G_TYPE_INT, 9999, nullptr)}) {
    gst_element_send_event(r.sinks[0], gst_event_new_custom(GST_EVENT_CUSTOM_UPSTREAM, bad));
  }
  double s_now = 1, vfov = 1;
  int width = 0;
  g_object_get(r.reqs[0], "eye-s", &s_now, "vfov", &vfov, "width", &width, nullptr);
  EXPECT_EQ(s_now, 0.0);
  EXPECT_EQ(vfov, 0.0);
  EXPECT_EQ(width, 160);
  int refused = 0;
  for (const std::string& w2 : r.bus_warnings())
    if (w2.find("lf-view") != std::string::npos) ++refused;
  EXPECT_EQ(refused, 5);
}

TEST_F(Runtime, EventsSteerOnlyTheViewerWhoseSinkTheyEnter) {
  Running r(live_pipeline(2), 2);
  ASSERT_NE(r.p, nullptr);
  Frame f;
  ASSERT_TRUE(pull(r.sinks[1], &f));
  // A key at viewer 1's sink moves viewer 1's eye, not viewer 0's.
  gst_element_send_event(r.sinks[1],
                         gst_navigation_event_new_key_press("Prior", GST_NAVIGATION_MODIFIER_NONE));
  gst_element_send_event(
      r.sinks[1], gst_event_new_custom(
                      GST_EVENT_CUSTOM_UPSTREAM,
                      gst_structure_new("lf-view", "focal-depth", G_TYPE_DOUBLE, 7.0, nullptr)));
  double w0 = 0, w1 = 0, d0 = 0, d1 = 0;
  g_object_get(r.reqs[0], "eye-w", &w0, "focal-depth", &d0, nullptr);
  g_object_get(r.reqs[1], "eye-w", &w1, "focal-depth", &d1, nullptr);
  EXPECT_EQ(w0, 0.0);
  EXPECT_EQ(d0, 0.0);
  EXPECT_NEAR(w1, rig_.typical_spacing(), 1e-12);  // Prior = Page_Up: one spacing forward
  EXPECT_EQ(d1, 7.0);
}

TEST_F(Runtime, NavigationKeepsTheEyeOverTheArrayAndTakesXSinkNames) {
  Running r(live_pipeline(1), 1);
  ASSERT_NE(r.p, nullptr);
  Frame f;
  ASSERT_TRUE(pull(r.sinks[0], &f));
  // Drag 4000 px right: 100 spacings; the eye stops at the array's edge.
  GstElement* sink = r.sinks[0];
  const auto none = GST_NAVIGATION_MODIFIER_NONE;
  gst_element_send_event(sink, gst_navigation_event_new_mouse_button_press(1, 10, 60, none));
  gst_element_send_event(sink, gst_navigation_event_new_mouse_move(4010, 60, none));
  gst_element_send_event(sink, gst_navigation_event_new_mouse_button_release(1, 4010, 60, none));
  double s = 0, t = 0;
  g_object_get(r.reqs[0], "eye-s", &s, "eye-t", &t, nullptr);
  // Just inside the cameras' hull, at its boundary.
  std::vector<cv::Point2f> pts, hull;
  for (const cv::Vec2d& p : rig_.plane_positions()) pts.emplace_back(p[0], p[1]);
  cv::convexHull(pts, hull);
  const double inside = cv::pointPolygonTest(hull, cv::Point2f(s, t), true);
  EXPECT_GT(inside, 0.0);
  EXPECT_LT(inside, 2e-3 * rig_.typical_spacing());
  // The output is not black with the eye at the array's edge.
  const uint64_t dragged = r.seen.newest();
  do ASSERT_TRUE(pull(sink, &f));
  while (f.sequence <= dragged + 1);
  cv::Mat grey;
  cv::cvtColor(f.rgba, grey, cv::COLOR_RGBA2GRAY);
  EXPECT_GT(cv::countNonZero(grey), grey.total() * 99 / 100);
  // ximagesink's wheel: button 4 (nearer focal plane), then 5 (back).
  gst_element_send_event(sink, gst_navigation_event_new_mouse_button_press(4, 80, 60, none));
  double depth = 0;
  g_object_get(r.reqs[0], "focal-depth", &depth, nullptr);
  const double q = 0.25 / (rig_.cameras[0].intrinsics.fx * rig_.typical_spacing());
  EXPECT_NEAR(1.0 / depth, q, 1e-9 * q);
  // "equal" (the + key without shift on X) and "Next" move along the normal.
  gst_element_send_event(sink, gst_navigation_event_new_key_press("equal", none));
  gst_element_send_event(sink, gst_navigation_event_new_key_press("equal", none));
  gst_element_send_event(sink, gst_navigation_event_new_key_press("Next", none));
  double w = 0;
  g_object_get(r.reqs[0], "eye-w", &w, nullptr);
  EXPECT_NEAR(w, rig_.typical_spacing(), 1e-12);
}

TEST_F(Runtime, ViewersShareTheCamerasAndEachEqualsItsSingleViewerOutput) {
  const double sp = rig_.typical_spacing();
  auto props = [&](int v) {
    const cv::Vec3d eye = rig_.plane().origin + rig_.plane().u * (0.1 * sp * (v % 4 - 1.5)) +
                          rig_.plane().v * (0.1 * sp * (v / 4));
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "width=160 height=120 num-buffers=3 focal-plane=param:-0.2 "
                  "position=\"<%.17g,%.17g,%.17g>\"",
                  eye[0], eye[1], eye[2]);
    return std::string(buf);
  };
  // Reference: each viewer alone (viewer id v, its own pipeline).
  std::vector<std::vector<cv::Mat>> alone(8);
  for (int v = 0; v < 8; ++v) {
    Running r(pipeline(
                  1, [&](int) { return props(v); }, false),
              1);
    Frame f;
    while (pull(r.sinks[0], &f, 2)) alone[v].push_back(f.rgba);
    ASSERT_EQ(alone[v].size(), 3u) << "viewer " << v;
    lf::ViewRequest req;
    ASSERT_TRUE(r.seen.get(0, 0, &req));
    EXPECT_EQ(differing(alone[v][0], render(req)), 0) << "viewer " << v;
  }
  for (int viewers : {1, 2, 4, 8}) {
    Running r(pipeline(viewers, props, false), viewers);
    for (int v = 0; v < viewers; ++v) {
      std::vector<cv::Mat> got;
      Frame f;
      while (got.size() < 3 && pull(r.sinks[v], &f, 5)) got.push_back(f.rgba);
      ASSERT_EQ(got.size(), 3u) << viewers << " viewers, viewer " << v;
      for (size_t k = 0; k < 3; ++k)
        EXPECT_EQ(differing(got[k], alone[v][k]), 0) << viewers << " viewers, viewer " << v;
    }
    // Each camera's demuxer sent every fragment to its viewer's pad only:
    // 3 requests per viewer, none unrouted.
    for (size_t i = 0; i < rig_.cameras.size(); ++i) {
      GstElement* d = gst_bin_get_by_name(GST_BIN(r.p), ("ft" + std::to_string(i)).c_str());
      ASSERT_NE(d, nullptr);
      guint64 routed = 0, unrouted = 0;
      g_object_get(d, "routed", &routed, "unrouted", &unrouted, nullptr);
      gst_object_unref(d);
      EXPECT_EQ(routed, 3u * viewers) << "camera " << i << ", " << viewers << " viewers";
      EXPECT_EQ(unrouted, 0u) << "camera " << i;
    }
  }
}

TEST_F(Runtime, CompositorFollowsADownstreamSize) {
  std::string desc = pipeline(
      1,
      [](int) { return std::string("width=160 height=120 num-buffers=2 focal-plane=param:-0.2"); },
      false, "format=RGBA,width=80,height=60");
  Running r(desc, 1);
  Frame f;
  ASSERT_TRUE(pull(r.sinks[0], &f));
  ASSERT_EQ(f.rgba.cols, 80);
  ASSERT_EQ(f.rgba.rows, 60);
  lf::ViewRequest req;
  ASSERT_TRUE(r.seen.get(0, f.sequence, &req));
  cv::Mat ref;
  cv::resize(render(req), ref, cv::Size(80, 60), 0, 0, cv::INTER_AREA);
  cv::Mat d;
  cv::absdiff(f.rgba, ref, d);
  const cv::Scalar mad = cv::mean(d);
  EXPECT_LT((mad[0] + mad[1] + mad[2]) / 3, 4.0);  // scaler vs area resampling
}

TEST_F(Runtime, CompositorWarnsWhenItsViewerNeverComes) {
  // Requests of viewer 0, compositor waiting for viewer 5 (every fragment
  // reaches it through a tee).
  std::string desc = pipeline(
      1, [](int) { return std::string("width=80 height=60 framerate=30/1"); }, true, "format=RGBA",
      true);
  desc.replace(desc.find("name=c0 rig=" + rig_path_ + " viewer-id=0"),
               std::string("name=c0 rig=" + rig_path_ + " viewer-id=0").size(),
               "name=c0 rig=" + rig_path_ + " viewer-id=5");
  Running r(desc, 1);
  bool warned = false;
  // The warning comes after 2 s of other viewers' fragments; up to 10 s
  // allowed on a busy machine.
  for (int k = 0; k < 200 && !warned; ++k) {
    g_usleep(50000);
    for (const std::string& w : r.bus_warnings())
      warned |= w.find("No fragments of viewer 5") != std::string::npos;
  }
  EXPECT_TRUE(warned);
}

}  // namespace

namespace {

TEST_F(Runtime, BinsBuildTheSameGraphAsTheHandBuiltOne) {
  const std::string req =
      "lfviewrequest name=req0 rig=" + rig_path_ + " width=160 height=120 num-buffers=3 orbit=0.3";
  std::vector<cv::Mat> hand, array, hosts;
  {
    Running r(
        pipeline(
            1,
            [](int) {
              return std::string("width=160 height=120 num-buffers=3 orbit=0.3 focal-surface=true");
            },
            false),
        1);
    Frame f;
    while (pull(r.sinks[0], &f, 5)) hand.push_back(f.rgba);
  }
  {
    // The one-machine array: requests in, video out.
    Running r(req + " ! lfarray rig=" + rig_path_ +
                  " num-buffers=1 ! video/x-raw,format=RGBA ! appsink name=out0 sync=false",
              1);
    Frame f;
    while (pull(r.sinks[0], &f, 5)) array.push_back(f.rgba);
  }
  {
    // Two camera hosts (cameras 0-1 and 2-3), each one fragment stream.
    Running r(req + " ! tee name=t lfcompositor name=c rig=" + rig_path_ +
                  " ! video/x-raw,format=RGBA ! appsink name=out0 sync=false"
                  " t. ! queue ! lfcamerahost rig=" +
                  rig_path_ +
                  " cameras=0-1 num-buffers=1 ! c.sink_0"
                  " t. ! queue ! lfcamerahost rig=" +
                  rig_path_ + " cameras=2,3 num-buffers=1 ! c.sink_1",
              1);
    Frame f;
    while (pull(r.sinks[0], &f, 5)) hosts.push_back(f.rgba);
  }
  ASSERT_EQ(hand.size(), 3u);
  ASSERT_EQ(array.size(), 3u);
  ASSERT_EQ(hosts.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(differing(array[k], hand[k]), 0) << "lfarray, frame " << k;
    EXPECT_EQ(differing(hosts[k], hand[k]), 0) << "lfcamerahost, frame " << k;
  }
  // A bad camera list is a clear error when the pipeline starts.
  GstElement* p = gst_parse_launch(
      ("lfviewrequest rig=" + rig_path_ + " ! lfarray rig=" + rig_path_ + " cameras=0-9 ! fakesink")
          .c_str(),
      nullptr);
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(gst_element_set_state(p, GST_STATE_PLAYING), GST_STATE_CHANGE_FAILURE);
  GstBus* bus = gst_element_get_bus(p);
  GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR);
  ASSERT_NE(m, nullptr);
  const std::string dbg = testing_lf::take_error_debug(m);
  EXPECT_NE(dbg.find("'9' is not an index in 0..3"), std::string::npos) << dbg;
  gst_object_unref(bus);
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(p);
}

}  // namespace

namespace {

// A live camera host drops a request as stale once a request of the same
// viewer request-max-age newer waits behind it (lfrequestqueue, the viewers
// in turn); lfarray waits at least as long as its compositor does (a
// shorter bound dropped requests that its compositor still waited for: a
// recording played back on a busy machine then lost cameras from frames).
// Every live host has one request queue for all cameras (request-queue,
// before the tee), so a request is answered by every camera or dropped by
// all; where each camera has a request thread of its own (live cameras,
// not lfarray's whole-view mode), a queue per camera (requests<id>) holds
// one request and blocks. (Before, each camera had its own lfrequestqueue
// and shed alone.)
TEST_F(Runtime, LiveRequestQueuesAreBoundedByTheRequestMaxAge) {
  struct Case {
    std::string element;
    std::string props;
    guint64 expected_ns;
    int camera_queues;
  };
  const int threads = 4;  // live cameras: one each, whatever request-threads says
  const Case cases[] = {
      {"lfcamerahost", "", 0, threads},  // the default: the newest request wins
      {"lfcamerahost", "request-max-age=50000000", 50 * GST_MSECOND, threads},
      {"lfarray", "", 0, 0},
      {"lfarray", "whole-view=false", 0, threads},
      {"lfarray", "whole-view=false request-threads=2", 0, 4},
      {"lfarray", "encoding=jpeg request-max-age=200000000", 200 * GST_MSECOND, threads},
      {"lfarray", "latency=3000000000", 3 * GST_SECOND, 0},
      {"lfarray", "latency=10000000 request-max-age=400000000", 400 * GST_MSECOND, 0},
      {"lfarray", "whole-view=false latency=10000000 request-max-age=400000000", 400 * GST_MSECOND,
       threads}};
  for (const Case& c : cases) {
    GstElement* e = gst_parse_launch(
        (c.element + " name=h rig=" + rig_path_ + " is-live=true " + c.props).c_str(), nullptr);
    ASSERT_NE(e, nullptr);
    ASSERT_NE(gst_element_set_state(e, GST_STATE_READY), GST_STATE_CHANGE_FAILURE);
    // One lfrequestqueue for all, request-queue; the cameras' queues are
    // named requests<camera id> (the tee is `requests`).
    int shared = 0, camera_queues = 0;
    GstIterator* it = gst_bin_iterate_elements(GST_BIN(e));
    GValue item = G_VALUE_INIT;
    while (gst_iterator_next(it, &item) == GST_ITERATOR_OK) {
      GstElement* q = GST_ELEMENT(g_value_get_object(&item));
      const std::string name = GST_OBJECT_NAME(q);
      if (name == "request-queue") {
        ++shared;
        EXPECT_STREQ(G_OBJECT_TYPE_NAME(q), "LfRequestQueue") << name;
        guint64 max_age = 0;
        g_object_get(q, "max-age", &max_age, nullptr);
        EXPECT_EQ(max_age, c.expected_ns) << c.element << " " << c.props << " " << name;
      } else if (name.rfind("requests", 0) == 0 && name != "requests") {
        ++camera_queues;
        EXPECT_STREQ(G_OBJECT_TYPE_NAME(q), "GstQueue") << name;
        guint buffers = 0;
        g_object_get(q, "max-size-buffers", &buffers, nullptr);
        EXPECT_EQ(buffers, 1u) << c.element << " " << c.props << " " << name;
      }
      g_value_reset(&item);
    }
    g_value_unset(&item);
    gst_iterator_free(it);
    EXPECT_EQ(shared, 1) << c.element << " " << c.props;
    EXPECT_EQ(camera_queues, c.camera_queues) << c.element << " " << c.props;
    gst_element_set_state(e, GST_STATE_NULL);
    gst_object_unref(e);
  }
}

}  // namespace

namespace {

// Request -> frame latency of a live pipeline: each request's time as it
// leaves lfviewrequest (by sequence) against its frame's at the sink.
struct Latency {
  std::mutex m;
  std::map<guint64, gint64> sent;
  std::vector<double> ms;
  std::vector<std::pair<gint64, gint64>> matched;  // (request sent, its frame out), µs
  std::vector<gint64> out;                         // every frame out, µs
  static GstPadProbeReturn request(GstPad*, GstPadProbeInfo* info, gpointer data) {
    auto* l = static_cast<Latency*>(data);
    std::lock_guard<std::mutex> lock(l->m);
    l->sent[GST_BUFFER_OFFSET(GST_PAD_PROBE_INFO_BUFFER(info))] = g_get_monotonic_time();
    return GST_PAD_PROBE_OK;
  }
  static GstPadProbeReturn frame(GstPad*, GstPadProbeInfo* info, gpointer data) {
    auto* l = static_cast<Latency*>(data);
    const gint64 now = g_get_monotonic_time();
    std::lock_guard<std::mutex> lock(l->m);
    l->out.push_back(now);
    auto it = l->sent.find(GST_BUFFER_OFFSET(GST_PAD_PROBE_INFO_BUFFER(info)));
    if (it != l->sent.end()) {
      l->ms.push_back((now - it->second) / 1000.0);
      l->matched.emplace_back(it->second, now);
    }
    return GST_PAD_PROBE_OK;
  }
  // For each matched frame from the `first`th on, how many other frames
  // came out between its request and itself: the work it waited behind,
  // in frames, which a busy machine's stretched periods do not change.
  std::vector<int> frames_behind(size_t first) const {
    std::vector<int> n;
    for (size_t i = first; i < matched.size(); ++i) {
      const gint64 sent = matched[i].first, done = matched[i].second;
      n.push_back(static_cast<int>(
          std::count_if(out.begin(), out.end(), [&](gint64 t) { return t > sent && t < done; })));
    }
    std::sort(n.begin(), n.end());
    return n;
  }
};

}  // namespace

// Issue 38: when the host cannot keep the rate asked for, the newest
// request wins: the compositor composites the newest complete request, not
// each stale one in turn behind it, so a viewer's latency stays within a
// few frame periods of the rate achieved. 4K requests at 120 a second, with
// two busy threads beside the pipeline: more than this machine composites.
// lfarray's own deadline (adaptive-deadline), as a user gets it: with a
// fixed latency=100 ms, as this test once set, the compositor's live pads
// (GstAggregator queues up to its latency) keep 100 ms of requests, 1.5
// periods at 15 fps, and p95 reached 3.8-4.1 periods.
//
// The bound is in frames: how many other frames came out while a request
// waited for its own (the work it waited behind). A period of the average
// rate was the unit before, and a p95 in time failed once in a CI run with
// a neighbour's bursts (4.4 periods, bound 4; 2.0-2.95 alone): a busy
// machine stretches single frames, not the number a request waits behind.
// Measured on a 2-core Intel Xeon VM: 10.4-10.6 fps alone, median 1 frame,
// p95 2, at most 2 (in time: median 1.9-2.0 periods, p95 2.9); beside two
// more busy loops 6.5-6.9 fps, median 1, p95 1, at most 2 (3 runs each).
// Queueing (shed_stale() a no-op, request-max-age=2 s): median 4, p95 5
// frames, in time 4.7 and 5.8 periods; it fails both frame bounds (2 and
// 3), the median in time (3 periods) and `stale`. 480 requests: with 240,
// at 15 fps the run ended within 3 s and measured mostly the pipeline
// filling.
TEST_F(Runtime, ALiveCompositorBehindTheRequestsShedsStaleOnes) {
#ifdef LF_TEST_ASAN
  // The sanitizer build composites several times slower: 4K gave 9 frames
  // in 30 s. A smaller view, for as many frames (7-9 fps alone).
  const std::string size = "width=1280 height=720 num-buffers=240";
#else
  const std::string size = "width=3840 height=2160 num-buffers=480";
#endif
  const std::string desc =
      "lfviewrequest name=req rig=" + rig_path_ + " " + size +
      " framerate=120/1 is-live=true focal-surface=false"
      " orbit=0.5 ! lfarray name=h rig=" +
      rig_path_ + " max-rate=0 max-pixel-rate=0 ! appsink name=out sync=false max-buffers=4";
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  ASSERT_NE(p, nullptr) << (err ? err->message : "");
  Latency lat;
  GstElement* req = gst_bin_get_by_name(GST_BIN(p), "req");
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  GstPad* rp = gst_element_get_static_pad(req, "src");
  gst_pad_add_probe(rp, GST_PAD_PROBE_TYPE_BUFFER, Latency::request, &lat, nullptr);
  GstPad* op = gst_element_get_static_pad(out, "sink");
  gst_pad_add_probe(op, GST_PAD_PROBE_TYPE_BUFFER, Latency::frame, &lat, nullptr);
  gst_object_unref(rp);
  gst_object_unref(op);
  std::atomic<bool> stop{false};
  std::vector<std::thread> hogs;
  for (int i = 0; i < 2; ++i)
    hogs.emplace_back([&] {
      volatile double x = 1;
      while (!stop) x = x * 1.0000001 + 1e-9;
    });
  gst_element_set_state(p, GST_STATE_PLAYING);
  std::vector<gint64> arrivals;
  while (true) {
    GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(out), 10 * GST_SECOND);
    if (!s) break;
    arrivals.push_back(g_get_monotonic_time());
    gst_sample_unref(s);
  }
  stop = true;
  for (auto& t : hogs) t.join();
  guint64 stale = 0;
  GstBus* bus = gst_element_get_bus(p);
  while (GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_ELEMENT)) {
    const GstStructure* st = gst_message_get_structure(m);
    if (gst_structure_has_name(st, "lf-rate")) gst_structure_get_uint64(st, "stale", &stale);
    gst_message_unref(m);
  }
  gst_object_unref(bus);
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(req);
  gst_object_unref(out);
  gst_object_unref(p);
  ASSERT_GT(arrivals.size(), 20u);
  // The rate achieved after the first quarter, and the latencies then.
  const size_t q = arrivals.size() / 4;
  const double fps = (arrivals.size() - 1 - q) / ((arrivals.back() - arrivals[q]) / 1e6);
  std::vector<double> ms(lat.ms.begin() + static_cast<long>(std::min(q, lat.ms.size())),
                         lat.ms.end());
  ASSERT_GT(ms.size(), 10u) << "frames not matched to their requests";
  std::sort(ms.begin(), ms.end());
  const double median = ms[ms.size() / 2], p95 = ms[ms.size() * 95 / 100];
  const double period = 1000.0 / fps;
  const std::vector<int> behind = lat.frames_behind(std::min(q, lat.matched.size()));
  const int behind_median = behind[behind.size() / 2],
            behind_p95 = behind[behind.size() * 95 / 100];
  std::printf(
      "%zu frames, %.1f fps: latency median %.1f ms, p95 %.1f ms "
      "(period %.1f ms; %.1f and %.1f periods); frames out while a request waited: median %d, "
      "p95 %d, most %d; %" G_GUINT64_FORMAT " stale requests dropped\n",
      arrivals.size(), fps, median, p95, period, median / period, p95 / period, behind_median,
      behind_p95, behind.back(), stale);
  EXPECT_LT(fps, 110) << "the machine kept the rate: nothing was shed, nothing is tested";
  EXPECT_GT(stale, 0u);
  EXPECT_LE(median, 3 * period);
  EXPECT_LE(behind_median, 2);
  EXPECT_LE(behind_p95, 3);
}
