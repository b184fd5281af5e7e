/**
 * SECTION:element-lfcamerahost
 * @title: lfcamerahost
 *
 * The cameras of one host, built from the rig (Yang et al. 2002, Figure 2:
 * a camera host): for each camera selected by `cameras` (rig-order indices,
 * e.g. "0-15"; empty: all), an `lfcamsrc` and an `lffragment` fed by one
 * shared request input. View requests enter on the `sink` pad
 * (`application/x-lf-view-request`, e.g. from `lfviewrequest` or an RTP
 * receiver); the fragments of all its cameras leave on the `src` pad
 * (`application/x-lf-fragment`), one stream, for `lfcompositor` or an RTP
 * sender. The camera and fragment properties below are set on every
 * camera's `lfcamsrc` or `lffragment` (their documentation is theirs). The
 * graph is built when the bin goes to READY, from the rig as it is then.
 *
 * `partial-sums=true` adds each request's fragments of this host's cameras
 * into one (`lfpartialsum`; docs/deploy.md: it pays for a contiguous block
 * of the grid). `record=rec/cam%02d.mkv` also writes every camera's frames
 * with their capture times to one Matroska file per camera, and
 * `playback=...` replaces the cameras by such files, played on the recorded
 * schedule; both pick frames by capture time, so the same requests give the
 * same fragments (docs/steering.md, "Recording and playback").
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 udpsrc port=5000 caps=... ! rtpgstdepay ! \
 *   lfcamerahost rig=rig.json cameras=0-15 is-live=true encoding=jpeg ! \
 *   rtpgstpay ! udpsink host=compositor port=5200
 * ]|
 */
#include "lfcamerahost.h"

#include <gst/gst.h>

#include <algorithm>
#include <string>
#include <vector>

#include "lf/io/parse.h"
#include "lf/render/gl_render.h"
#include "lfbackend.h"
#include "lfbundle.h"
#include "lfcamerahostprops.h"
#include "lfforward.h"
#include "lfguard.h"
#include "lfprops.h"
#include "lfrate.h"
#include "lfrecording.h"
#include "lfrig.h"
#include "lfwarn.h"

extern "C" GType lf_cam_src_get_type(void);
extern "C" GType lf_fragment_get_type(void);
extern "C" GType lf_compositor_get_type(void);

GST_DEBUG_CATEGORY_STATIC(lf_camera_host_debug);
#define GST_CAT_DEFAULT lf_camera_host_debug

namespace {

// Property ids: 1..9 the camera host's own (`props`, in the order added),
// 10 lfarray's whole-view, then the children's properties it forwards.
constexpr guint PROP_FIRST_FORWARD = 11;

using lfgst::Forward;
const Forward kCameraHostForwards[] = {
    {lf_cam_src_get_type, "mode"},           {lf_cam_src_get_type, "framerate"},
    {lf_cam_src_get_type, "phase"},          {lf_cam_src_get_type, "is-live"},
    {lf_cam_src_get_type, "num-buffers"},    {lf_cam_src_get_type, "loop"},
    {lf_cam_src_get_type, "noise"},          {lf_fragment_get_type, "encoding"},
    {lf_fragment_get_type, "jpeg-quality"},  {lf_fragment_get_type, "max-pixels"},
    {lf_fragment_get_type, "max-rate"},      {lf_fragment_get_type, "max-pixel-rate"},
    {lf_fragment_get_type, "frame-timeout"}, {lf_fragment_get_type, "frame-select"},
    {lf_fragment_get_type, "backend"}};
const Forward kArrayForwards[] = {
    {lf_compositor_get_type, "viewer-id"}, {lf_compositor_get_type, "latency"},
    {lf_compositor_get_type, "stereo"},    {lf_compositor_get_type, "second-planes"},
    {lf_compositor_get_type, "width"},     {lf_compositor_get_type, "height"}};

// The forwarded properties of a class: the camera host's, then lfarray's.
std::vector<Forward> forwards(bool composite) {
  std::vector<Forward> f(std::begin(kCameraHostForwards), std::end(kCameraHostForwards));
  if (composite) f.insert(f.end(), std::begin(kArrayForwards), std::end(kArrayForwards));
  return f;
}

using Settings = lfgst::CameraHostSettings;
lfgst::Properties<Settings> props;

struct Priv {
  Settings settings;
  // Forwarded property values (object lock); sized for lfarray's list (a
  // superset): during instance init the class is still LfCameraHost's.
  lfgst::ForwardedValues values{forwards(true).size()};
  GstPad* sink = nullptr;  // ghost pads, targets set when built
  GstPad* src = nullptr;
  std::vector<GstElement*> children;
  // Playback sources (decodebin, filesrc), started only once the rest of the
  // graph is PAUSED (see add_playback).
  std::vector<GstElement*> deferred;
};

}  // namespace

typedef struct {
  Priv* priv;
} LfCameraHostPrivate;

G_DEFINE_TYPE_WITH_PRIVATE(LfCameraHost, lf_camera_host, GST_TYPE_BIN)
GST_ELEMENT_REGISTER_DEFINE(lfcamerahost, "lfcamerahost", GST_RANK_NONE, LF_TYPE_CAMERA_HOST)

static Priv* priv_of(gpointer self) {
  return static_cast<LfCameraHostPrivate*>(
             lf_camera_host_get_instance_private(LF_CAMERA_HOST(self)))
      ->priv;
}
static bool composite_of(gpointer self) {
  return LF_CAMERA_HOST_GET_CLASS(self)->composite;
}

static GstStaticPadTemplate request_sink = GST_STATIC_PAD_TEMPLATE(
    "sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS("application/x-lf-view-request"));
static GstStaticPadTemplate fragment_src = GST_STATIC_PAD_TEMPLATE(
    "src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS("application/x-lf-fragment"));

// Own properties through the table, the children's through `values`.
static void lf_camera_host_set_property(GObject* obj, guint id, const GValue* v, GParamSpec* ps) {
  Priv* p = priv_of(obj);
  if (id < PROP_FIRST_FORWARD) return props.set(obj, p->settings, id, v, ps);
  GST_OBJECT_LOCK(obj);
  const bool known = p->values.set(id - PROP_FIRST_FORWARD, v);
  GST_OBJECT_UNLOCK(obj);
  if (!known) G_OBJECT_WARN_INVALID_PROPERTY_ID(obj, id, ps);
}

static void lf_camera_host_get_property(GObject* obj, guint id, GValue* v, GParamSpec* ps) {
  Priv* p = priv_of(obj);
  if (id < PROP_FIRST_FORWARD) return props.get(obj, p->settings, id, v, ps);
  GST_OBJECT_LOCK(obj);
  const bool known = p->values.get(id - PROP_FIRST_FORWARD, v, ps);
  GST_OBJECT_UNLOCK(obj);
  if (!known) G_OBJECT_WARN_INVALID_PROPERTY_ID(obj, id, ps);
}

static GstElement* make(const char* factory, const std::string& name) {
  return lfgst::make_element(factory, name.c_str());
}

// Adds `e` to the bin and to the children torn down with it.
static GstElement* adopt(GstBin* bin, Priv* p, GstElement* e) {
  gst_bin_add(bin, e);
  p->children.push_back(e);
  return e;
}

// Builds the graph from the rig (NULL->READY).
static bool build(LfCameraHost* self) {
  Priv* p = priv_of(self);
  const Settings ps = lfgst::snapshot(GST_OBJECT(self), p->settings);
  const std::string &rig_path = ps.rig, &cameras = ps.cameras;
  const std::string &record = ps.record, &playback = ps.playback;
  guint64 max_age = ps.request_max_age;
  const bool sums = ps.partial_sums;
  const bool whole_view = ps.whole_view && composite_of(self) && !sums;
  GST_OBJECT_LOCK(self);
  lfgst::ForwardedValues::Copy forwarded;
  p->values.copy(forwards(composite_of(self)), &forwarded);
  std::vector<lfgst::ForwardedValues::Set>& values = forwarded.values;
  GST_OBJECT_UNLOCK(self);
  const std::shared_ptr<const lf::Rig> rig = lfgst::open_rig(GST_ELEMENT(self), rig_path);
  bool ok = rig != nullptr;
  GError* err = nullptr;
  if (ok &&
      !lfgst::guard(
          [&] {
            const std::vector<int> chosen =
                lf::parse_index_ranges(cameras, static_cast<int>(rig->cameras.size()), "cameras");
            bool live = false, frame_select_set = false, by_capture_time = false, raw = true;
            for (auto& [f, v] : values) {
              if (g_str_equal(f.name, "is-live")) live = g_value_get_boolean(&v);
              if (g_str_equal(f.name, "encoding"))
                raw = g_value_get_enum(&v) == static_cast<gint>(lfgst::FragmentEncoding::kRaw);
              if (g_str_equal(f.name, "frame-select")) {
                frame_select_set = true;
                const GEnumValue* ev = g_enum_get_value(
                    G_ENUM_CLASS(g_type_class_peek(G_VALUE_TYPE(&v))), g_value_get_enum(&v));
                by_capture_time = ev && g_str_equal(ev->value_nick, "capture-time");
              }
              // lfarray: a request its compositor still waits for is not
              // stale.
              if (g_str_equal(f.name, "latency"))
                max_age = std::max<guint64>(max_age, g_value_get_uint64(&v));
            }
            // Whole-view mode: the fragments leave their drawing to the compositor
            // (lffragment defer); they only plan, so one request thread plans every
            // camera (one hand-off a request, not one a camera), unless frames are
            // picked by capture time (recording, playback, frame-select): there a
            // request may wait for a camera's frame, and each camera keeps its own.
            const bool defer = whole_view && raw;
            const bool one_thread = defer && record.empty() && playback.empty() && !by_capture_time;
            // Bad file name patterns fail here, before anything is made.
            if (!record.empty()) lf::camera_file_name(record, 0, "record");
            if (!playback.empty()) lf::camera_file_name(playback, 0, "playback");
            GstElement* tee = make("tee", "requests");
            g_object_set(tee, "allow-not-linked", TRUE, nullptr);
            // Live: one lfrequestqueue before the tee sheds stale requests once for
            // every camera (the viewers in turn; a viewer's request behind one of its
            // own request-max-age newer is stale), and each request thread's queue
            // holds one and blocks: a camera shedding alone answered a request that
            // others dropped (incomplete frames). Not live: queues with their
            // defaults.
            const lfgst::Adopt adopt_here = [&](GstElement* e) {
              return adopt(GST_BIN(self), p, e);
            };
            auto request_queue = [&](const std::string& name, bool shared) {
              GstElement* q =
                  adopt(GST_BIN(self), p, make(live && shared ? "lfrequestqueue" : "queue", name));
              if (live && shared) g_object_set(q, "max-age", max_age, nullptr);
              if (live && !shared)
                g_object_set(q, "max-size-buffers", 1u, "max-size-bytes", 0u, "max-size-time",
                             G_GUINT64_CONSTANT(0), nullptr);
              return q;
            };
            GstElement* out = composite_of(self) ? make("lfcompositor", "compositor")
                              : sums             ? make("lfpartialsum", "sums")
                                                 : make("funnel", "fragments");
            gst_bin_add_many(GST_BIN(self), tee, out, nullptr);
            p->children = {tee, out};
            // Partial sums: the cameras' raw fragments are added up,
            // and the sum encoded, in `sum`.
            GstElement* sum = nullptr;
            if (sums && composite_of(self)) {
              sum = adopt(GST_BIN(self), p, make("lfpartialsum", "sums"));
              if (!gst_element_link_pads(sum, "src", out, "sink_%u"))
                throw std::runtime_error("cannot link the partial sums");
            } else if (sums) {
              sum = out;
            }
            if (sum) {
              g_object_set(sum, "latency", ps.sum_latency, nullptr);
              for (auto& [f, v] : values)
                if (g_str_equal(f.name, "encoding") || g_str_equal(f.name, "jpeg-quality"))
                  g_object_set_property(G_OBJECT(sum), f.name, &v);
            }
            auto apply = [&](GstElement* e, GType type) {
              // `backend` is the fragments' and, in lfarray, the compositor's.
              for (auto& [f, v] : values)
                if (f.child() == type ||
                    (type == lf_compositor_get_type() && g_str_equal(f.name, "backend")))
                  g_object_set_property(G_OBJECT(e), f.name, &v);
            };
            if (composite_of(self)) {
              g_object_set(out, "rig", rig_path.c_str(), nullptr);
              apply(out, lf_compositor_get_type());
            }
            // The request threads: one plans every camera (whole-view); a
            // camera whose request may wait for its frame (live cameras, or
            // frames picked by capture time) has its own; otherwise
            // `request-threads` of them, each a queue and a tee for every
            // n-th camera, whose cameras answer every request (answer-empty:
            // one that answered none would hold the thread).
            const size_t n_cams = chosen.size();
            const size_t threads =
                one_thread ? 1
                : live || by_capture_time || !record.empty() || !playback.empty()
                    ? n_cams
                    : std::min<size_t>(n_cams, ps.request_threads ? ps.request_threads
                                                                  : g_get_num_processors() + 1);
            std::vector<GstElement*> fans;  // the threads' tees (none: a queue per camera)
            // Into the compositor, each thread's fragments of a request in one
            // buffer or two (gst/lfbundle.h: a push per camera wakes it each time).
            // Whole-view mode's one thread too: its 64 plans reach the
            // compositor in 4 pushes, not 64.
            std::vector<GstElement*> bundles;
            const bool fan_out = !one_thread && threads < n_cams;
            for (size_t t = 0; (one_thread && t == 0) || (fan_out && t < threads); ++t) {
              const std::string id = std::to_string(t);
              if (!one_thread) {
                GstElement* q = request_queue("requests-" + id, false);
                GstElement* fan = adopt(GST_BIN(self), p, make("tee", "request-fan-" + id));
                g_object_set(fan, "allow-not-linked", TRUE, nullptr);
                if (!gst_element_link_pads(tee, "src_%u", q, "sink") || !gst_element_link(q, fan))
                  throw std::runtime_error("cannot link request thread " + id);
                fans.push_back(fan);
              }
              if (!composite_of(self) || sum) continue;
              GstElement* b = adopt(GST_BIN(self), p,
                                    GST_ELEMENT(g_object_new(LF_TYPE_FRAGMENT_BUNDLE, "name",
                                                             ("bundle-" + id).c_str(), nullptr)));
              if (!gst_element_link_pads(b, "src", out, "sink_%u"))
                throw std::runtime_error("cannot link request thread " + id + "'s bundle");
              bundles.push_back(b);
            }
            std::vector<GstElement*> frags;
            for (int i : chosen) {
              const int cam_id = rig->cameras[i].id;
              const std::string id = std::to_string(cam_id);
              GstElement* from = fans.empty() ? tee : fans[frags.size() % fans.size()];
              GstElement* q =
                  one_thread || !fans.empty() ? nullptr : request_queue("requests" + id, false);
              GstElement* frag = adopt(GST_BIN(self), p, make("lffragment", "fragment" + id));
              frags.push_back(frag);
              g_object_set(frag, "rig", rig_path.c_str(), "camera-id", cam_id, nullptr);
              apply(frag, lf_fragment_get_type());
              if (sum) gst_util_set_object_arg(G_OBJECT(frag), "encoding", "raw");
              if (defer)
                g_object_set(frag, "defer", TRUE, "backend", static_cast<gint>(lf::Backend::kCpu),
                             nullptr);
              if (!fans.empty()) g_object_set(frag, "answer-empty", TRUE, nullptr);
              // A recording pairs frames with requests by capture time, live
              // and played back alike.
              if ((!record.empty() || !playback.empty()) && !frame_select_set)
                gst_util_set_object_arg(G_OBJECT(frag), "frame-select", "capture-time");
              GstElement* cam;
              if (playback.empty()) {
                cam = adopt(GST_BIN(self), p, make("lfcamsrc", "camera" + id));
                g_object_set(cam, "rig", rig_path.c_str(), "camera-id", cam_id, nullptr);
                apply(cam, lf_cam_src_get_type());
              } else {
                cam = lfgst::add_playback(adopt_here, p->deferred,
                                          lf::camera_file_name(playback, cam_id, "playback"),
                                          rig->cameras[i], id);
              }
              if (!record.empty())
                cam = lfgst::add_recorder(adopt_here, cam,
                                          lf::camera_file_name(record, cam_id, "record"),
                                          ps.record_quality, id);
              if ((q && (!gst_element_link_pads(tee, "src_%u", q, "sink") ||
                         !gst_element_link_pads(q, "src", frag, "request"))) ||
                  (!q && !gst_element_link_pads(from, "src_%u", frag, "request")) ||
                  !gst_element_link_pads(cam, nullptr, frag, "sink") ||
                  !gst_element_link_pads(frag, "src",
                                         sum ? sum
                                         : bundles.empty()
                                             ? out
                                             : bundles[(frags.size() - 1) % bundles.size()],
                                         "sink_%u"))
                throw std::runtime_error("cannot link the graph of camera " + id);
            }
            // Live, that queue before the tee (the source never waits for the
            // cameras); not live, the request source's own thread.
            GstElement* first = tee;
            if (live) {
              first = request_queue("request-queue", true);
              if (!gst_element_link(first, tee))
                throw std::runtime_error("cannot link the request queue");
            }
            GstPad* tsink = gst_element_get_static_pad(first, "sink");
            if (!frags.empty()) {
              // The requests' limits once for all cameras (lfrate.h), on the
              // thread that brings the requests (not each camera alone: the
              // same request dropped by some and answered by others).
              double rate = 0, pixel_rate = 0;
              g_object_get(frags.front(), "max-rate", &rate, "max-pixel-rate", &pixel_rate,
                           nullptr);
              for (GstElement* f : frags)
                g_object_set(f, "max-rate", 0.0, "max-pixel-rate", 0.0, nullptr);
              lfgst::limit_requests(tsink, GST_ELEMENT(self), rate, pixel_rate, live);
            }
            GstPad* osrc = gst_element_get_static_pad(out, "src");
            gst_ghost_pad_set_target(GST_GHOST_PAD(p->sink), tsink);
            gst_ghost_pad_set_target(GST_GHOST_PAD(p->src), osrc);
            gst_object_unref(tsink);
            gst_object_unref(osrc);
            GST_INFO_OBJECT(self, "%zu cameras of %s", chosen.size(), rig_path.c_str());
          },
          &err)) {
    GST_ELEMENT_ERROR(self, LIBRARY, SETTINGS, ("Cannot build the camera graph"),
                      ("%s", err->message));
    g_error_free(err);
    ok = false;
  }
  return ok;
}

static void teardown(LfCameraHost* self) {
  Priv* p = priv_of(self);
  gst_ghost_pad_set_target(GST_GHOST_PAD(p->sink), nullptr);
  gst_ghost_pad_set_target(GST_GHOST_PAD(p->src), nullptr);
  for (GstElement* e : p->children) {
    gst_element_set_state(e, GST_STATE_NULL);
    gst_bin_remove(GST_BIN(self), e);
  }
  p->children.clear();
  p->deferred.clear();
}

static GstStateChangeReturn lf_camera_host_change_state(GstElement* el, GstStateChange t) {
  LfCameraHost* self = LF_CAMERA_HOST(el);
  if (t == GST_STATE_CHANGE_NULL_TO_READY) {
    teardown(self);
    if (!build(self)) {
      teardown(self);
      return GST_STATE_CHANGE_FAILURE;
    }
  }
  GstStateChangeReturn ret = GST_ELEMENT_CLASS(lf_camera_host_parent_class)->change_state(el, t);
  if (t == GST_STATE_CHANGE_READY_TO_PAUSED && ret != GST_STATE_CHANGE_FAILURE) {
    // Playback sources last, decoders before their file sources.
    Priv* p = priv_of(self);
    for (GstElement* e : p->deferred) {
      gst_element_set_locked_state(e, FALSE);
      if (!gst_element_sync_state_with_parent(e)) ret = GST_STATE_CHANGE_FAILURE;
    }
    p->deferred.clear();
  }
  if (t == GST_STATE_CHANGE_READY_TO_NULL) teardown(self);
  return ret;
}

static void lf_camera_host_finalize(GObject* obj) {
  delete priv_of(obj);
  G_OBJECT_CLASS(lf_camera_host_parent_class)->finalize(obj);
}

static void lf_camera_host_init(LfCameraHost* self) {
  auto* ip = static_cast<LfCameraHostPrivate*>(lf_camera_host_get_instance_private(self));
  ip->priv = new Priv();
  Priv* p = ip->priv;
  GstElementClass* ec = GST_ELEMENT_GET_CLASS(self);
  p->sink = gst_ghost_pad_new_no_target_from_template(
      "sink", gst_element_class_get_pad_template(ec, "sink"));
  p->src = gst_ghost_pad_new_no_target_from_template("src",
                                                     gst_element_class_get_pad_template(ec, "src"));
  gst_element_add_pad(GST_ELEMENT(self), p->sink);
  gst_element_add_pad(GST_ELEMENT(self), p->src);
}

// Installs the camera host's own and forwarded properties on `oc`.
static void install_properties(GObjectClass* oc) {
  lfgst::install_camera_host_properties(oc, &props);
  lfgst::install_forwards(oc, PROP_FIRST_FORWARD, std::begin(kCameraHostForwards),
                          std::end(kCameraHostForwards));
}

static void lf_camera_host_class_init(LfCameraHostClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  oc->set_property = lf_camera_host_set_property;
  oc->get_property = lf_camera_host_get_property;
  oc->finalize = lf_camera_host_finalize;
  ec->change_state = lf_camera_host_change_state;
  klass->composite = FALSE;
  install_properties(oc);
  gst_element_class_add_static_pad_template(ec, &request_sink);
  gst_element_class_add_static_pad_template(ec, &fragment_src);
  gst_element_class_set_static_metadata(
      ec, "Light field camera host", "Source/Video/Bin",
      "The cameras of one host built from the rig: an lfcamsrc and an lffragment per selected "
      "camera, view requests in on one pad, their fragments out on one (Yang et al. 2002, "
      "Figure 2)",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess num-buffers=60 ! "
      "lfcamerahost rig=../shared/data/stanford-chess encoding=jpeg ! lfcompositor "
      "rig=../shared/data/stanford-chess ! videoconvert ! autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "Posts its children's warnings and errors (see lfcamsrc, lffragment, lfpartialsum); an error "
      "at READY when the rig cannot be read or cameras names no camera of it.");
  GST_DEBUG_CATEGORY_INIT(lf_camera_host_debug, "lfcamerahost", 0,
                          "light field camera host and array bins");
}

void lf_camera_host_install_composite_properties(GObjectClass* oc, GParamSpec* whole_view) {
  oc->set_property = lf_camera_host_set_property;  // GObject wants them per class
  oc->get_property = lf_camera_host_get_property;
  props.add(oc, &Settings::whole_view, whole_view);
  // The base class installed the camera host's properties; add lfarray's.
  lfgst::install_forwards(oc, PROP_FIRST_FORWARD + G_N_ELEMENTS(kCameraHostForwards),
                          std::begin(kArrayForwards), std::end(kArrayForwards));
}

void lf_camera_host_replace_src(LfCameraHost* self) {
  Priv* p = priv_of(self);
  gst_element_remove_pad(GST_ELEMENT(self), p->src);
  p->src = gst_ghost_pad_new_no_target_from_template(
      "src", gst_element_class_get_pad_template(GST_ELEMENT_GET_CLASS(self), "src"));
  gst_element_add_pad(GST_ELEMENT(self), p->src);
}
