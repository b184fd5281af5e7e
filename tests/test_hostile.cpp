// Hostile input (issue "Hardening"): each case an attacker on the camera
// network could send, through real pipelines (appsrc into the elements,
// appsink out), asserting that the host keeps running, later legitimate
// frames still come out correctly, and memory stays bounded.
#include <gst/app/gstappsink.h>
#include <gst/app/gstappsrc.h>
#include <gst/gst.h>
#include <gst/rtp/gstrtpbuffer.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <thread>

#include "../tools/launch_guard.h"
#include "../tools/launch_srtp.h"
#include "calib/bundle.h"
#include "gst_init.h"
#include "lf/focus/focus.h"
#include "lf/focus/surface_probe.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/rig_file.h"
#include "lf/quality/synthetic.h"
#include "lf/render/composite.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"
#include "lf/wire/wire.h"

#ifdef LF_TEST_ASAN
#include <sanitizer/allocator_interface.h>
#endif

namespace {

namespace fs = std::filesystem;

// Resident set size of this process, MiB.
double rss_mib() {
  std::ifstream in("/proc/self/statm");
  long pages = 0, resident = 0;
  in >> pages >> resident;
  return resident * (sysconf(_SC_PAGESIZE) / 1048576.0);
}

// The memory the process holds: its RSS; under ASan, whose allocator keeps
// freed memory in quarantine and ignores malloc_trim, the bytes allocated
// and not freed (what the RSS would give back).
double held_mib() {
#ifdef LF_TEST_ASAN
  return static_cast<double>(__sanitizer_get_current_allocated_bytes()) / 1048576.0;
#else
  return rss_mib();
#endif
}

class Hostile : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    testing_lf::init_gstreamer_with_plugin();
    rig2_ = lf::synthetic_grid_rig(1, 2, 0.05, 64, 48, 40);
    rig1_ = rig2_.subset({0});
    rig1_path_ = (fs::temp_directory_path() / "lf-hostile-rig1.json").string();
    rig2_path_ = (fs::temp_directory_path() / "lf-hostile-rig2.json").string();
    lf::save_rig(rig1_, rig1_path_);
    lf::save_rig(rig2_, rig2_path_);
  }
  static lf::Rig rig1_, rig2_;
  static std::string rig1_path_, rig2_path_;

  static lf::ViewRequest request(const lf::Rig& rig, uint64_t seq, uint32_t viewer = 0, int w = 80,
                                 int h = 60) {
    lf::ViewRequest r;
    r.viewer_id = viewer;
    r.sequence = seq;
    r.view = lf::view_between_cameras(rig, rig.plane().origin + cv::Vec3d(0.01, 0.002, 0), w, h);
    r.focal_plane = lf::plane_at_depth(rig, 1.25);
    return r;
  }
  // Camera `index`'s real fragment of `req`.
  static lf::Fragment fragment(const lf::Rig& rig, const lf::ViewRequest& req, int index) {
    const lf::ViewGeometry g(rig, req);
    lf::Fragment f;
    f.viewer_id = req.viewer_id;
    f.sequence = req.sequence;
    f.camera_id = rig.cameras[index].id;
    lf::render_fragment(lf::plan_fragment(g, index), rig.cameras[index],
                        lf::SyntheticScene::for_rig(rig).render(rig.cameras[index], 0.0), f);
    return f;
  }
  static lf::Fragment empty(uint32_t camera, uint64_t seq, uint32_t viewer, int w, int h) {
    lf::Fragment f;
    f.camera_id = camera;
    f.sequence = seq;
    f.viewer_id = viewer;
    f.out_width = w;
    f.out_height = h;
    return f;
  }
  static void push(GstElement* appsrc, const std::vector<uint8_t>& bytes, GstClockTime pts = 0) {
    GstBuffer* b = gst_buffer_new_memdup(bytes.data(), bytes.size());
    GST_BUFFER_PTS(b) = pts;
    ASSERT_EQ(gst_app_src_push_buffer(GST_APP_SRC(appsrc), b), GST_FLOW_OK);
  }
  // Viewer 1 floods 60 requests (of flood_w x flood_h), viewer 0 then sends 5
  // (80x60), and the stream ends; counts the fragments of each that come out
  // of the camera until none has come for 3 s. Returns the seconds it took.
  static double flood_and_count(const lf::Rig& rig, GstElement* src, GstElement* sink, int flood_w,
                                int flood_h, int answered[2]) {
    const auto t0 = std::chrono::steady_clock::now();
    for (uint64_t s = 1; s <= 60; ++s)
      push(src, lf::serialize_request(request(rig, s, 1, flood_w, flood_h)));
    for (uint64_t s = 1; s <= 5; ++s) push(src, lf::serialize_request(request(rig, s, 0)));
    gst_app_src_end_of_stream(GST_APP_SRC(src));
    while (GstSample* smp = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 3 * GST_SECOND)) {
      GstMapInfo m;
      GstBuffer* b = gst_sample_get_buffer(smp);
      gst_buffer_map(b, &m, GST_MAP_READ);
      const lf::FragmentHeader h = lf::peek_fragment_header(m.data, m.size);
      if (h.viewer_id < 2) ++answered[h.viewer_id];
      gst_buffer_unmap(b, &m);
      gst_sample_unref(smp);
    }
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  // Pulls one frame; its request sequence (buffer offset), or -1 on time-out.
  static int64_t pull(GstElement* sink, cv::Mat* rgba = nullptr, double seconds = 5) {
    GstSample* s =
        gst_app_sink_try_pull_sample(GST_APP_SINK(sink), static_cast<GstClockTime>(seconds * 1e9));
    if (!s) return -1;
    GstBuffer* b = gst_sample_get_buffer(s);
    const int64_t seq = static_cast<int64_t>(GST_BUFFER_OFFSET(b));
    if (rgba) {
      GstStructure* st = gst_caps_get_structure(gst_sample_get_caps(s), 0);
      int w = 0, h = 0;
      gst_structure_get_int(st, "width", &w);
      gst_structure_get_int(st, "height", &h);
      GstMapInfo m;
      gst_buffer_map(b, &m, GST_MAP_READ);
      if (m.size == static_cast<size_t>(w) * h * 4) cv::Mat(h, w, CV_8UC4, m.data).copyTo(*rgba);
      gst_buffer_unmap(b, &m);
    }
    gst_sample_unref(s);
    return seq;
  }

  // appsrc (fragments) ! lfcompositor ! [filter] ! appsink.
  struct Compositor {
    GstElement *pipe = nullptr, *src = nullptr, *sink = nullptr;
    Compositor(const std::string& rig, const std::string& comp_props,
               const std::string& filter = "",
               const std::string& caps =
                   "application/x-lf-fragment,encoding=raw,width=80,height=60,framerate=30/1",
               const std::string& src_props = "") {
      const std::string desc = "appsrc name=in format=time " + src_props + " caps=" + caps +
                               " ! lfcompositor name=c rig=" + rig + " " + comp_props + " ! " +
                               (filter.empty() ? "" : filter + " ! ") +
                               "appsink name=out sync=false max-buffers=64";
      pipe = gst_parse_launch(desc.c_str(), nullptr);
      src = gst_bin_get_by_name(GST_BIN(pipe), "in");
      sink = gst_bin_get_by_name(GST_BIN(pipe), "out");
      gst_element_set_state(pipe, GST_STATE_PLAYING);
    }
    ~Compositor() {
      gst_element_set_state(pipe, GST_STATE_NULL);
      gst_object_unref(src);
      gst_object_unref(sink);
      gst_object_unref(pipe);
    }
    bool error() const {
      GstBus* bus = gst_element_get_bus(pipe);
      GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR);
      gst_object_unref(bus);
      if (m) gst_message_unref(m);
      return m != nullptr;
    }
  };

  // A live one (appsrc is-live) compositing viewer 0's views of w x h at 30/1.
  struct LiveCompositor : Compositor {
    LiveCompositor(const std::string& rig, const std::string& props, int w = 80, int h = 60)
        : Compositor(rig, "viewer-id=0 " + props, "",
                     "application/x-lf-fragment,encoding=raw,width=" + std::to_string(w) +
                         ",height=" + std::to_string(h) + ",framerate=30/1",
                     "is-live=true") {}
  };

  // appsrc (requests) ! lffragment (frames from lfcamsrc) ! appsink.
  struct Camera {
    GstElement *pipe = nullptr, *src = nullptr, *sink = nullptr;
    explicit Camera(const std::string& rig, const std::string& frag_props = "",
                    bool with_frames = true, const std::string& cam_props = "") {
      std::string desc =
          "appsrc name=in format=time caps=application/x-lf-view-request ! f.request "
          "lffragment name=f rig=" +
          rig + " camera-id=0 " + frag_props + " ! appsink name=out sync=false";
      if (with_frames)
        desc += " lfcamsrc rig=" + rig + " camera-id=0 mode=synthetic num-buffers=1 " + cam_props +
                " ! f.sink";
      pipe = gst_parse_launch(desc.c_str(), nullptr);
      src = gst_bin_get_by_name(GST_BIN(pipe), "in");
      sink = gst_bin_get_by_name(GST_BIN(pipe), "out");
      gst_element_set_state(pipe, GST_STATE_PLAYING);
    }
    ~Camera() {
      gst_element_set_state(pipe, GST_STATE_NULL);
      gst_object_unref(src);
      gst_object_unref(sink);
      gst_object_unref(pipe);
    }
    // Messages of `type` posted so far (each message is counted once: the
    // bus is drained into the tallies).
    int count(GstMessageType type) {
      GstBus* bus = gst_element_get_bus(pipe);
      while (GstMessage* m = gst_bus_pop(bus)) {
        if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ERROR) ++errors;
        if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_WARNING) ++warnings;
        gst_message_unref(m);
      }
      gst_object_unref(bus);
      return type == GST_MESSAGE_ERROR ? errors : warnings;
    }
    int errors = 0, warnings = 0;
  };
};
lf::Rig Hostile::rig1_, Hostile::rig2_;
std::string Hostile::rig1_path_, Hostile::rig2_path_;

// 1. Empty fragments with sequence 2^63-1: after a legitimate stream they are
// outside the window and ignored; as the very first fragment they anchor the
// window, and the legitimate stream is followed again as soon as two
// consecutive requests of it confirm the new window (RFC 3550 A.1 style).
TEST_F(Hostile, HugeSequenceNeitherStopsNorFreezesTheOutput) {
  const uint64_t huge = (uint64_t{1} << 63) - 1;
  {
    Compositor c(rig1_path_, "viewer-id=0");
    for (uint64_t s = 1; s <= 3; ++s) {
      push(c.src,
           lf::serialize_fragment(fragment(rig1_, request(rig1_, s), 0), lf::Encoding::kRaw));
      EXPECT_EQ(pull(c.sink), static_cast<int64_t>(s));
    }
    for (int k = 0; k < 4; ++k)
      push(c.src, lf::serialize_fragment(empty(rig1_.cameras[0].id, huge, 0, 80, 60),
                                         lf::Encoding::kEmpty));
    for (uint64_t s = 4; s <= 6; ++s) {
      push(c.src,
           lf::serialize_fragment(fragment(rig1_, request(rig1_, s), 0), lf::Encoding::kRaw));
      EXPECT_EQ(pull(c.sink), static_cast<int64_t>(s)) << "legitimate request after the attack";
    }
  }
  {
    Compositor c(rig1_path_, "viewer-id=0");
    push(c.src,
         lf::serialize_fragment(empty(rig1_.cameras[0].id, huge, 0, 80, 60), lf::Encoding::kEmpty));
    EXPECT_EQ(pull(c.sink), static_cast<int64_t>(huge));  // the attacker's frame (blank)
    const auto t0 = std::chrono::steady_clock::now();
    int64_t got = -1;
    for (uint64_t s = 1; s <= 60 && got < 0; ++s) {
      push(c.src,
           lf::serialize_fragment(fragment(rig1_, request(rig1_, s), 0), lf::Encoding::kRaw));
      got = pull(c.sink, nullptr, 0.05);
    }
    const double waited =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_GT(got, 0) << "the legitimate stream is followed again";
    EXPECT_LT(waited, 2.5) << "at once: two consecutive real requests confirm the new window";
    EXPECT_LE(got, 3) << "the second consecutive real request moves the window";
    // And from then on every request comes out.
    for (uint64_t s = got + 1; s <= static_cast<uint64_t>(got) + 3; ++s) {
      push(c.src,
           lf::serialize_fragment(fragment(rig1_, request(rig1_, s), 0), lf::Encoding::kRaw));
      EXPECT_EQ(pull(c.sink), static_cast<int64_t>(s));
    }
  }
}

// 1b. Forged fragments carrying the real stream's identity (plain RTP, the
// documented SSRC), as an attacker on the camera network sends them: every
// third request, one forged fragment of camera 0, 4000 requests ahead, or
// 1..10 ahead with pixels of its own (magenta). The window never moves
// (RFC 3550 A.1-style probation: no single fragment moves it), every real
// request comes out once and in order, and no forged pixel reaches a
// frame: a request that got two fragments of camera 0 uses neither.
TEST_F(Hostile, ForgedFragmentsNeitherMoveTheWindowNorEnterAFrame) {
  constexpr uint64_t kRequests = 60;
  auto real = [&](uint64_t seq, int index) {
    return lf::serialize_fragment(fragment(rig2_, request(rig2_, seq), index), lf::Encoding::kRaw);
  };
  // The frames of a run, by request sequence (all pushed, then EOS).
  auto run = [&](bool attack, std::set<uint64_t>* conflicted) {
    std::map<int64_t, cv::Mat> frames;
    Compositor c(rig2_path_, "viewer-id=0");
    int step = 0;
    for (uint64_t seq = 1; seq <= kRequests; ++seq) {
      if (attack && seq % 3 == 0) {
        const uint64_t ahead = step % 3 == 0 ? 4000 : 1 + step % 10;
        ++step;
        const uint64_t target = seq + ahead;
        if (ahead == 4000) {
          push(c.src, lf::serialize_fragment(empty(rig2_.cameras[0].id, target, 0, 80, 60),
                                             lf::Encoding::kEmpty));
        } else if (target <= kRequests) {
          lf::Fragment f = fragment(rig2_, request(rig2_, target), 0);
          for (size_t i = 0; i + 3 < f.pixels.size(); i += 4)
            f.pixels[i] = f.pixels[i + 3], f.pixels[i + 1] = 0, f.pixels[i + 2] = f.pixels[i + 3];
          push(c.src, lf::serialize_fragment(f, lf::Encoding::kRaw));
          conflicted->insert(target);
        }
      }
      push(c.src, real(seq, 0));
      push(c.src, real(seq, 1));
    }
    gst_app_src_end_of_stream(GST_APP_SRC(c.src));
    for (;;) {
      cv::Mat rgba;
      const int64_t seq = pull(c.sink, &rgba, 10);
      if (seq < 0) break;
      EXPECT_EQ(frames.count(seq), 0u) << "request " << seq << " came out twice";
      EXPECT_TRUE(frames.empty() || seq > frames.rbegin()->first) << "out of order: " << seq;
      frames[seq] = rgba;
    }
    return frames;
  };
  std::set<uint64_t> conflicted, none;
  const auto clean = run(false, &none);
  const auto attacked = run(true, &conflicted);
  ASSERT_EQ(clean.size(), kRequests);
  ASSERT_EQ(attacked.size(), kRequests) << "every real request, and nothing else, came out";
  EXPECT_GE(conflicted.size(), 8u);
  size_t identical = 0;
  for (const auto& [seq, frame] : attacked) {
    ASSERT_TRUE(seq >= 1 && seq <= static_cast<int64_t>(kRequests)) << seq;
    ASSERT_FALSE(frame.empty());
    // No forged pixel: none pulled towards magenta (red and blue up, green
    // down, each by over 50 levels) from the clean run's frame.
    cv::Mat a, c;
    frame.convertTo(a, CV_16SC4);
    clean.at(seq).convertTo(c, CV_16SC4);
    std::vector<cv::Mat> d;
    cv::split(a - c, d);
    const cv::Mat magenta = (d[0] > 50) & (d[1] < -50) & (d[2] > 50);
    EXPECT_EQ(cv::countNonZero(magenta), 0) << "forged pixels in frame " << seq;
    const double diff = cv::norm(frame, clean.at(seq), cv::NORM_INF);
    if (!conflicted.count(static_cast<uint64_t>(seq))) {
      EXPECT_EQ(diff, 0) << "frame " << seq << " differs from the clean run";
      ++identical;
    }
  }
  EXPECT_EQ(identical, kRequests - conflicted.size());
}

// 2 and 6. Requests for huge views (raw 4096x4096 exceeds the wire format's
// payload cap; JPEG 16384x16384 would take gigabytes): dropped with a
// warning by the camera host, which keeps answering legitimate requests.
TEST_F(Hostile, HugeRequestsAreDroppedNotFatal) {
  for (const char* enc : {"encoding=raw", "encoding=jpeg"}) {
    Camera cam(rig1_path_, enc);
    const double rss0 = rss_mib();
    const auto t0 = std::chrono::steady_clock::now();
    push(cam.src, lf::serialize_request(request(rig1_, 1, 0, 4096, 4096)));
    push(cam.src, lf::serialize_request(request(rig1_, 2, 0, 16384, 16384)));
    push(cam.src, lf::serialize_request(request(rig1_, 3)));
    EXPECT_EQ(pull(cam.sink), 3) << enc;  // only the legitimate one
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_LT(secs, 2.0) << enc;
    EXPECT_LT(rss_mib() - rss0, 64.0) << enc;
    EXPECT_EQ(cam.count(GST_MESSAGE_ERROR), 0) << enc;
    EXPECT_GE(cam.count(GST_MESSAGE_WARNING), 1) << enc;
  }
}

// 2b. One viewer's flood of requests spends its own max-rate, never another
// viewer's (before, one bucket for all viewers: the flood took the other
// viewer's requests with it).
TEST_F(Hostile, OneViewersFloodLeavesAnotherItsRequests) {
  Camera cam(rig1_path_, "max-rate=10");
  int answered[2] = {0, 0};
  const double secs = flood_and_count(rig1_, cam.src, cam.sink, 80, 60, answered);
  EXPECT_EQ(answered[0], 5) << "the quiet viewer's requests all pass";
  EXPECT_GE(answered[1], 10);
  EXPECT_LE(answered[1], 10 + static_cast<int>(10 * secs) + 1) << "the flood is cut at max-rate";
  EXPECT_GE(cam.count(GST_MESSAGE_WARNING), 1);
}

// Requests are priced in output pixels too (max-pixel-rate): a viewer of
// large views (here 640x480, 64 times the quiet viewer's 80x60) spends its
// own pixel budget of ten such views a second, never the quiet viewer's,
// although it stays under max-rate. (Live: a non-live pipeline renders
// every request.)
TEST_F(Hostile, OneViewersLargeViewsLeaveAnotherItsPixels) {
  const double budget = 10.0 * 640 * 480;
  Camera cam(rig1_path_, "max-rate=1000 max-pixel-rate=" + std::to_string(budget), true,
             "is-live=true");
  int answered[2] = {0, 0};
  const double secs = flood_and_count(rig1_, cam.src, cam.sink, 640, 480, answered);
  EXPECT_EQ(answered[0], 5) << "the quiet viewer's requests all pass";
  EXPECT_GE(answered[1], 10);
  EXPECT_LE(answered[1], 10 + static_cast<int>(10 * secs) + 1)
      << "the large views are cut at max-pixel-rate";
  EXPECT_GE(cam.count(GST_MESSAGE_WARNING), 1);
}

// The compositor host keeps the pixel budget again (lfcompositor
// max-pixel-rate, live): a flood of requests the camera hosts let through
// (here 60 at once, fragments straight in) is composited up to a second's
// budget plus what refills meanwhile, each over it dropped whole with a
// warning and counted; the frames that come out are whole requests.
TEST_F(Hostile, TheCompositorKeepsItsPixelBudget) {
  const double budget = 10.0 * 80 * 60;  // ten 80x60 requests a second
  LiveCompositor c(rig1_path_, "max-pixel-rate=" + std::to_string(budget));
  const auto t0 = std::chrono::steady_clock::now();
  for (uint64_t seq = 1; seq <= 60; ++seq)
    push(c.src, lf::serialize_fragment(fragment(rig1_, request(rig1_, seq), 0), lf::Encoding::kRaw),
         0);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  int frames = 0;
  while (pull(c.sink, nullptr, 1.0) >= 0) ++frames;
  guint64 over = 0;
  GstElement* comp = gst_bin_get_by_name(GST_BIN(c.pipe), "c");
  g_object_get(comp, "over-budget", &over, nullptr);
  gst_object_unref(comp);
  EXPECT_GE(frames, 10);
  EXPECT_LE(frames, 10 + static_cast<int>(10 * secs) + 1) << "the flood is cut at max-pixel-rate";
  EXPECT_EQ(static_cast<guint64>(frames) + over, 60u) << "every request composited or counted";
  GstBus* bus = gst_element_get_bus(c.pipe);
  GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_WARNING);
  ASSERT_NE(m, nullptr);
  GError* err = nullptr;
  gst_message_parse_warning(m, &err, nullptr);
  EXPECT_STREQ(err->message, "Dropping requests above max-pixel-rate");
  g_error_free(err);
  gst_message_unref(m);
  gst_object_unref(bus);
  EXPECT_FALSE(c.error());
}

// The compositor reports the rate it achieves once a second (an lf-rate
// element message, gst/lfevents.h): frames composited a second and of them
// complete, against the viewer's request rate (the caps' 30/1), and the
// requests dropped over its budget. Fragments of a one-camera rig at about
// 20 a second: every frame complete, about 20 a second.
TEST_F(Hostile, TheCompositorReportsTheRateItAchieves) {
  LiveCompositor c(rig1_path_, "");
  GstBus* bus = gst_element_get_bus(c.pipe);
  const GstStructure* s = nullptr;
  GstMessage* m = nullptr;
  for (uint64_t seq = 1; seq <= 80 && !s; ++seq) {
    push(c.src,
         lf::serialize_fragment(fragment(rig1_, request(rig1_, seq), 0), lf::Encoding::kRaw));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    while (!s && (m = gst_bus_pop_filtered(bus, GST_MESSAGE_ELEMENT))) {
      if (gst_message_has_name(m, "lf-rate"))
        s = gst_message_get_structure(m);
      else
        gst_message_unref(m);
    }
  }
  ASSERT_NE(s, nullptr) << "no lf-rate message in 4 s of frames";
  double requested = 0, fps = 0, complete = 0, interval = 0;
  gint64 viewer = -2;
  guint64 over = 1;
  ASSERT_TRUE(gst_structure_get(s, "viewer-id", G_TYPE_INT64, &viewer, "requested-fps",
                                G_TYPE_DOUBLE, &requested, "fps", G_TYPE_DOUBLE, &fps,
                                "complete-fps", G_TYPE_DOUBLE, &complete, "interval", G_TYPE_DOUBLE,
                                &interval, "over-budget", G_TYPE_UINT64, &over, nullptr));
  EXPECT_EQ(viewer, 0);
  EXPECT_DOUBLE_EQ(requested, 30.0);
  EXPECT_GE(interval, 1.0);
  EXPECT_LT(interval, 1.5);
  EXPECT_GT(fps, 8.0) << "about 20 fragments a second went in";
  EXPECT_LE(fps, 21.0);
  EXPECT_DOUBLE_EQ(complete, fps) << "one camera: every frame complete";
  EXPECT_EQ(over, 0u);
  gst_message_unref(m);
  gst_object_unref(bus);
  EXPECT_FALSE(c.error());
}

// A live compositor whose viewer went quiet frees its frames (LF_IDLE_RELEASE,
// 2 s, after its last output) and trims the heap: the memory of a viewer's
// 3840x2160 frames (31.6 MiB each: the last frame shown, the frame being
// composited, the output pool) does not stay with the process after a
// flood. (Its sums never take a frame's memory: lf::Compositor::composite
// keeps them band by band in cache; before it did, they were 127 MiB more
// to free, and the thresholds were 150 and 100 MiB.) Measured: 58 MiB
// before, 217-252 with the frames, 125-157 after going quiet, nine runs;
// under ASan 6, 198 and 103-135 MiB allocated. The memory with the frames
// is the peak read every 5 ms by a thread of its own while they are made:
// on a loaded machine (a sanitizer build beside other suites took 12.8 s
// for the three frames) the release can come before the test thread reads
// it.
TEST_F(Hostile, AQuietViewersCompositorGivesItsMemoryBack) {
  LiveCompositor c(rig1_path_, "", 3840, 2160);
  const double rss0 = held_mib();
  std::atomic<bool> sampling{true};
  std::atomic<double> peak{rss0};
  std::thread sampler([&] {
    while (sampling) {
      const double m = held_mib();
      if (m > peak) peak = m;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  for (uint64_t seq = 1; seq <= 3; ++seq)
    push(c.src, lf::serialize_fragment(fragment(rig1_, request(rig1_, seq, 0, 3840, 2160), 0),
                                       lf::Encoding::kRaw));
  int pulled = 0;
  while (pulled < 3 && pull(c.sink) >= 0) ++pulled;
  sampling = false;
  sampler.join();
  ASSERT_EQ(pulled, 3) << "three frames out";
  const double busy = std::max(peak.load(), held_mib());
  double rss = held_mib();
  constexpr double kFrameMib = 3840.0 * 2160 * 4 / (1 << 20);
  for (int i = 0; i < 100 && rss > busy - 1.5 * kFrameMib; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    rss = held_mib();
  }
  std::printf("4K viewer: %.0f MiB before, %.0f with its frames, %.0f after going quiet\n", rss0,
              busy, rss);
  EXPECT_GT(busy - rss0, 3.5 * kFrameMib) << "the 4K frames took their memory";
  EXPECT_LT(rss, busy - 1.5 * kFrameMib)
      << "freed within 10 s of the last frame (MiB before, during, after: " << rss0 << ", " << busy
      << ", " << rss << ")";
  EXPECT_FALSE(c.error());
}

// 3. Fragments announcing another output size (8192x8192, 16384x16384, 2x2):
// the output size comes from the caps; they are dropped before decoding, no
// allocation follows them, and legitimate fragments are composited.
TEST_F(Hostile, FragmentsDoNotChooseTheOutputSize) {
  Compositor c(rig1_path_, "viewer-id=0");
  const double rss0 = rss_mib();
  for (int side : {8192, 16384, 2})
    for (int k = 0; k < 4; ++k)
      push(c.src, lf::serialize_fragment(empty(rig1_.cameras[0].id, 1, 0, side, side),
                                         lf::Encoding::kEmpty));
  push(c.src, lf::serialize_fragment(fragment(rig1_, request(rig1_, 1), 0), lf::Encoding::kRaw));
  cv::Mat frame;
  EXPECT_EQ(pull(c.sink, &frame), 1);
  EXPECT_EQ(frame.cols, 80);
  EXPECT_EQ(frame.rows, 60);
  EXPECT_LT(rss_mib() - rss0, 64.0);
  EXPECT_FALSE(c.error());
}

// 4. An odd output size with I420 downstream: converted by GStreamer's
// converter, no exception, frames keep coming.
TEST_F(Hostile, OddSizeWithI420Downstream) {
  Compositor c(rig1_path_, "viewer-id=0", "video/x-raw,format=I420",
               "application/x-lf-fragment,encoding=raw,width=641,height=481");
  for (uint64_t s = 1; s <= 2; ++s) {
    push(c.src, lf::serialize_fragment(fragment(rig1_, request(rig1_, s, 0, 641, 481), 0),
                                       lf::Encoding::kRaw));
    EXPECT_EQ(pull(c.sink), static_cast<int64_t>(s));
  }
  EXPECT_FALSE(c.error());
}

// 5. A JPEG fragment claiming a huge rectangle: refused from its header,
// before decoding, in bounded time (the frame area is the parser's limit).
TEST_F(Hostile, HugeJpegFragmentIsRefusedBeforeDecoding) {
  // A real JPEG fragment of a 4096x4096 view, then fed to an 80x60 compositor.
  lf::Fragment big = fragment(rig1_, request(rig1_, 1, 0, 4096, 4096), 0);
  ASSERT_GT(big.rect.area(), 80 * 60);
  const std::vector<uint8_t> bytes = lf::serialize_fragment(big, lf::Encoding::kJpeg, 90);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_THROW(lf::parse_fragment(bytes.data(), bytes.size(), nullptr, 80 * 60), lf::WireError);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 0.05);
  Compositor c(rig1_path_, "viewer-id=0");
  push(c.src, bytes);
  push(c.src, lf::serialize_fragment(fragment(rig1_, request(rig1_, 2), 0), lf::Encoding::kJpeg));
  EXPECT_EQ(pull(c.sink), 2);
  EXPECT_FALSE(c.error());
}

// 5b. JPEG fragments are decoded on the thread that brings them, before the
// aggregator queues them, once the compositor has said what it takes (its
// viewer, the view's area, the sequence window): a frame from them equals
// one decoded on the aggregate thread, bit for bit. What it would not
// composite (another viewer, a request already emitted, a corrupt fragment,
// a rectangle larger than the view) goes on undecoded and is refused there
// with a warning, as before; legitimate fragments keep coming out.
TEST_F(Hostile, JpegFragmentsAreDecodedOnArrivalOnlyWhenAccepted) {
  Compositor c(rig1_path_, "viewer-id=0", "",
               "application/x-lf-fragment,encoding=jpeg,width=80,height=60,framerate=30/1");
  // What reaches the aggregator's queue: a probe after the compositor's own.
  struct Seen {
    std::mutex m;
    std::vector<lf::Encoding> encodings;
  } seen;
  GstElement* comp = gst_bin_get_by_name(GST_BIN(c.pipe), "c");
  GstPad* pad = gst_element_get_static_pad(comp, "sink_0");
  ASSERT_NE(pad, nullptr);
  testing_lf::on_each_buffer(pad, [&seen](const guint8* data, gsize size) {
    const lf::Encoding e = lf::peek_fragment_header(data, size).encoding;
    std::lock_guard<std::mutex> lock(seen.m);
    seen.encodings.push_back(e);
  });
  auto jpeg = [&](uint64_t seq, uint32_t viewer = 0) {
    return lf::serialize_fragment(fragment(rig1_, request(rig1_, seq, viewer), 0),
                                  lf::Encoding::kJpeg, 90);
  };
  auto last_seen = [&] {
    std::lock_guard<std::mutex> lock(seen.m);
    return seen.encodings.empty() ? lf::Encoding::kEmpty : seen.encodings.back();
  };
  auto seen_count = [&] {
    std::lock_guard<std::mutex> lock(seen.m);
    return seen.encodings.size();
  };
  // The first: nothing accepted yet, decoded on the aggregate thread.
  cv::Mat first, second, third;
  push(c.src, jpeg(1));
  ASSERT_EQ(pull(c.sink, &first), 1);
  EXPECT_EQ(last_seen(), lf::Encoding::kJpeg);
  // The next: decoded on arrival, the same frame.
  push(c.src, jpeg(2));
  ASSERT_EQ(pull(c.sink, &second), 2);
  EXPECT_EQ(last_seen(), lf::Encoding::kRaw);
  ASSERT_FALSE(first.empty());
  EXPECT_EQ(cv::norm(first, second, cv::NORM_INF), 0.0);
  // Not decoded: a request already emitted, another viewer's fragment, a
  // corrupt one, one larger than the view.
  std::vector<uint8_t> corrupt = jpeg(3);
  corrupt[corrupt.size() / 2] ^= 0x40;
  std::vector<std::vector<uint8_t>> refused = {
      jpeg(2), jpeg(3, /*viewer=*/5), corrupt,
      lf::serialize_fragment(fragment(rig1_, request(rig1_, 3, 0, 4096, 4096), 0),
                             lf::Encoding::kJpeg, 90)};
  const size_t before = seen_count();
  for (const auto& bytes : refused) push(c.src, bytes);
  push(c.src, jpeg(3));
  ASSERT_EQ(pull(c.sink, &third), 3);
  {
    std::lock_guard<std::mutex> lock(seen.m);
    ASSERT_EQ(seen.encodings.size(), before + refused.size() + 1);
    for (size_t k = 0; k < refused.size(); ++k)
      EXPECT_EQ(seen.encodings[before + k], lf::Encoding::kJpeg) << "fragment " << k;
    EXPECT_EQ(seen.encodings.back(), lf::Encoding::kRaw);
  }
  EXPECT_EQ(cv::norm(first, third, cv::NORM_INF), 0.0);
  GstBus* bus = gst_element_get_bus(c.pipe);
  int warnings = 0;
  while (GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_WARNING)) {
    ++warnings;
    gst_message_unref(m);
  }
  gst_object_unref(bus);
  EXPECT_GE(warnings, 2) << "the corrupt and the oversized fragment";
  EXPECT_FALSE(c.error());
  gst_object_unref(pad);
  gst_object_unref(comp);
}

// 7. A request before the first camera frame, then NULL: no deadlock; a
// camera that never delivers: the request is dropped after frame-timeout;
// a seek is refused and the pipeline keeps running.
TEST_F(Hostile, NoHangWithoutFramesOrOnSeek) {
  {
    Camera cam(rig1_path_, "frame-timeout=200000000", /*with_frames=*/false);
    push(cam.src, lf::serialize_request(request(rig1_, 1)));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const auto t0 = std::chrono::steady_clock::now();
    gst_element_set_state(cam.pipe, GST_STATE_NULL);
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0);
  }
  {
    Camera cam(rig1_path_, "frame-timeout=200000000", /*with_frames=*/false);
    push(cam.src, lf::serialize_request(request(rig1_, 1)));
    push(cam.src, lf::serialize_request(request(rig1_, 2)));
    // "No camera frame: dropping the request" after 0.2 s (polled: the
    // machine may be busy).
    for (int i = 0; i < 100 && cam.count(GST_MESSAGE_WARNING) < 1; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_GE(cam.count(GST_MESSAGE_WARNING), 1);
    EXPECT_EQ(cam.count(GST_MESSAGE_ERROR), 0);
  }
  {
    Compositor c(rig1_path_, "viewer-id=0");
    push(c.src, lf::serialize_fragment(fragment(rig1_, request(rig1_, 1), 0), lf::Encoding::kRaw));
    EXPECT_EQ(pull(c.sink), 1);
    EXPECT_FALSE(gst_element_seek_simple(c.pipe, GST_FORMAT_TIME, GST_SEEK_FLAG_FLUSH, 0));
    push(c.src, lf::serialize_fragment(fragment(rig1_, request(rig1_, 2), 0), lf::Encoding::kRaw));
    EXPECT_EQ(pull(c.sink), 2);
  }
}

// 8. Another viewer's fragments with the same sequence never enter this
// viewer's frame.
TEST_F(Hostile, ViewersNeverMix) {
  Compositor c(rig2_path_, "");  // default viewer-id 0
  const lf::ViewRequest mine = request(rig2_, 1, 0);
  lf::ViewRequest other = request(rig2_, 1, 1);
  other.view.position += cv::Vec3d(0.04, 0, 0);
  push(c.src, lf::serialize_fragment(fragment(rig2_, other, 0), lf::Encoding::kRaw));
  push(c.src, lf::serialize_fragment(fragment(rig2_, other, 1), lf::Encoding::kRaw));
  push(c.src, lf::serialize_fragment(fragment(rig2_, mine, 0), lf::Encoding::kRaw));
  push(c.src, lf::serialize_fragment(fragment(rig2_, mine, 1), lf::Encoding::kRaw));
  cv::Mat frame, ref;
  ASSERT_EQ(pull(c.sink, &frame), 1);
  lf::Compositor comp;
  comp.reset(80, 60);
  comp.add(fragment(rig2_, mine, 0));
  comp.add(fragment(rig2_, mine, 1));
  comp.resolve(ref);
  EXPECT_EQ(cv::norm(frame, ref, cv::NORM_INF), 0);
}

// 9. A frame composited without some of its fragments shows the last
// picture where no weight arrived, not black.
TEST_F(Hostile, MissingFragmentsShowTheLastPictureNotBlack) {
  Compositor c(rig2_path_, "viewer-id=0");
  push(c.src, lf::serialize_fragment(fragment(rig2_, request(rig2_, 1), 0), lf::Encoding::kRaw));
  push(c.src, lf::serialize_fragment(fragment(rig2_, request(rig2_, 1), 1), lf::Encoding::kRaw));
  cv::Mat a, b;
  ASSERT_EQ(pull(c.sink, &a), 1);
  // Request 2: only camera 0 answers; the stream ends (incomplete frame).
  lf::ViewRequest r2 = request(rig2_, 2);
  const lf::Fragment only = fragment(rig2_, r2, 0);
  push(c.src, lf::serialize_fragment(only, lf::Encoding::kRaw));
  gst_app_src_end_of_stream(GST_APP_SRC(c.src));
  ASSERT_EQ(pull(c.sink, &b), 2);
  std::vector<cv::Mat> ca, cb;
  cv::split(a, ca);
  cv::split(b, cb);
  // Pixels with colour in frame 1 are never black in frame 2.
  const cv::Mat lost = (ca[3] > 0) & (cb[3] == 0);
  EXPECT_EQ(cv::countNonZero(lost), 0);
  // Camera 0's own pixels are frame 2's, not frame 1's: some differ from a
  // plain copy of frame 1 only if the views differ; here they are the same
  // view, so frame 2 equals frame 1 where camera 1 was missing.
  EXPECT_GT(cv::countNonZero(cb[3]), 0);
}

// A camera's two layers in one buffer (lib/lf/wire/wire.h): a second fragment
// that is not the same camera's layer 1 of the same request, or bytes that
// are not a whole fragment, drop the buffer with a warning; it does not
// count as the camera's answer, and a good pair composites.
TEST_F(Hostile, MalformedLayerPairsAreDroppedNotCounted) {
  Compositor c(rig2_path_, "viewer-id=0");
  const lf::ViewRequest r = request(rig2_, 1);
  const lf::Fragment f0 = fragment(rig2_, r, 0), f1 = fragment(rig2_, r, 1);
  auto bytes = [](const lf::Fragment& f, int layer) {
    lf::Fragment g = f;
    g.layer = static_cast<uint8_t>(layer);
    return lf::serialize_fragment(g, lf::Encoding::kRaw);
  };
  auto pair = [](std::vector<uint8_t> a, const std::vector<uint8_t>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
  };
  push(c.src, pair(bytes(f0, 0), bytes(f1, 1)));     // another camera's layer 1
  push(c.src, pair(bytes(f0, 0), bytes(f0, 0)));     // layer 0 twice
  push(c.src, pair(bytes(f0, 1), bytes(f0, 0)));     // layers in the wrong order
  push(c.src, pair(bytes(f0, 0), {'L', 'F', 'F'}));  // a truncated second fragment
  lf::Fragment other = f0;
  other.sequence = 2;
  push(c.src, pair(bytes(f0, 0), bytes(other, 1)));  // another request's layer 1
  push(c.src, bytes(f1, 0));
  // Camera 0 has not answered: request 1 is not complete.
  EXPECT_EQ(pull(c.sink, nullptr, 0.5), -1);
  cv::Mat frame;
  push(c.src, pair(bytes(f0, 0), bytes(f0, 1)));
  ASSERT_EQ(pull(c.sink, &frame), 1);
  EXPECT_FALSE(c.error());
  std::vector<cv::Mat> ch;
  cv::split(frame, ch);
  EXPECT_GT(cv::countNonZero(ch[3]), 0);
}

// 10. Local files: counts in a BAL header do not allocate before data is
// read; out-of-range and wrongly typed rig fields give the documented
// std::runtime_error.
TEST_F(Hostile, LocalFilesAreBounded) {
  const std::string bal = (fs::temp_directory_path() / "lf-hostile.bal").string();
  std::ofstream(bal) << "1 1 100000000\n0 0 1.0 2.0\n";
  const double rss0 = rss_mib();
  EXPECT_THROW(lf::calib::read_bal(bal), std::runtime_error);
  EXPECT_LT(rss_mib() - rss0, 64.0);
  std::string json = lf::rig_to_json(rig1_);
  const auto at = json.find("\"width\"");
  ASSERT_NE(at, std::string::npos);
  const auto comma = json.find(',', at);
  std::string bad = json.substr(0, at) + "\"width\": 1e30" + json.substr(comma);
  EXPECT_THROW(lf::rig_from_json(bad), std::runtime_error);
  bad = json.substr(0, at) + "\"width\": 99999999999" + json.substr(comma);
  EXPECT_THROW(lf::rig_from_json(bad), std::runtime_error);
  // Found by fuzz_rig: a number out of double's range is a parse error too.
  EXPECT_THROW(lf::rig_from_json("{\"format\": 1e999}"), std::runtime_error);
  const auto name = json.find("\"name\"");
  ASSERT_NE(name, std::string::npos);
  bad = json.substr(0, name) + "\"name\": 5, \"x\"" + json.substr(json.find(':', name));
  try {
    lf::rig_from_json(bad);
    FAIL() << "accepted a number as the name";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("rig file"), std::string::npos) << e.what();
  }
}

// 12. Bad camera files are element errors naming the file, within seconds:
// a garbage JPEG, a truncated one, and a still of another shape, as the
// rig's still (mode=dataset) and as mode=file; a sequence with a damaged
// frame names that frame, or with skip-bad-frames=true warns and goes on.
TEST_F(Hostile, BadCameraFilesAreErrorsNamingThem) {
  const fs::path dir = fs::temp_directory_path() / ("lf-hostile-files-" + std::to_string(getpid()));
  fs::create_directories(dir);
  cv::Mat img(48, 64, CV_8UC3), other(64, 64, CV_8UC3);
  cv::randu(img, cv::Scalar::all(0), cv::Scalar::all(256));
  cv::randu(other, cv::Scalar::all(0), cv::Scalar::all(256));
  std::vector<uchar> jpg, square;
  cv::imencode(".jpg", img, jpg);
  cv::imencode(".jpg", other, square);
  auto write = [&](const std::string& name, std::vector<uchar> bytes) {
    const std::string f = (dir / name).string();
    std::ofstream(f, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()),
               static_cast<std::streamsize>(bytes.size()));
    return f;
  };
  std::vector<uchar> garbage = {0xff, 0xd8, 0xff, 0xe0};
  for (int i = 0; i < 4000; ++i) garbage.push_back(static_cast<uchar>((i * 7919) >> 3));
  const std::string files[] = {write("garbage.jpg", garbage),
                               write("cut.jpg", std::vector<uchar>(jpg.begin(), jpg.end() - 300)),
                               write("square.jpg", square)};
  for (int i = 0; i < 6; ++i) write("seq" + std::to_string(i) + ".jpg", jpg);
  write("seq3.jpg", garbage);
  // Runs lfcamsrc with `props` to its first error or warning (or EOS);
  // returns its text and how long it took.
  auto run = [&](const std::string& props, GstMessageType stop, double* seconds, int* frames) {
    const std::string desc = "lfcamsrc name=c camera-id=0 num-buffers=6 " + props +
                             " ! fakesink name=s signal-handoffs=true";
    GstElement* pipe = gst_parse_launch(desc.c_str(), nullptr);
    GstElement* sink = gst_bin_get_by_name(GST_BIN(pipe), "s");
    *frames = 0;
    g_signal_connect(sink, "handoff", G_CALLBACK(+[](GstElement*, GstBuffer*, GstPad*, gpointer n) {
                       ++*static_cast<int*>(n);
                     }),
                     frames);
    const auto t0 = std::chrono::steady_clock::now();
    gst_element_set_state(pipe, GST_STATE_PLAYING);
    GstBus* bus = gst_element_get_bus(pipe);
    GstMessage* m = gst_bus_timed_pop_filtered(
        bus, 10 * GST_SECOND,
        static_cast<GstMessageType>(stop | GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
    *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::string text = m ? GST_MESSAGE_TYPE_NAME(m) : "nothing";
    if (m &&
        (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ERROR || GST_MESSAGE_TYPE(m) == GST_MESSAGE_WARNING))
      text += ": " + testing_lf::take_error_debug(m);
    else if (m)
      gst_message_unref(m);
    gst_object_unref(bus);
    gst_element_set_state(pipe, GST_STATE_NULL);
    gst_object_unref(sink);
    gst_object_unref(pipe);
    return text;
  };
  double secs = 0;
  int frames = 0;
  for (const std::string& f : files) {
    lf::Rig r = rig1_;
    r.cameras[0].image = f;
    const std::string rig = (dir / "rig.json").string();
    lf::save_rig(r, rig);
    for (const std::string& mode :
         {"mode=dataset still-cache=" + (dir / "cache").string(), "mode=file location=" + f}) {
      const int runs = f.find("garbage") != std::string::npos ? 20 : 1;
      for (int k = 0; k < runs; ++k) {
        const std::string text = run("rig=" + rig + " " + mode, GST_MESSAGE_ERROR, &secs, &frames);
        EXPECT_EQ(text.rfind("error", 0), 0u) << mode << ": " << text;
        EXPECT_NE(text.find(f), std::string::npos) << mode << ": " << text;
        EXPECT_LT(secs, 5.0) << mode << " " << f;
        EXPECT_EQ(frames, 0) << mode << " " << f;
      }
    }
  }
  const std::string seq =
      "rig=" + rig1_path_ + " mode=file location=" + (dir / "seq%d.jpg").string();
  std::string text = run(seq, GST_MESSAGE_ERROR, &secs, &frames);
  EXPECT_NE(text.find((dir / "seq3.jpg").string() + " (frame 3)"), std::string::npos) << text;
  EXPECT_EQ(frames, 3);
  text = run(seq + " skip-bad-frames=true", GST_MESSAGE_WARNING, &secs, &frames);
  EXPECT_NE(text.find("seq3.jpg (frame 3)"), std::string::npos) << text;
  EXPECT_NE(text.find("1 skipped so far"), std::string::npos) << text;
  text = run(seq + " skip-bad-frames=true", GST_MESSAGE_EOS, &secs, &frames);
  EXPECT_EQ(text, "eos");
  EXPECT_EQ(frames, 5) << "the five good frames";
  fs::remove_all(dir);
}

// 11. A location with quotes and '!' is a file name, not pipeline syntax.
TEST_F(Hostile, CameraLocationIsNotPipelineSyntax) {
  GstElement* src = gst_element_factory_make("lfcamsrc", nullptr);
  g_object_set(src, "rig", rig1_path_.c_str(), "camera-id", 0, "mode", 2, "location",
               "/nonexistent/a\" ! fakesink name=\"injected", nullptr);
  GstElement* pipe = gst_pipeline_new(nullptr);
  GstElement* sink = gst_element_factory_make("fakesink", nullptr);
  gst_bin_add_many(GST_BIN(pipe), src, sink, nullptr);
  gst_element_link(src, sink);
  gst_element_set_state(pipe, GST_STATE_PLAYING);
  GstBus* bus = gst_element_get_bus(pipe);
  GstMessage* m = gst_bus_timed_pop_filtered(bus, 10 * GST_SECOND, GST_MESSAGE_ERROR);
  ASSERT_NE(m, nullptr) << "a missing file is an error";
  GError* err = nullptr;
  gchar* dbg = nullptr;
  gst_message_parse_error(m, &err, &dbg);
  const std::string text = std::string(err->message) + " " + (dbg ? dbg : "");
  EXPECT_EQ(text.find("syntax"), std::string::npos) << text;
  g_error_free(err);
  g_free(dbg);
  gst_message_unref(m);
  gst_object_unref(bus);
  gst_element_set_state(pipe, GST_STATE_NULL);
  gst_object_unref(pipe);
}

}  // namespace

// A surface probe that every camera sat out (only empty answers: its instant
// was not among their frames, as when a live pipeline starts or a host is
// overloaded) measured nothing: the first in a row is logged, not warned;
// the second in a row is warned, so a pipeline where it always happens is
// not silent.
TEST_F(Hostile, ASurfaceProbeThatEveryCameraSatOutWarnsOnlyTheSecondTimeInARow) {
  Compositor c(rig2_path_, "viewer-id=0");
  auto sat_out = [&](uint32_t id) {
    const auto steps = lf::surface_probe_requests(rig2_, request(rig2_, 1), id);
    ASSERT_FALSE(steps.empty());
    for (const lf::Camera& cam : rig2_.cameras)
      for (const lf::ViewRequest& st : steps)
        push(c.src, lf::serialize_fragment(empty(static_cast<uint32_t>(cam.id), st.sequence, 0,
                                                 st.view.width, st.view.height),
                                           lf::Encoding::kEmpty));
  };
  // Warnings naming the focal surface, waiting up to `seconds` for `want`.
  int surface_warnings = 0;
  auto wait_for = [&](int want, double seconds) {
    GstBus* bus = gst_element_get_bus(c.pipe);
    const gint64 until = g_get_monotonic_time() + static_cast<gint64>(seconds * 1e6);
    while (surface_warnings < want && g_get_monotonic_time() < until) {
      GstMessage* m = gst_bus_timed_pop_filtered(bus, 50 * GST_MSECOND, GST_MESSAGE_WARNING);
      if (!m) continue;
      GError* err = nullptr;
      gst_message_parse_warning(m, &err, nullptr);
      if (err && std::strstr(err->message, "focal surface")) ++surface_warnings;
      if (err) g_error_free(err);
      gst_message_unref(m);
    }
    gst_object_unref(bus);
  };
  sat_out(1);
  sat_out(2);  // the second in a row: one warning, which also shows the first was scored
  wait_for(1, 10);
  EXPECT_EQ(surface_warnings, 1);
  wait_for(2, 0.5);  // and only one
  EXPECT_EQ(surface_warnings, 1);
  EXPECT_FALSE(c.error());
}

// lf-launch's plain RTP check (tools/launch_guard.h) on an appsrc: forged
// packets with the stream's SSRC come first and take the window (a pair in
// sequence); the real stream then starts, 15 ms a packet. Its packets are
// refused until it has been heard in more 10-ms slots than the forged
// window; then those refused go on first, so its first packet (a sender's
// in-band caps) is not lost. Every real packet comes out, once, in order,
// and nothing forged after the first pair.
TEST(LaunchGuard, ARealStreamAfterForgedPacketsKeepsItsFirstPackets) {
  testing_lf::init_gstreamer_with_plugin();
  GstElement* pipe = gst_parse_launch(
      "appsrc name=src format=time caps=\"application/x-rtp,media=application,clock-rate=90000,"
      "encoding-name=X-GST,payload=96,ssrc=(uint)4096\" ! appsink name=sink sync=false",
      nullptr);
  ASSERT_NE(pipe, nullptr);
  GstElement* src = gst_bin_get_by_name(GST_BIN(pipe), "src");
  GstElement* sink = gst_bin_get_by_name(GST_BIN(pipe), "sink");
  GstPad* pad = gst_element_get_static_pad(src, "src");
  guard_plain_rtp(pad);
  gst_element_set_state(pipe, GST_STATE_PLAYING);
  auto packet = [](guint16 seq, guint32 ts, guint8 mark) {
    GstBuffer* b = gst_rtp_buffer_new_allocate(4, 0, 0);
    GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
    gst_rtp_buffer_map(b, GST_MAP_WRITE, &rtp);
    gst_rtp_buffer_set_ssrc(&rtp, 4096);
    gst_rtp_buffer_set_payload_type(&rtp, 96);
    gst_rtp_buffer_set_seq(&rtp, seq);
    gst_rtp_buffer_set_timestamp(&rtp, ts);
    std::memset(gst_rtp_buffer_get_payload(&rtp), mark, 4);
    gst_rtp_buffer_unmap(&rtp);
    return b;
  };
  // The forged pair, then the real stream: 30 packets from 100, 1350 ticks
  // (15 ms) apart in time and timestamp.
  gst_app_src_push_buffer(GST_APP_SRC(src), packet(40000, 123456789, 0xee));
  gst_app_src_push_buffer(GST_APP_SRC(src), packet(40001, 123456789, 0xee));
  for (guint16 k = 0; k < 30; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(15));
    gst_app_src_push_buffer(GST_APP_SRC(src), packet(100 + k, 5000 + 1350u * k, 0x11));
  }
  gst_app_src_end_of_stream(GST_APP_SRC(src));
  std::vector<int> real;
  int forged = 0;
  while (GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 5 * GST_SECOND)) {
    GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
    if (gst_rtp_buffer_map(gst_sample_get_buffer(s), GST_MAP_READ, &rtp)) {
      const auto* p = static_cast<const guint8*>(gst_rtp_buffer_get_payload(&rtp));
      if (p[0] == 0x11)
        real.push_back(gst_rtp_buffer_get_seq(&rtp));
      else
        ++forged;
      gst_rtp_buffer_unmap(&rtp);
    }
    gst_sample_unref(s);
  }
  std::vector<int> want(30);
  for (int k = 0; k < 30; ++k) want[k] = 100 + k;
  EXPECT_EQ(real, want) << "every real packet, once, in order (the first ones after the takeover)";
  EXPECT_LE(forged, 2) << "only the forged pair, while it held the window";
  gst_element_set_state(pipe, GST_STATE_NULL);
  gst_object_unref(pad);
  gst_object_unref(src);
  gst_object_unref(sink);
  gst_object_unref(pipe);
}

// lf-launch's SRTP master key identifiers (tools/launch_srtp.h): a new MKI
// is the session's and no other session's; any changed byte makes it
// made-up; each MKI gives its own start key, the same one every time, as
// long as the master key (30 bytes: AES-128 + salt; 46: AES-256 + salt).
TEST(LaunchSrtp, MkisAreTaggedAndEachStartHasItsOwnKey) {
  std::vector<uint8_t> master(30), other(30);
  for (size_t i = 0; i < master.size(); ++i) master[i] = static_cast<uint8_t>(i * 7 + 1);
  other = master;
  other[29] ^= 1;
  uint8_t a[kSrtpMkiBytes], b[kSrtpMkiBytes];
  ASSERT_TRUE(srtp_new_mki(master.data(), master.size(), a));
  ASSERT_TRUE(srtp_new_mki(master.data(), master.size(), b));
  EXPECT_NE(std::memcmp(a, b, kSrtpMkiBytes), 0) << "random nonces";
  EXPECT_TRUE(srtp_mki_is_sessions(master.data(), master.size(), a));
  EXPECT_FALSE(srtp_mki_is_sessions(other.data(), other.size(), a)) << "another session's key";
  for (size_t i = 0; i < kSrtpMkiBytes; ++i) {
    uint8_t c[kSrtpMkiBytes];
    std::memcpy(c, a, kSrtpMkiBytes);
    c[i] ^= 0x40;
    EXPECT_FALSE(srtp_mki_is_sessions(master.data(), master.size(), c)) << "byte " << i;
  }
  for (size_t len : {30u, 46u}) {
    std::vector<uint8_t> m(len, 0x5a), ka(len), ka2(len), kb(len);
    ASSERT_TRUE(srtp_start_key(m.data(), m.size(), a, ka.data(), len));
    ASSERT_TRUE(srtp_start_key(m.data(), m.size(), a, ka2.data(), len));
    ASSERT_TRUE(srtp_start_key(m.data(), m.size(), b, kb.data(), len));
    EXPECT_EQ(ka, ka2) << len;
    EXPECT_NE(ka, kb) << len;
    EXPECT_NE(ka, m) << len;
  }
  uint8_t big[65];
  EXPECT_FALSE(srtp_start_key(master.data(), master.size(), a, big, sizeof big));
}
