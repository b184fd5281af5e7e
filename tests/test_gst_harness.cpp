// GstHarness tests of each element on its own: caps, properties, bad input.
#include <gst/check/gstharness.h>
#include <gst/gst.h>
#include <gst/video/navigation.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "gst_init.h"
#include "lf/focus/focus.h"
#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/parse.h"
#include "lf/io/rig_file.h"
#include "lf/quality/quality.h"
#include "lf/quality/synthetic.h"
#include "lf/render/composite.h"
#include "lf/render/fragment.h"
#include "lf/render/gl_render.h"
#include "lf/render/render.h"
#include "lf/render/render_view.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"
#include "lfevents.h"
#include "lfmemory.h"
#include "lfrate.h"
#include "lfrig.h"

namespace {

class Harness : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    testing_lf::init_gstreamer_with_plugin();
    rig_ = lf::synthetic_grid_rig(2, 2, 0.05, 64, 48, 40);
    // One file a process: gst_harness_nogl runs this binary beside gst_harness
    // (a shared name was rewritten while the other read it: a failed start).
    rig_path_ = (std::filesystem::temp_directory_path() /
                 ("lf-harness-rig-" + std::to_string(getpid()) + ".json"))
                    .string();
    lf::save_rig(rig_, rig_path_);
  }
  static void TearDownTestSuite() { std::filesystem::remove(rig_path_); }
  static lf::Rig rig_;
  static std::string rig_path_;

  // The request / fragment a buffer carries (the buffer stays the caller's).
  template <typename T>
  static T parsed(GstBuffer* b, T (*parse)(const uint8_t*, size_t)) {
    GstMapInfo map;
    EXPECT_TRUE(gst_buffer_map(b, &map, GST_MAP_READ));
    T out = parse(map.data, map.size);
    gst_buffer_unmap(b, &map);
    return out;
  }
  static lf::ViewRequest parsed_request(GstBuffer* b) { return parsed(b, lf::parse_request); }
  // A request buffer's requests: one, or a probe's steps (lf/wire/probe_bundle.h).
  static std::vector<lf::ViewRequest> parsed_requests(GstBuffer* b) {
    return parsed<std::vector<lf::ViewRequest>>(
        b, [](const uint8_t* d, size_t n) { return lf::parse_requests(d, n); });
  }
  static lf::Fragment parsed_fragment(GstBuffer* b) {
    return parsed<lf::Fragment>(
        b, [](const uint8_t* d, size_t n) { return lf::parse_fragment(d, n); });
  }
  static lf::ViewRequest request(uint64_t seq) {
    lf::ViewRequest r;
    r.viewer_id = 3;
    r.sequence = seq;
    r.view =
        lf::view_between_cameras(rig_, rig_.plane().origin + cv::Vec3d(0.01, 0.005, 0), 80, 60);
    r.focal_plane = lf::plane_at_depth(rig_, 1.25);
    return r;
  }
  // An lffragment of camera 1 whose camera sent one frame of the synthetic
  // scene (PTS 123, returned in *frame): the harness of its request pad,
  // with request caps set, and that of its camera pad in *video.
  // `backend`: the element's backend property (auto when null).
  static GstHarness* camera1_fragment(GstHarness** video, cv::Mat* frame,
                                      const char* backend = nullptr) {
    // Configure first: the harness sets its element playing when it is made.
    GstElement* el = gst_element_factory_make("lffragment", nullptr);
    g_object_set(el, "rig", rig_path_.c_str(), "camera-id", 1, nullptr);
    if (backend) gst_util_set_object_arg(G_OBJECT(el), "backend", backend);
    GstHarness* h = gst_harness_new_with_element(el, "request", "src");
    *video = gst_harness_new_with_element(el, "sink", nullptr);
    gst_object_unref(el);
    gst_harness_set_src_caps_str(*video,
                                 "video/x-raw,format=RGBA,width=64,height=48,framerate=30/1");
    *frame = lf::SyntheticScene::for_rig(rig_).render(rig_.cameras[1], 0.0);
    GstBuffer* fb = gst_buffer_new_memdup(frame->data, frame->total() * 4);
    GST_BUFFER_PTS(fb) = 123;
    EXPECT_EQ(gst_harness_push(*video, fb), GST_FLOW_OK);
    gst_harness_set_src_caps_str(h, "application/x-lf-view-request");
    return h;
  }
  // A non-live lfcompositor of viewer 3 over the rig of camera `index`
  // alone, fed raw 80x60 fragments on sink_0.
  static GstHarness* one_camera_compositor(int index, const char* file) {
    const lf::Rig one = rig_.subset({index});
    const std::string path = (std::filesystem::temp_directory_path() / file).string();
    lf::save_rig(one, path);
    GstElement* el = gst_element_factory_make("lfcompositor", nullptr);
    g_object_set(el, "rig", path.c_str(), "viewer-id", 3, nullptr);
    GstHarness* h = gst_harness_new_with_element(el, "sink_0", "src");
    gst_object_unref(el);
    gst_harness_set_live(h, FALSE);
    gst_harness_set_src_caps_str(h, "application/x-lf-fragment,encoding=raw,width=80,height=60");
    return h;
  }
  static GstBuffer* bytes(const std::vector<uint8_t>& b, GstClockTime pts) {
    GstBuffer* buf = gst_buffer_new_memdup(b.data(), b.size());
    GST_BUFFER_PTS(buf) = pts;
    GST_BUFFER_DURATION(buf) = GST_SECOND / 30;
    return buf;
  }
};
lf::Rig Harness::rig_;
std::string Harness::rig_path_;

TEST_F(Harness, CamSrcCapsAndCaptureTime) {
  GstHarness* h = gst_harness_new("lfcamsrc");
  g_object_set(h->element, "rig", rig_path_.c_str(), "camera-id", 2, "mode", 1, "framerate", 30, 1,
               "phase", static_cast<guint64>(5 * GST_MSECOND), nullptr);
  gst_harness_play(h);
  GstBuffer* b0 = gst_harness_pull(h);
  GstBuffer* b1 = gst_harness_pull(h);
  ASSERT_NE(b1, nullptr);
  GstCaps* caps = gst_pad_get_current_caps(h->sinkpad);
  GstStructure* s = gst_caps_get_structure(caps, 0);
  int w = 0, hh = 0;
  gst_structure_get_int(s, "width", &w);
  gst_structure_get_int(s, "height", &hh);
  EXPECT_STREQ(gst_structure_get_string(s, "format"), "RGBA");
  EXPECT_EQ(w, 64);
  EXPECT_EQ(hh, 48);
  // Capture schedule: k * period + phase.
  EXPECT_EQ(GST_BUFFER_PTS(b0), 5 * GST_MSECOND);
  EXPECT_EQ(GST_BUFFER_PTS(b1), GST_SECOND / 30 + 5 * GST_MSECOND);
  GstCustomMeta* m = gst_buffer_get_custom_meta(b1, "LfCaptureMeta");
  ASSERT_NE(m, nullptr);
  int cam = -1;
  guint64 t = 0;
  gst_structure_get_int(gst_custom_meta_get_structure(m), "camera-id", &cam);
  gst_structure_get_uint64(gst_custom_meta_get_structure(m), "capture-time", &t);
  EXPECT_EQ(cam, 2);
  EXPECT_EQ(t, GST_BUFFER_PTS(b1));
  gst_caps_unref(caps);
  gst_buffer_unref(b0);
  gst_buffer_unref(b1);
  gst_harness_teardown(h);
}

TEST_F(Harness, ViewRequestProperties) {
  GstHarness* h = gst_harness_new("lfviewrequest");
  g_object_set(h->element, "rig", rig_path_.c_str(), "viewer-id", 7u, "width", 320, "height", 200,
               "focal-plane", "depth:1.25", "vfov", 33.0, nullptr);
  // Points are GstValueArrays: "<x, y, z>" in gst-launch syntax.
  gst_util_set_object_arg(G_OBJECT(h->element), "look-at", "<0, 0, 10>");
  gst_util_set_object_arg(G_OBJECT(h->element), "position", "<0.01, 0.02, -0.1>");
  gst_harness_play(h);
  GstBuffer* b = gst_harness_pull(h);
  ASSERT_NE(b, nullptr);
  const lf::ViewRequest r = parsed_request(b);
  EXPECT_EQ(r.viewer_id, 7u);
  EXPECT_EQ(r.view.width, 320);
  EXPECT_EQ(r.view.height, 200);
  EXPECT_NEAR(r.view.vfov_deg, 33.0, 1e-12);
  EXPECT_NEAR(r.view.position[2], -0.1, 1e-12);
  GstCaps* caps = gst_pad_get_current_caps(h->sinkpad);
  EXPECT_TRUE(
      gst_structure_has_name(gst_caps_get_structure(caps, 0), "application/x-lf-view-request"));
  gst_caps_unref(caps);
  gst_buffer_unref(b);
  gst_harness_teardown(h);
  // A bad position is refused when starting.
  GstHarness* bad = gst_harness_new("lfviewrequest");
  g_object_set(bad->element, "rig", rig_path_.c_str(), nullptr);
  gst_util_set_object_arg(G_OBJECT(bad->element), "position", "<1, 2>");
  EXPECT_EQ(gst_element_set_state(bad->element, GST_STATE_PLAYING), GST_STATE_CHANGE_FAILURE);
  gst_harness_teardown(bad);
}

// lfviewrequest aperture (rig units) and f-number (full-frame equivalent,
// rigs in mm, cm or m) set the requests' aperture scale while playing, and
// ulr-cameras their ULR aperture.
TEST_F(Harness, ViewRequestApertureAndFNumber) {
  lf::Rig mm = rig_;
  mm.unit = "mm";
  const std::string mm_path = (std::filesystem::temp_directory_path() / "lf_rig_mm.json").string();
  lf::save_rig(mm, mm_path);
  const double tent = lf::aperture_diameter(1, rig_.typical_spacing());
  for (const std::string& path : {rig_path_, mm_path}) {
    GstHarness* h = gst_harness_new("lfviewrequest");
    g_object_set(h->element, "rig", path.c_str(), "width", 64, "height", 48, "vfov", 30.0,
                 "is-live", TRUE, "focal-surface", FALSE, nullptr);
    gst_util_set_object_arg(G_OBJECT(h->element), "framerate", "100/1");
    gst_harness_use_systemclock(h);  // live: requests on the clock
    gst_harness_play(h);
    // The scale of a request made after the last change: those queued and
    // the one in the making are passed over.
    auto next_scale = [&] {
      while (gst_harness_buffers_in_queue(h) > 0) gst_buffer_unref(gst_harness_pull(h));
      double k = -1;
      for (int i = 0; i < 2; ++i) {
        GstBuffer* b = gst_harness_pull(h);
        EXPECT_NE(b, nullptr);
        if (!b) return -1.0;
        k = parsed_request(b).aperture_scale;
        gst_buffer_unref(b);
      }
      return k;
    };
    EXPECT_EQ(next_scale(), 1.0) << "the tent by default";
    g_object_set(h->element, "aperture", 2.5 * tent, nullptr);
    EXPECT_NEAR(next_scale(), 2.5, 0.5 / 256);
    g_object_set(h->element, "aperture", 0.5 * tent, nullptr);
    EXPECT_EQ(next_scale(), 1.0) << "never narrower than the tent";
    // f/N: D = 36 mm * fx / width / N.
    const double fx = 24.0 / std::tan(15.0 * CV_PI / 180), n = 36.0 * fx / 64 / (3 * tent);
    g_object_set(h->element, "aperture", 0.0, "f-number", n, nullptr);
    if (path == mm_path)
      EXPECT_NEAR(next_scale(), 3.0, 0.5 / 256) << "f/" << n;
    else
      EXPECT_EQ(next_scale(), 1.0) << "f-number ignored: the rig's unit is not a length";
    // ulr-cameras: ULR weights over k cameras in place of the tent.
    g_object_set(h->element, "f-number", 0.0, "ulr-cameras", 5u, nullptr);
    EXPECT_EQ(next_scale(), 1.0);
    GstBuffer* b = gst_harness_pull(h);
    ASSERT_NE(b, nullptr);
    const lf::ViewRequest u = parsed_request(b);
    gst_buffer_unref(b);
    EXPECT_EQ(u.aperture, lf::Aperture::kUlr);
    EXPECT_EQ(u.ulr_cameras, 5);
    // ULR needs two cameras: 1 counts as 2.
    g_object_set(h->element, "ulr-cameras", 1u, nullptr);
    EXPECT_EQ(next_scale(), 1.0);
    GstBuffer* b1 = gst_harness_pull(h);
    ASSERT_NE(b1, nullptr);
    EXPECT_EQ(parsed_request(b1).ulr_cameras, 2);
    gst_buffer_unref(b1);
    gst_harness_teardown(h);
  }
}

// A click whose probe gets no answer is probed again a second later (25
// requests at 25 fps, live), twice at most; an answer stops the retries.
// lfviewrequest focal-surface=true: a surface probe with the first request
// and every surface-interval requests; an lf-surface answer to it goes into
// the next requests; malformed answers, answers to probes it did not send,
// and surfaces for another grid are refused.
TEST_F(Harness, ViewRequestCarriesTheSurfaceTheCompositorSent) {
  GstHarness* h = gst_harness_new("lfviewrequest");
  g_object_set(h->element, "rig", rig_path_.c_str(), "viewer-id", 2u, "is-live", TRUE, "width", 64,
               "height", 48, "eye-s", 0.01, "focal-surface", TRUE, "surface-interval", 4u, nullptr);
  gst_util_set_object_arg(G_OBJECT(h->element), "framerate", "50/1");
  gst_harness_use_systemclock(h);  // live: requests on the clock
  gst_harness_play(h);
  const int planes_per_probe = lf::SurfaceOptions{}.planes;
  // Pulls request buffers until `done` says so of a request (at most
  // `limit` buffers); false if none did. A probe's steps come in one buffer.
  auto pull_until = [&](int limit, auto done) {
    for (int k = 0; k < limit; ++k) {
      GstBuffer* b = gst_harness_pull(h);
      if (!b) return false;
      const std::vector<lf::ViewRequest> reqs = parsed_requests(b);
      gst_buffer_unref(b);
      if (reqs.size() > 1 || lf::is_surface_probe(reqs[0].sequence)) {
        EXPECT_EQ(reqs.size(), static_cast<size_t>(planes_per_probe)) << "a whole probe";
      }
      for (const lf::ViewRequest& r : reqs) {
        if (lf::is_surface_probe(r.sequence)) {
          EXPECT_EQ(r.view.width, 64);  // below the probe's 160 pixels: the view's own
        }
        if (done(r)) return true;
      }
    }
    return false;
  };
  // Buffers per probe interval: the probe's and 4 requests.
  const int interval = 5;
  auto probe_end = [&](uint32_t* id) {
    return [=](const lf::ViewRequest& r) {
      if (!lf::is_surface_probe(r.sequence) ||
          lf::surface_probe_step(r.sequence) != planes_per_probe - 1)
        return false;
      *id = lf::surface_probe_id(r.sequence);
      return true;
    };
  };
  auto frame = [](bool with_surface, lf::ViewRequest* out) {
    return [=](const lf::ViewRequest& r) {
      if (lf::is_surface_probe(r.sequence) || r.surface.empty() == with_surface) return false;
      *out = r;
      return true;
    };
  };
  auto answer = [&](uint32_t probe, int tile, int cols, int rows, std::vector<double> planes,
                    std::vector<uint8_t> plane_of) {
    GBytes* pb = g_bytes_new(planes.data(), planes.size() * sizeof(double));
    GBytes* ob = g_bytes_new(plane_of.data(), plane_of.size());
    gst_harness_push_upstream_event(
        h, gst_event_new_custom(
               GST_EVENT_CUSTOM_UPSTREAM,
               gst_structure_new("lf-surface", "viewer-id", G_TYPE_UINT, 2u, "probe-id",
                                 G_TYPE_UINT, probe, "tile", G_TYPE_INT, tile, "cols", G_TYPE_INT,
                                 cols, "rows", G_TYPE_INT, rows, "planes", G_TYPE_BYTES, pb,
                                 "plane-of", G_TYPE_BYTES, ob, nullptr)));
    g_bytes_unref(pb);
    g_bytes_unref(ob);
  };
  uint32_t first = 0, second = 0;
  lf::ViewRequest r;
  ASSERT_TRUE(pull_until(2, probe_end(&first))) << "a probe with the first request";
  // 64x48 in 16-pixel tiles: 4 x 3. Two planes (z = 2 and z = 5, n = +z).
  const std::vector<double> planes = {0, 0, 1, -2, 0, 0, 1, -5};
  std::vector<uint8_t> plane_of(12, 0);
  plane_of[5] = plane_of[6] = 1;
  answer(first + 7, 16, 4, 3, planes, plane_of);  // a probe it did not send
  answer(first, 16, 4, 3, {0, 0, 1}, plane_of);   // planes: not 4 doubles each
  answer(first, 16, 4, 3, planes, {0, 1});        // plane-of: not one per tile
  EXPECT_FALSE(pull_until(3 * interval, frame(true, &r))) << "no valid answer yet";
  answer(first, 16, 4, 3, planes, plane_of);
  ASSERT_TRUE(pull_until(2 * interval, frame(true, &r)));
  EXPECT_EQ(r.surface.plane_of, plane_of);
  EXPECT_NEAR(r.focal_plane.d, -2, 1e-12);  // plane 0, the single plane
  guint used = 0;
  g_object_get(h->element, "surface-planes", &used, nullptr);
  EXPECT_EQ(used, 2u);
  ASSERT_TRUE(pull_until(2 * interval, probe_end(&second)));
  EXPECT_GT(second, first);
  ASSERT_TRUE(pull_until(2, frame(true, &r))) << "the surface stays until a newer one comes";
  // An answer for another grid (8-pixel tiles): refused when a request
  // takes it (lf::validate); the requests go back to the focal plane.
  answer(second, 8, 8, 6, planes, std::vector<uint8_t>(48, 1));
  EXPECT_TRUE(pull_until(2 * interval, frame(false, &r)));
  // focal-surface off: after the tick under way, no probes and no surface.
  g_object_set(h->element, "focal-surface", FALSE, nullptr);
  uint32_t none = 0;
  pull_until(2, frame(false, &r));
  EXPECT_FALSE(pull_until(12, probe_end(&none)));
  gst_harness_teardown(h);
}

TEST_F(Harness, AnUnansweredClickIsProbedAgainTwice) {
  // Pulls requests up to request `until`; the requests (ticks) whose probe
  // went with them, and the last probe's id.
  // Live on the system clock, the requests start at the current tick.
  uint64_t tick = 0;
  auto pull_to = [&tick](GstHarness* h, uint64_t until, std::vector<uint64_t>* at, uint32_t* id) {
    while (tick < until) {
      GstBuffer* b = gst_harness_pull(h);
      ASSERT_NE(b, nullptr);
      const std::vector<lf::ViewRequest> reqs = parsed_requests(b);
      gst_buffer_unref(b);
      for (const lf::ViewRequest& r : reqs) {
        if (!lf::is_focus_probe(r.sequence)) {
          tick = r.sequence;  // a tick's view request, then its probe's requests
        } else if (lf::focus_probe_step(r.sequence) == 0) {
          ASSERT_EQ(reqs.size(), static_cast<size_t>(lf::kFocusProbeSteps)) << "a whole probe";
          at->push_back(tick);
          *id = lf::focus_probe_id(r.sequence);
        }
      }
    }
  };
  for (bool answer : {false, true}) {
    GstHarness* h = gst_harness_new("lfviewrequest");
    g_object_set(h->element, "rig", rig_path_.c_str(), "viewer-id", 2u, "is-live", TRUE, "width",
                 64, "height", 48, "focal-surface", FALSE, nullptr);
    gst_util_set_object_arg(G_OBJECT(h->element), "framerate", "25/1");
    gst_harness_use_systemclock(h);  // live: requests on the clock
    gst_harness_play(h);
    std::vector<uint64_t> at;
    uint32_t id = 0;
    tick = 0;
    pull_to(h, 1, &at, &id);
    pull_to(h, tick + 2, &at, &id);
    gst_harness_push_upstream_event(
        h, gst_navigation_event_new_mouse_button_press(3, 30, 20, GST_NAVIGATION_MODIFIER_NONE));
    while (at.empty()) pull_to(h, tick + 1, &at, &id);
    const uint64_t first = at[0];
    if (answer)
      gst_harness_push_upstream_event(
          h, gst_event_new_custom(
                 GST_EVENT_CUSTOM_UPSTREAM,
                 gst_structure_new("lf-focus", "viewer-id", G_TYPE_UINT, 2u, "probe-id",
                                   G_TYPE_UINT, id, "inverse-depth", G_TYPE_DOUBLE, 0.5, nullptr)));
    pull_to(h, first + 70, &at, &id);
    if (answer) {
      EXPECT_EQ(at, std::vector<uint64_t>({first})) << "answered: no retry";
      double depth = 0;
      g_object_get(h->element, "focal-depth", &depth, nullptr);
      EXPECT_NEAR(depth, 2.0, 1e-9);
    } else {
      // Two retries, a second apart (a live source skips the ticks it is
      // late for: up to 4 more on a busy machine).
      ASSERT_EQ(at.size(), 3u);
      for (size_t i = 1; i < 3; ++i) {
        EXPECT_GE(at[i] - at[i - 1], 25u);
        EXPECT_LT(at[i] - at[i - 1], 30u);
      }
    }
    gst_harness_teardown(h);
  }
}

TEST_F(Harness, FragmentFromFrameAndRequest) {
  GstHarness* video = nullptr;
  cv::Mat frame;
  GstHarness* h = camera1_fragment(&video, &frame);
  // Garbage first: dropped with a warning, the stream goes on.
  EXPECT_EQ(gst_harness_push(h, bytes({1, 2, 3}, 0)), GST_FLOW_OK);
  ASSERT_EQ(gst_harness_push(h, bytes(lf::serialize_request(request(42)), GST_SECOND)),
            GST_FLOW_OK);
  GstBuffer* out = gst_harness_pull(h);
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(GST_BUFFER_PTS(out), GST_SECOND);
  const lf::Fragment f = parsed_fragment(out);
  EXPECT_EQ(f.camera_id, 1u);
  EXPECT_EQ(f.viewer_id, 3u);
  EXPECT_EQ(f.sequence, 42u);
  EXPECT_EQ(f.capture_time_ns, 123);
  // Same pixels as the library.
  const lf::ViewGeometry g(rig_, request(42));
  lf::Fragment ref;
  lf::render_fragment(lf::plan_fragment(g, 1), rig_.cameras[1], frame, ref);
  EXPECT_EQ(f.pixels, ref.pixels);
  EXPECT_EQ(gst_harness_buffers_in_queue(h), 0u);  // nothing for the garbage
  GstCaps* caps = gst_pad_get_current_caps(h->sinkpad);
  EXPECT_STREQ(gst_structure_get_string(gst_caps_get_structure(caps, 0), "encoding"), "raw");
  gst_caps_unref(caps);
  gst_buffer_unref(out);
  gst_harness_teardown(video);
  gst_harness_teardown(h);
}

// A request with a focal surface (wire version 3) is warped through it:
// the same pixels as the library's.
TEST_F(Harness, FragmentThroughAFocalSurface) {
  GstHarness* video = nullptr;
  cv::Mat frame;
  GstHarness* h = camera1_fragment(&video, &frame);
  lf::ViewRequest r = request(5);
  lf::FocalSurface& sf = r.surface;
  sf.tile = 8;
  sf.cols = (r.view.width + 7) / 8, sf.rows = (r.view.height + 7) / 8;
  sf.planes = {lf::plane_at_depth(rig_, 0.6), lf::plane_at_depth(rig_, 1.25),
               lf::plane_at_depth(rig_, 4.0)};
  for (int t = 0; t < sf.cols * sf.rows; ++t) sf.plane_of.push_back((t % sf.cols) * 3 / sf.cols);
  ASSERT_EQ(gst_harness_push(h, bytes(lf::serialize_request(r), GST_SECOND)), GST_FLOW_OK);
  GstBuffer* out = gst_harness_pull(h);
  ASSERT_NE(out, nullptr);
  const lf::Fragment f = parsed_fragment(out);
  gst_buffer_unref(out);
  lf::Fragment ref, flat;
  lf::render_fragment(lf::plan_fragment(lf::ViewGeometry(rig_, r), 1), rig_.cameras[1], frame, ref);
  lf::ViewRequest one = r;
  one.surface = lf::FocalSurface{};
  lf::render_fragment(lf::plan_fragment(lf::ViewGeometry(rig_, one), 1), rig_.cameras[1], frame,
                      flat);
  ASSERT_FALSE(ref.empty());
  EXPECT_EQ(f.pixels, ref.pixels);
  EXPECT_NE(f.pixels, flat.pixels) << "the surface changed the sampling";
  gst_harness_teardown(video);
  gst_harness_teardown(h);
}

// backend=gl: the fragment drawn by EGL/GLES 3 (lf/render/gl_render.h), the same
// pixels as the CPU kernel's within the GL tolerance of tests/test_gl.cpp
// (on Mesa's llvmpipe, identical); the frame is uploaded once for both
// requests. A build or machine without GL fails to start instead.
TEST_F(Harness, FragmentOnTheGlBackend) {
  const char* platform = std::getenv("EGL_PLATFORM");
  if (platform && std::string(platform) == "nowhere") {  // meson test gst_harness_nogl
    ASSERT_FALSE(lf::gl_info().available);
  }
  if (!lf::gl_info().available) {
    GstElement* el = gst_element_factory_make("lffragment", nullptr);
    g_object_set(el, "rig", rig_path_.c_str(), "camera-id", 1, nullptr);
    gst_util_set_object_arg(G_OBJECT(el), "backend", "gl");
    EXPECT_EQ(gst_element_set_state(el, GST_STATE_PAUSED), GST_STATE_CHANGE_FAILURE)
        << "no GL here (" << lf::gl_info().error << "): backend=gl must not start";
    gst_element_set_state(el, GST_STATE_NULL);
    gst_object_unref(el);
    return;
  }
  GstHarness* video = nullptr;
  cv::Mat frame;
  GstHarness* h = camera1_fragment(&video, &frame, "gl");
  for (uint64_t seq : {7u, 8u}) {
    ASSERT_EQ(gst_harness_push(h, bytes(lf::serialize_request(request(seq)), GST_SECOND)),
              GST_FLOW_OK);
    GstBuffer* out = gst_harness_pull(h);
    ASSERT_NE(out, nullptr);
    const lf::Fragment f = parsed_fragment(out);
    gst_buffer_unref(out);
    lf::Fragment ref;
    lf::render_fragment(lf::plan_fragment(lf::ViewGeometry(rig_, request(seq)), 1), rig_.cameras[1],
                        frame, ref);
    ASSERT_FALSE(ref.empty());
    EXPECT_EQ(f.sequence, seq);
    EXPECT_EQ(f.spans, ref.spans);
    ASSERT_EQ(f.pixels.size(), ref.pixels.size());
    double sum = 0;
    int worst = 0;
    size_t differ = 0;
    for (size_t i = 0; i < f.pixels.size(); ++i) {
      const int e = std::abs(f.pixels[i] - ref.pixels[i]);
      sum += e;
      worst = std::max(worst, e);
      differ += e != 0;
    }
    EXPECT_LE(sum / f.pixels.size(), 1.0);
    EXPECT_LE(worst, 3);
    EXPECT_LE(differ, f.pixels.size() / 100);
  }
  gst_harness_teardown(video);
  gst_harness_teardown(h);
}

// A focus probe is answered from the frame of its own instant only: a camera
// that skipped that frame (late) sits the probe out with an explicitly empty
// fragment (so a non-live compositor does not wait for it), where a frame
// request takes the newest frame before it. Surface probes alike.
TEST_F(Harness, AProbeTakesOnlyTheFrameOfItsInstant) {
  GstHarness* video = nullptr;
  cv::Mat frame;
  GstHarness* h = camera1_fragment(&video, &frame);  // a frame at 123 ns, 30 fps
  GstBuffer* later = gst_buffer_new_memdup(frame.data, frame.total() * 4);
  GST_BUFFER_PTS(later) = 123 + 3 * GST_SECOND / 30;  // two frames skipped
  ASSERT_EQ(gst_harness_push(video, later), GST_FLOW_OK);
  auto answers = [&](uint64_t sequence, int64_t time_ns) {
    lf::ViewRequest r = request(sequence);
    r.time_ns = time_ns;
    EXPECT_EQ(gst_harness_push(h, bytes(lf::serialize_request(r), GST_SECOND)), GST_FLOW_OK);
    // "empty", "pixels" or how many buffers came otherwise.
    const guint n = gst_harness_buffers_in_queue(h);
    std::string what = std::to_string(n) + " buffers";
    if (n == 1) {
      GstBuffer* out = gst_harness_pull(h);
      const lf::Fragment f = parsed_fragment(out);
      gst_buffer_unref(out);
      EXPECT_EQ(f.sequence, sequence);
      what = f.empty() ? "empty" : "pixels";
    }
    while (gst_harness_buffers_in_queue(h) > 0) gst_buffer_unref(gst_harness_pull(h));
    return what;
  };
  const int64_t skipped = 123 + 2 * GST_SECOND / 30;
  EXPECT_EQ(answers(lf::focus_probe_sequence(1, 0), skipped), "empty") << "its frame was skipped";
  EXPECT_EQ(answers(lf::surface_probe_sequence(1, 0), skipped), "empty") << "its frame was skipped";
  EXPECT_EQ(answers(lf::focus_probe_sequence(2, 0), 123 + 10), "pixels") << "its frame is there";
  EXPECT_EQ(answers(lf::surface_probe_sequence(2, 0), 123 + 10), "pixels") << "its frame is there";
  EXPECT_EQ(answers(7, skipped), "pixels") << "a frame request takes the frame before";
  gst_harness_teardown(video);
  gst_harness_teardown(h);
}

// A probe bundle (lib/lf/wire/probe_bundle.h): one request buffer with all the
// steps, one answer buffer with the camera's fragment of each step in
// order, each the one that step alone gets; a bundle that is not one
// probe's steps is dropped with no answer.
TEST_F(Harness, AProbeBundleIsAnsweredInOneBuffer) {
  GstHarness* video = nullptr;
  cv::Mat frame;
  GstHarness* h = camera1_fragment(&video, &frame);  // a frame at 123 ns
  lf::ViewRequest view = request(9);
  view.time_ns = 123 + 10;
  for (bool focus : {false, true}) {
    // The same probe twice: its steps one by one (id 5), then bundled (id 6).
    std::vector<lf::ViewRequest> alone, bundled;
    if (focus) {
      alone = lf::focus_probe_requests(rig_, view, 40, 30, 5);
      bundled = lf::focus_probe_requests(rig_, view, 40, 30, 6);
    } else {
      alone = lf::surface_probe_requests(rig_, view, 5);
      bundled = lf::surface_probe_requests(rig_, view, 6);
    }
    std::vector<lf::Fragment> one_by_one;
    for (const lf::ViewRequest& r : alone) {
      ASSERT_EQ(gst_harness_push(h, bytes(lf::serialize_request(r), GST_SECOND)), GST_FLOW_OK);
      ASSERT_EQ(gst_harness_buffers_in_queue(h), 1u);
      GstBuffer* out = gst_harness_pull(h);
      one_by_one.push_back(parsed_fragment(out));
      gst_buffer_unref(out);
    }
    ASSERT_EQ(gst_harness_push(h, bytes(lf::serialize_probe_bundle(bundled), GST_SECOND)),
              GST_FLOW_OK);
    ASSERT_EQ(gst_harness_buffers_in_queue(h), 1u) << "one answer for the whole probe";
    GstBuffer* out = gst_harness_pull(h);
    EXPECT_EQ(GST_BUFFER_PTS(out), GST_SECOND);
    GstMapInfo map;
    ASSERT_TRUE(gst_buffer_map(out, &map, GST_MAP_READ));
    const std::vector<lf::FragmentSpan> spans = lf::split_probe_answer(map.data, map.size);
    ASSERT_EQ(spans.size(), bundled.size());
    int with_pixels = 0;
    for (size_t k = 0; k < spans.size(); ++k) {
      const lf::Fragment f = lf::parse_fragment(map.data + spans[k].offset, spans[k].size);
      EXPECT_EQ(f.sequence, bundled[k].sequence);
      EXPECT_EQ(f.camera_id, static_cast<uint32_t>(rig_.cameras[1].id));
      EXPECT_EQ(f.pixels, one_by_one[k].pixels) << "step " << k;
      EXPECT_EQ(f.rect, one_by_one[k].rect) << "step " << k;
      with_pixels += !f.empty();
    }
    EXPECT_GT(with_pixels, 0);
    gst_buffer_unmap(out, &map);
    gst_buffer_unref(out);
  }
  // Not one probe's steps: a frame request with a step, a step twice.
  std::vector<lf::ViewRequest> steps = lf::surface_probe_requests(rig_, view, 7);
  std::vector<uint8_t> mixed = lf::serialize_request(request(10));
  const std::vector<uint8_t> step = lf::serialize_request(steps[0]);
  mixed.insert(mixed.end(), step.begin(), step.end());
  std::vector<uint8_t> twice = step;
  twice.insert(twice.end(), step.begin(), step.end());
  for (const auto& bad : {mixed, twice}) {
    ASSERT_EQ(gst_harness_push(h, bytes(bad, GST_SECOND)), GST_FLOW_OK);
    EXPECT_EQ(gst_harness_buffers_in_queue(h), 0u);
  }
  gst_harness_teardown(video);
  gst_harness_teardown(h);
}

TEST_F(Harness, CompositorCapsAndBadInput) {
  const lf::Rig one = rig_.subset({0});
  GstHarness* h = one_camera_compositor(0, "lf-harness-one.json");
  // Garbage: dropped with a warning.
  EXPECT_EQ(gst_harness_push(h, bytes({'L', 'F', 'F', 'R', 0, 1}, 0)), GST_FLOW_OK);
  // A real fragment of the one camera: composited alone, renormalised.
  const lf::ViewRequest req = request(5);
  const lf::ViewGeometry g(one, req);
  const cv::Mat img = lf::SyntheticScene::for_rig(one).render(one.cameras[0], 0.0);
  lf::Fragment f;
  f.viewer_id = req.viewer_id;
  f.sequence = 5;
  lf::render_fragment(lf::plan_fragment(g, 0), one.cameras[0], img, f);
  ASSERT_FALSE(f.empty());
  ASSERT_EQ(gst_harness_push(h, bytes(lf::serialize_fragment(f, lf::Encoding::kRaw), GST_SECOND)),
            GST_FLOW_OK);
  GstBuffer* out = gst_harness_pull(h);
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(GST_BUFFER_PTS(out), GST_SECOND);
  GstCaps* caps = gst_pad_get_current_caps(h->sinkpad);
  GstStructure* s = gst_caps_get_structure(caps, 0);
  int w = 0, hh = 0;
  gst_structure_get_int(s, "width", &w);
  gst_structure_get_int(s, "height", &hh);
  EXPECT_EQ(w, 80);
  EXPECT_EQ(hh, 60);
  EXPECT_STREQ(gst_structure_get_string(s, "format"), "RGBA");
  lf::Compositor c;
  c.reset(80, 60);
  c.add(f);
  cv::Mat ref;
  c.resolve(ref);
  GstMapInfo map;
  gst_buffer_map(out, &map, GST_MAP_READ);
  EXPECT_EQ(std::memcmp(map.data, ref.data, 80 * 60 * 4), 0);
  gst_buffer_unmap(out, &map);
  gst_caps_unref(caps);
  gst_buffer_unref(out);
  gst_harness_teardown(h);
}

// lfcompositor resolves a frame straight into its output buffer (RGBA at
// the view's size, gst/lfvideoout.h) and keeps the last one sent: a
// request left incomplete at EOS takes the last frame's pixels where its
// one camera gave no weight, and the frame sent before is not written to.
TEST_F(Harness, AnIncompleteFrameTakesTheLastFramesPixels) {
  const lf::Rig two = rig_.subset({0, 1});
  const std::string path =
      (std::filesystem::temp_directory_path() / "lf-harness-two.json").string();
  lf::save_rig(two, path);
  GstElement* el = gst_element_factory_make("lfcompositor", nullptr);
  g_object_set(el, "rig", path.c_str(), "viewer-id", 3, nullptr);
  GstHarness* h0 = gst_harness_new_with_element(el, "sink_0", "src");
  GstHarness* h1 = gst_harness_new_with_element(el, "sink_1", nullptr);
  gst_object_unref(el);
  for (GstHarness* h : {h0, h1}) {
    gst_harness_set_live(h, FALSE);
    gst_harness_set_src_caps_str(h, "application/x-lf-fragment,encoding=raw,width=80,height=60");
  }
  auto fragment = [&](int cam, uint64_t seq, double t) {
    const lf::ViewRequest req = request(seq);
    lf::Fragment f;
    f.viewer_id = req.viewer_id;
    f.sequence = seq;
    const cv::Mat img = lf::SyntheticScene::for_rig(two).render(two.cameras[cam], t);
    lf::render_fragment(lf::plan_fragment(lf::ViewGeometry(two, req), cam), two.cameras[cam], img,
                        f);
    return f;
  };
  const lf::Fragment a0 = fragment(0, 5, 0.0), a1 = fragment(1, 5, 0.0);
  const lf::Fragment b0 = fragment(0, 6, 0.5);  // another instant: other pixels
  ASSERT_FALSE(a0.empty());
  ASSERT_FALSE(a1.empty());
  ASSERT_EQ(gst_harness_push(h0, bytes(lf::serialize_fragment(a0, lf::Encoding::kRaw), 0)),
            GST_FLOW_OK);
  ASSERT_EQ(gst_harness_push(h1, bytes(lf::serialize_fragment(a1, lf::Encoding::kRaw), 0)),
            GST_FLOW_OK);
  GstBuffer* first = gst_harness_pull(h0);
  ASSERT_NE(first, nullptr);
  lf::Compositor c;
  c.reset(80, 60);
  c.add(a0), c.add(a1);
  cv::Mat want_first;
  c.resolve(want_first);
  ASSERT_EQ(gst_harness_push(h0, bytes(lf::serialize_fragment(b0, lf::Encoding::kRaw), GST_SECOND)),
            GST_FLOW_OK);
  gst_harness_push_event(h1, gst_event_new_eos());
  gst_harness_push_event(h0, gst_event_new_eos());
  GstBuffer* second = gst_harness_pull(h0);
  ASSERT_NE(second, nullptr);
  c.reset(80, 60);
  c.add(b0);
  cv::Mat only_b0;
  c.resolve(only_b0);
  GstMapInfo m1, m2;
  ASSERT_TRUE(gst_buffer_map(first, &m1, GST_MAP_READ));
  ASSERT_TRUE(gst_buffer_map(second, &m2, GST_MAP_READ));
  const cv::Mat got_first(60, 80, CV_8UC4, m1.data), got_second(60, 80, CV_8UC4, m2.data);
  EXPECT_EQ(cv::norm(got_first, want_first, cv::NORM_INF), 0) << "the first frame, unchanged";
  int filled = 0, own = 0;
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) {
      const bool weighted = only_b0.at<cv::Vec4b>(y, x)[3] != 0;
      const cv::Vec4b want =
          weighted ? only_b0.at<cv::Vec4b>(y, x) : want_first.at<cv::Vec4b>(y, x);
      ASSERT_EQ(got_second.at<cv::Vec4b>(y, x), want) << x << "," << y;
      (weighted ? own : filled) += want_first.at<cv::Vec4b>(y, x)[3] != 0;
    }
  EXPECT_GT(filled, 100) << "pixels taken from the last frame";
  EXPECT_GT(own, 100) << "pixels of camera 0 at the new instant";
  gst_buffer_unmap(first, &m1);
  gst_buffer_unmap(second, &m2);
  gst_buffer_unref(first);
  gst_buffer_unref(second);
  gst_harness_teardown(h1);
  gst_harness_teardown(h0);
}

// lfpartialsum on one camera's pad: garbage and a fragment for a frame
// larger than the view (the caps' 80x60) are dropped with a warning, not
// summed; a real fragment comes out as its own sum (one camera: a plain
// version-1 fragment, the same sums), with its PTS.
TEST_F(Harness, PartialSumDropsBadFragmentsAndSumsTheRest) {
  GstElement* el = gst_element_factory_make("lfpartialsum", nullptr);
  GstHarness* h = gst_harness_new_with_element(el, "sink_0", "src");
  gst_object_unref(el);
  gst_harness_set_live(h, FALSE);
  gst_harness_set_src_caps_str(h, "application/x-lf-fragment,encoding=raw,width=80,height=60");
  EXPECT_EQ(gst_harness_push(h, bytes({'L', 'F', 'F', 'R', 0, 1}, 0)), GST_FLOW_OK);
  const lf::ViewRequest req = request(7);
  const lf::ViewGeometry g(rig_, req);
  lf::Fragment f;
  f.viewer_id = req.viewer_id;
  f.sequence = 7;
  f.camera_id = rig_.cameras[2].id;
  lf::render_fragment(lf::plan_fragment(g, 2), rig_.cameras[2],
                      lf::SyntheticScene::for_rig(rig_).render(rig_.cameras[2], 0.0), f);
  ASSERT_FALSE(f.empty());
  lf::Fragment huge = f;  // the same pixels, claimed for a 4000x4000 frame
  huge.sequence = 6;
  huge.out_width = huge.out_height = 4000;
  EXPECT_EQ(gst_harness_push(h, bytes(lf::serialize_fragment(huge, lf::Encoding::kRaw), 1)),
            GST_FLOW_OK);
  ASSERT_EQ(
      gst_harness_push(h, bytes(lf::serialize_fragment(f, lf::Encoding::kRaw), 2 * GST_SECOND)),
      GST_FLOW_OK);
  GstBuffer* out = gst_harness_pull(h);
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(GST_BUFFER_PTS(out), 2 * GST_SECOND);
  const lf::Fragment sum = parsed_fragment(out);
  EXPECT_EQ(sum.sequence, 7u);
  EXPECT_EQ(sum.cameras, 1);
  // Trimmed of the pixels of weight 0, else the same sums everywhere.
  EXPECT_TRUE((sum.rect & f.rect) == sum.rect);
  lf::Compositor a, b;
  a.reset(80, 60), b.reset(80, 60);
  a.add(sum), b.add(f);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x)
      ASSERT_EQ(std::memcmp(a.sums_at(x, y), b.sums_at(x, y), 16), 0) << x << "," << y;
  gst_buffer_unref(out);
  EXPECT_EQ(gst_harness_try_pull(h), nullptr) << "nothing from the bad buffers";
  guint64 sums = 0;
  g_object_get(h->element, "sums", &sums, nullptr);
  EXPECT_EQ(sums, 1u);
  gst_harness_teardown(h);
}

// Raw fragments made in this process carry LfSealedMeta; lfcompositor skips
// their CRC (the bytes never left the process) and nothing else. The meta
// does not survive a copy, so a copied (or received) buffer is checked in
// full: a flipped pixel bit is then caught.
TEST_F(Harness, SealedFragmentsSkipOnlyTheCrc) {
  GstHarness* video = nullptr;
  cv::Mat frame;
  GstHarness* fh = camera1_fragment(&video, &frame);
  GstBuffer* frag[2];
  for (int k = 0; k < 2; ++k) {
    ASSERT_EQ(
        gst_harness_push(fh, bytes(lf::serialize_request(request(5 + k)), (5 + k) * GST_SECOND)),
        GST_FLOW_OK);
    frag[k] = gst_harness_pull(fh);
    ASSERT_NE(frag[k], nullptr);
  }
  const GType api = g_type_from_name("LfSealedMetaAPI");
  ASSERT_NE(api, 0u);
  EXPECT_NE(gst_buffer_get_meta(frag[0], api), nullptr);
  // Request 5: copied (meta dropped), then a pixel bit flipped.
  GstBuffer* copied = gst_buffer_copy(frag[0]);
  gst_buffer_unref(frag[0]);
  EXPECT_EQ(gst_buffer_get_meta(copied, api), nullptr);
  // Request 6: the sealed buffer itself, the same bit flipped in place.
  frag[1] = gst_buffer_make_writable(frag[1]);
  ASSERT_NE(gst_buffer_get_meta(frag[1], api), nullptr);
  for (GstBuffer* b : {copied, frag[1]}) {
    GstMapInfo map;
    ASSERT_TRUE(gst_buffer_map(b, &map, GST_MAP_WRITE));
    ASSERT_GT(map.size, lf::kFragmentHeaderSize + 64);
    map.data[map.size - 2] ^= 0x01;
    gst_buffer_unmap(b, &map);
  }
  GstHarness* h = one_camera_compositor(1, "lf-harness-sealed.json");
  EXPECT_EQ(gst_harness_push(h, copied), GST_FLOW_OK);   // CRC mismatch: dropped
  EXPECT_EQ(gst_harness_push(h, frag[1]), GST_FLOW_OK);  // sealed here: composited
  GstBuffer* out = gst_harness_pull(h);
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(GST_BUFFER_OFFSET(out), 6u);
  gst_buffer_unref(out);
  gst_harness_teardown(h);
  gst_harness_teardown(video);
  gst_harness_teardown(fh);
}

// lffragmentdemux: each fragment to its viewer's pad only; garbage and
// fragments of viewers without a pad dropped (counted), never a crash.
TEST_F(Harness, FragmentDemuxRoutesByViewer) {
  GstHarness* h = gst_harness_new_with_padnames("lffragmentdemux", "sink", nullptr);
  gst_harness_set_src_caps_str(h, "application/x-lf-fragment,encoding=raw,width=80,height=60");
  GstHarness* v2 = gst_harness_new_with_element(h->element, nullptr, "src_2");
  GstHarness* v5 = gst_harness_new_with_element(h->element, nullptr, "src_5");
  gst_harness_play(h);
  auto fragment = [](uint32_t viewer, uint64_t seq) {
    lf::Fragment f;
    f.viewer_id = viewer;
    f.sequence = seq;
    f.camera_id = 1;
    f.out_width = 80;
    f.out_height = 60;
    return bytes(lf::serialize_fragment(f, lf::Encoding::kRaw), seq * GST_SECOND);
  };
  EXPECT_EQ(gst_harness_push(h, bytes({'L', 'F', 'F', 'R', 0, 1}, 0)), GST_FLOW_OK);  // garbage
  EXPECT_EQ(gst_harness_push(h, fragment(2, 1)), GST_FLOW_OK);
  EXPECT_EQ(gst_harness_push(h, fragment(7, 2)), GST_FLOW_OK);  // nobody's
  EXPECT_EQ(gst_harness_push(h, fragment(5, 3)), GST_FLOW_OK);
  EXPECT_EQ(gst_harness_push(h, fragment(2, 4)), GST_FLOW_OK);
  ASSERT_EQ(gst_harness_buffers_received(v2), 2u);
  ASSERT_EQ(gst_harness_buffers_received(v5), 1u);
  for (uint64_t want : {1u, 4u}) {
    GstBuffer* b = gst_harness_pull(v2);
    GstMapInfo m;
    gst_buffer_map(b, &m, GST_MAP_READ);
    EXPECT_EQ(lf::peek_fragment_header(m.data, m.size).sequence, want);
    gst_buffer_unmap(b, &m);
    gst_buffer_unref(b);
  }
  // The new pads got the stream's caps.
  GstCaps* caps = gst_pad_get_current_caps(v5->sinkpad);
  ASSERT_NE(caps, nullptr);
  EXPECT_STREQ(gst_structure_get_name(gst_caps_get_structure(caps, 0)),
               "application/x-lf-fragment");
  gst_caps_unref(caps);
  guint64 routed = 0, unrouted = 0;
  g_object_get(h->element, "routed", &routed, "unrouted", &unrouted, nullptr);
  EXPECT_EQ(routed, 3u);
  EXPECT_EQ(unrouted, 1u);
  // A pad name that is not src_<viewer id> is refused.
  EXPECT_EQ(gst_element_request_pad_simple(h->element, "src_x"), nullptr);
  gst_harness_teardown(v5);
  gst_harness_teardown(v2);
  gst_harness_teardown(h);
}

// GStreamer's own warnings (a push before stream-start, sticky events out
// of order), counted while a test runs.
std::atomic<int> gst_warnings{0};
void count_gst_warning(const gchar*, GLogLevelFlags, const gchar* message, gpointer) {
  ++gst_warnings;
  std::fprintf(stderr, "GStreamer warning: %s\n", message);
}

// lffragmentdemux while viewers come and go (lf-web: a browser connecting
// and closing as fast as it can): fragments stream in on one thread while
// another requests, links and releases viewer pads. A pad is routed to only
// once it is whole (active, its sticky events in place, in the flow
// combiner), and a viewer pad that is flushing (its branch stopping) is that
// viewer's, not the stream's: every push returns OK, and each viewer gets
// stream-start and segment before its first fragment. Before, a push could
// reach a pad still being made: it returned FLUSHING, which stopped the
// cameras' stream for every viewer for good (lf-web's viewers then got no
// frame and no offer until its 2-s retry), or came before stream-start.
TEST_F(Harness, FragmentDemuxPadsComeAndGoWhileStreaming) {
  GstHarness* h = gst_harness_new_with_padnames("lffragmentdemux", "sink", nullptr);
  gst_harness_set_src_caps_str(h, "application/x-lf-fragment,encoding=raw,width=80,height=60");
  gst_harness_play(h);
  const guint handler =
      g_log_set_handler("GStreamer", GLogLevelFlags(G_LOG_LEVEL_WARNING | G_LOG_LEVEL_CRITICAL),
                        count_gst_warning, nullptr);
  gst_warnings = 0;
  std::vector<GstBuffer*> frags;
  for (uint32_t viewer = 0; viewer < 4; ++viewer) {
    lf::Fragment f;
    f.viewer_id = viewer;
    f.camera_id = 1;
    f.out_width = 80;
    f.out_height = 60;
    frags.push_back(bytes(lf::serialize_fragment(f, lf::Encoding::kRaw), 0));
  }
  std::atomic<bool> stop{false};
  std::atomic<int> pushes{0}, not_ok{0};
  std::atomic<int> last_bad{GST_FLOW_OK};
  std::thread stream([&] {
    for (int k = 0; !stop; ++k) {
      const GstFlowReturn r = gst_harness_push(h, gst_buffer_ref(frags[k % 4]));
      ++pushes;
      if (r != GST_FLOW_OK) ++not_ok, last_bad = r;
    }
  });
  // A viewer's input: counts fragments that came without stream-start or
  // segment before them.
  static std::atomic<int> received{0}, unprepared{0};
  received = unprepared = 0;
  auto chain = [](GstPad* pad, GstObject*, GstBuffer* b) -> GstFlowReturn {
    ++received;
    for (GstEventType t : {GST_EVENT_STREAM_START, GST_EVENT_SEGMENT}) {
      if (GstEvent* e = gst_pad_get_sticky_event(pad, t, 0))
        gst_event_unref(e);
      else
        ++unprepared;
    }
    gst_buffer_unref(b);
    return GST_FLOW_OK;
  };
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  int cycles = 0;
  while (std::chrono::steady_clock::now() < until || cycles < 200) {
    const std::string name = "src_" + std::to_string(cycles % 4);
    GstPad* src = gst_element_request_pad_simple(h->element, name.c_str());
    ASSERT_NE(src, nullptr) << name;
    GstPad* sink = gst_pad_new("sink", GST_PAD_SINK);
    gst_pad_set_chain_function(sink, chain);
    gst_pad_set_active(sink, TRUE);
    ASSERT_EQ(gst_pad_link(src, sink), GST_PAD_LINK_OK);
    if (cycles % 2) g_usleep(100);  // a while with fragments coming in
    // A third of them stop first (a viewer's branch going to NULL: flushing).
    if (cycles % 3 == 0) gst_pad_set_active(sink, FALSE);
    gst_element_release_request_pad(h->element, src);
    gst_object_unref(src);
    gst_pad_set_active(sink, FALSE);
    gst_object_unref(sink);
    ++cycles;
  }
  stop = true;
  stream.join();
  g_log_remove_handler("GStreamer", handler);
  std::printf("%d pad cycles, %d pushes, %d fragments received\n", cycles, pushes.load(),
              received.load());
  EXPECT_EQ(not_ok.load(), 0) << "last flow: " << gst_flow_get_name(GstFlowReturn(last_bad.load()));
  EXPECT_EQ(unprepared.load(), 0) << "fragments before stream-start or segment";
  EXPECT_EQ(gst_warnings.load(), 0);
  EXPECT_GT(received.load(), 0);
  for (GstBuffer* b : frags) gst_buffer_unref(b);
  gst_harness_teardown(h);
}

}  // namespace

// The per-viewer request limit (gst/lfrate.h): a request's viewer id read
// from its header as the wire format writes it (big-endian), and a bucket
// per viewer that another viewer's flood does not spend; made-up ids beyond
// kViewers share one bucket.
TEST(RequestLimit, ViewerIdAndBucketsPerViewer) {
  lf::ViewRequest r;
  r.viewer_id = 0x01020304;
  r.view.width = 64, r.view.height = 48, r.view.vfov_deg = 40;
  const auto bytes = lf::serialize_request(r);
  EXPECT_EQ(lfgst::request_viewer(bytes.data(), bytes.size()), 0x01020304u);
  EXPECT_EQ(lfgst::request_viewer(bytes.data(), 11), G_MAXUINT32);
  lfgst::ViewerBuckets b;
  const gint64 t = 1000000;
  int passed1 = 0, passed2 = 0;
  for (int i = 0; i < 100; ++i) passed1 += b.take(1, 10, t);
  for (int i = 0; i < 5; ++i) passed2 += b.take(2, 10, t);
  EXPECT_EQ(passed1, 10);
  EXPECT_EQ(passed2, 5);
  // 64 viewers with buckets of their own (1, 2 and 62 more); ids beyond
  // share one bucket.
  for (guint32 v = 3; v < 1 + lfgst::ViewerBuckets::kViewers; ++v) EXPECT_TRUE(b.take(v, 10, t));
  int shared = 0;
  for (guint32 v = 1000; v < 1100; ++v) shared += b.take(v, 10, t);
  EXPECT_EQ(shared, 10) << "made-up ids get no fresh tokens";
  // Idle ids give their bucket up: a new viewer gets one later.
  EXPECT_TRUE(b.take(5000, 10, t + 2 * lfgst::ViewerBuckets::kIdleUs));
}

// The elements' rig cache (gst/lfrig.h): one entry per file whatever the
// name used, and an edited file is loaded again.
// This process's resident memory, KiB (VmRSS).
static long rss_kib() {
  FILE* f = std::fopen("/proc/self/status", "r");
  long kib = -1;
  char line[256];
  while (f && std::fgets(line, sizeof line, f))
    if (std::sscanf(line, "VmRSS: %ld kB", &kib) == 1) break;
  if (f) std::fclose(f);
  return kib;
}

// lfgst::new_buffer: a large buffer has a mapping of its own, taken again
// by the next buffer of its size, and its pages leave the RSS when the
// mappings are released (a burst of 4K fragments from glibc's arenas once
// stayed in it); a small one is an ordinary buffer.
TEST(LargeBuffers, OwnMappingsReusedThenReturned) {
  gst_init(nullptr, nullptr);
  lfgst::release_buffers();
  const gsize big = 64u << 20;  // 64 MiB
  const long before = rss_kib();
  GstBuffer* b = lfgst::new_buffer(big + 5);
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(gst_buffer_get_size(b), big + 5);
  GstMapInfo m;
  ASSERT_TRUE(gst_buffer_map(b, &m, GST_MAP_WRITE));
  std::memset(m.data, 7, m.size);  // every page resident
  const guint8* first = m.data;
  gst_buffer_unmap(b, &m);
  EXPECT_GT(rss_kib() - before, 60 * 1024);
  gst_buffer_unref(b);
  // Kept for the next buffer of its size: the same pages.
  b = lfgst::new_buffer(big + 100);
  ASSERT_TRUE(gst_buffer_map(b, &m, GST_MAP_READ));
  EXPECT_EQ(m.data, first);
  EXPECT_EQ(m.data[12345], 7);
  gst_buffer_unmap(b, &m);
  gst_buffer_unref(b);
  // Released: the pages leave the RSS.
  lfgst::release_buffers();
  EXPECT_LT(rss_kib() - before, 8 * 1024);
  // Small: an ordinary buffer, writable.
  b = lfgst::new_buffer(1000);
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(gst_buffer_get_size(b), 1000u);
  EXPECT_TRUE(gst_buffer_is_writable(b));
  gst_buffer_unref(b);
}

TEST(RigCache, CanonicalPathAndEditsReload) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "lf-rig-cache-test";
  fs::create_directories(dir);
  const fs::path file = dir / "rig.json";
  lf::save_rig(lf::synthetic_grid_rig(2, 2, 0.05, 64, 48, 40), file.string());
  const auto a = lfgst::load_rig_cached(file.string());
  const fs::path cwd = fs::current_path();
  fs::current_path(dir);
  const auto b = lfgst::load_rig_cached("rig.json");
  const auto c = lfgst::load_rig_cached("./../lf-rig-cache-test/rig.json");
  fs::current_path(cwd);
  EXPECT_EQ(a.get(), b.get());
  EXPECT_EQ(a.get(), c.get());
  EXPECT_EQ(a->cameras.size(), 4u);
  // Edit: a 3x3 rig under the same name (and a later modification time).
  lf::save_rig(lf::synthetic_grid_rig(3, 3, 0.05, 64, 48, 40), file.string());
  fs::last_write_time(file, fs::last_write_time(file) + std::chrono::seconds(2));
  const auto d = lfgst::load_rig_cached(file.string());
  EXPECT_NE(a.get(), d.get());
  EXPECT_EQ(d->cameras.size(), 9u);
  EXPECT_EQ(lfgst::load_rig_cached(file.string()).get(), d.get());
  fs::remove_all(dir);
}

// Stream facts in caps: the compositor's output rate comes from the fragment
// caps' framerate (the request rate), and its deadline is one such period
// unless the latency property is set.
TEST_F(Harness, CompositorRateAndDeadlineFromFragmentCaps) {
  const lf::Rig one = rig_.subset({0});
  const std::string one_path =
      (std::filesystem::temp_directory_path() / "lf-harness-one-rate.json").string();
  lf::save_rig(one, one_path);
  for (const GstClockTime user_latency : {GstClockTime(0), GstClockTime(5 * GST_MSECOND)}) {
    GstElement* el = gst_element_factory_make("lfcompositor", nullptr);
    g_object_set(el, "rig", one_path.c_str(), "viewer-id", 3, "latency", user_latency, nullptr);
    GstHarness* h = gst_harness_new_with_element(el, "sink_0", "src");
    gst_harness_set_live(h, FALSE);
    gst_harness_set_src_caps_str(
        h, "application/x-lf-fragment,encoding=raw,framerate=15/1,width=80,height=60");
    const lf::ViewRequest req = request(2);
    const lf::ViewGeometry g(one, req);
    lf::Fragment f;
    f.viewer_id = req.viewer_id;
    f.sequence = 2;
    lf::render_fragment(lf::plan_fragment(g, 0), one.cameras[0],
                        lf::SyntheticScene::for_rig(one).render(one.cameras[0], 0.0), f);
    ASSERT_EQ(gst_harness_push(h, bytes(lf::serialize_fragment(f, lf::Encoding::kRaw), 0)),
              GST_FLOW_OK);
    GstBuffer* out = gst_harness_pull(h);
    ASSERT_NE(out, nullptr);
    GstCaps* caps = gst_pad_get_current_caps(h->sinkpad);
    gint n = 0, d = 0;
    ASSERT_TRUE(gst_structure_get_fraction(gst_caps_get_structure(caps, 0), "framerate", &n, &d));
    EXPECT_EQ(n, 15);
    EXPECT_EQ(d, 1);
    // The aggregator's latency: its property plus the element's own (one
    // period when the property is 0).
    GstQuery* q = gst_query_new_latency();
    gboolean live = FALSE;
    GstClockTime min = 0, max = 0;
    gst_harness_set_live(h, TRUE);
    ASSERT_TRUE(gst_pad_peer_query(h->sinkpad, q));
    {
      gst_query_parse_latency(q, &live, &min, &max);
      EXPECT_EQ(min, user_latency > 0 ? user_latency : GST_SECOND / 15) << user_latency;
    }
    gst_query_unref(q);
    gst_caps_unref(caps);
    gst_buffer_unref(out);
    gst_object_unref(el);
    gst_harness_teardown(h);
  }
}

// The custom events' codec (gst/lfevents.h): each structure round-trips
// with its version; a newer version, a missing or out-of-range field, or a
// surface whose sizes disagree is refused with a reason; an lf-view change
// is checked whole against lfviewrequest's properties.
TEST_F(Harness, EventCodecRoundTripsAndRefusesWhatIsWrong) {
  std::string why;
  lfgst::FocusAnswer f{3, 17, 0.125, 123456};
  GstStructure* s = lfgst::focus_structure(f);
  lfgst::FocusAnswer back;
  ASSERT_TRUE(lfgst::read_focus(s, &back, &why)) << why;
  EXPECT_EQ(back.viewer, 3u);
  EXPECT_EQ(back.probe, 17u);
  EXPECT_DOUBLE_EQ(back.inverse_depth, 0.125);
  EXPECT_EQ(back.capture_ns, 123456);
  gst_structure_set(s, "version", G_TYPE_UINT, lfgst::kEventVersion + 1, nullptr);
  EXPECT_FALSE(lfgst::read_focus(s, &back, &why));
  EXPECT_NE(why.find("version"), std::string::npos) << why;
  gst_structure_remove_field(s, "version");  // written before the field: version 1
  EXPECT_TRUE(lfgst::read_focus(s, &back, &why)) << why;
  gst_structure_set(s, "inverse-depth", G_TYPE_DOUBLE, -1.0, nullptr);
  EXPECT_FALSE(lfgst::read_focus(s, &back, &why));
  gst_structure_free(s);

  lfgst::SurfaceAnswer a;
  a.viewer = 2, a.probe = 5, a.capture_ns = 9, a.planes_used = 2;
  a.surface.tile = 16, a.surface.cols = 3, a.surface.rows = 2;
  a.surface.planes = {lf::FocalPlane::through({0, 0, 5}, {0, 0, 1}),
                      lf::FocalPlane::through({0, 0, 9}, {0, 0.1, 1})};
  a.surface.plane_of = {0, 1, 1, 0, 0, 1};
  a.surface.second_of = {255, 0, 255, 255, 1, 255};
  s = lfgst::surface_structure(a);
  lfgst::SurfaceAnswer b;
  ASSERT_TRUE(lfgst::read_surface(s, &b, &why)) << why;
  EXPECT_EQ(b.probe, 5u);
  EXPECT_EQ(b.planes_used, 2);
  EXPECT_EQ(b.surface.plane_of, a.surface.plane_of);
  EXPECT_EQ(b.surface.second_of, a.surface.second_of);
  ASSERT_EQ(b.surface.planes.size(), 2u);
  EXPECT_DOUBLE_EQ(b.surface.planes[1].d, a.surface.planes[1].d);
  gst_structure_set(s, "cols", G_TYPE_INT, 4, nullptr);  // plane-of no longer cols x rows
  EXPECT_FALSE(lfgst::read_surface(s, &b, &why));
  EXPECT_NE(why.find("plane-of"), std::string::npos) << why;
  gst_structure_free(s);

  GstElement* req = gst_element_factory_make("lfviewrequest", nullptr);
  ASSERT_NE(req, nullptr);
  std::vector<std::pair<GParamSpec*, GValue>> values;
  s = lfgst::view_change_structure({{"eye-s", 0.25}, {"focal-depth", 3.0}}, 4);
  ASSERT_TRUE(lfgst::read_view_change(s, G_OBJECT(req), 1e12, &values, &why)) << why;
  ASSERT_EQ(values.size(), 2u);
  EXPECT_STREQ(values[0].first->name, "eye-s");
  EXPECT_DOUBLE_EQ(g_value_get_double(&values[0].second), 0.25);
  for (auto& kv : values) g_value_unset(&kv.second);
  values.clear();
  guint viewer = 0;
  EXPECT_TRUE(gst_structure_get_uint(s, "viewer-id", &viewer) && viewer == 4);
  gst_structure_free(s);
  // Refused whole: an unknown field, a property fixed while playing, out of
  // range, the wrong type.
  for (GstStructure* bad :
       {gst_structure_new("lf-view", "eye-s", G_TYPE_DOUBLE, 0.1, "zoom", G_TYPE_DOUBLE, 2.0,
                          nullptr),
        gst_structure_new("lf-view", "width", G_TYPE_INT, 320, nullptr),
        gst_structure_new("lf-view", "vfov", G_TYPE_DOUBLE, 500.0, nullptr),
        gst_structure_new("lf-view", "eye-s", G_TYPE_STRING, "left", nullptr)}) {
    EXPECT_FALSE(lfgst::read_view_change(bad, G_OBJECT(req), 1e12, &values, &why))
        << gst_structure_to_string(bad);
    EXPECT_TRUE(values.empty());
    EXPECT_FALSE(why.empty());
    gst_structure_free(bad);
  }
  // The view-event action (what the C and Python examples call): fields of
  // any structure name, in the string form, written as a versioned lf-view
  // event in the properties' types; a bad field gives no event.
  GstStructure* fields = gst_structure_new_from_string(
      "fields, position=<1, 2.5, 0>, focal-depth=3, eye-s=0.25, viewer-id=7");
  GstEvent* event = nullptr;
  g_signal_emit_by_name(req, "view-event", fields, &event);
  ASSERT_NE(event, nullptr);
  EXPECT_EQ(GST_EVENT_TYPE(event), GST_EVENT_CUSTOM_UPSTREAM);
  const GstStructure* es = gst_event_get_structure(event);
  EXPECT_TRUE(gst_structure_has_name(es, "lf-view"));
  guint version = 0;
  EXPECT_TRUE(gst_structure_get_uint(es, "version", &version) && version == lfgst::kEventVersion);
  EXPECT_TRUE(gst_structure_get_uint(es, "viewer-id", &viewer) && viewer == 7);
  double depth = 0;  // written as the property's type: an int given, a double written
  EXPECT_TRUE(gst_structure_get_double(es, "focal-depth", &depth) && depth == 3.0);
  const GValue* pos = gst_structure_get_value(es, "position");
  ASSERT_TRUE(pos && GST_VALUE_HOLDS_ARRAY(pos) && gst_value_array_get_size(pos) == 3);
  EXPECT_DOUBLE_EQ(g_value_get_double(gst_value_array_get_value(pos, 1)), 2.5);
  ASSERT_TRUE(lfgst::read_view_change(es, G_OBJECT(req), 1e12, &values, &why)) << why;
  EXPECT_EQ(values.size(), 3u);
  for (auto& kv : values) g_value_unset(&kv.second);
  values.clear();
  gst_event_unref(event);
  gst_structure_free(fields);
  for (const char* bad : {"fields, focal-dept=2.0", "fields, focal-depth=-1.0",
                          "fields, position=<1, 2>", "fields, eye-s=0.1, viewer-id=left"}) {
    fields = gst_structure_new_from_string(bad);
    ASSERT_NE(fields, nullptr) << bad;
    event = nullptr;
    g_signal_emit_by_name(req, "view-event", fields, &event);
    EXPECT_EQ(event, nullptr) << bad;
    if (event) gst_event_unref(event);
    gst_structure_free(fields);
  }
  gst_object_unref(req);
}
