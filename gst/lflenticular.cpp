/**
 * SECTION:element-lflenticular
 * @title: lflenticular
 *
 * Interleaves a quilt (lib/lf/render/quilt.h: views tiled from the bottom-left,
 * left to right, then upward, as `lfviewrequest quilt-views=N` and
 * `lfcompositor` make it) into the panel image of a lenticular light-field
 * display (the Looking Glass family): every sub-pixel of the panel shows
 * the view that lies under it through the display's slanted lenticules,
 * from the display's calibration (its "visual.json": pitch, slope, center,
 * DPI, screenW, screenH, invView, flipImageX, flipSubp). The formula is the
 * display's published one (lib/lf/render/lenticular.h); each view is sampled at
 * the nearest pixel of its tile.
 *
 * Input: RGBA frames that are a whole number of `quilt-columns` x
 * `quilt-rows` tiles. Output: RGBA frames of the panel's size (screenW x
 * screenH), the frame rate and timestamps of the input, for a full-screen
 * video sink on the display (or a file).
 *
 * `backend=gl` runs the interleave as a fragment shader (lib/lf/render/gl_render.h
 * GlRenderer::interleave), the same arithmetic as the CPU kernel
 * (tests/test_gl.cpp: identical output on Mesa's llvmpipe).
 *
 * Errors: a calibration file that cannot be read or lacks a field (the
 * message names it) at start; a quilt whose size is not whole tiles at
 * negotiation.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess width=1280 height=720 \
 *   quilt-views=48 num-buffers=30 ! lfarray rig=../shared/data/stanford-chess ! \
 *   lflenticular calibration=docs/examples/lenticular-calibration.json ! videoconvert ! \
 *   autovideosink
 * ]|
 */
#include <gst/gst.h>
#include <gst/video/gstvideofilter.h>
#include <gst/video/video.h>

#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "lf/render/gl_render.h"
#include "lf/render/lenticular.h"
#include "lfbackend.h"
#include "lfguard.h"
#include "lfprops.h"

GST_DEBUG_CATEGORY_STATIC(lf_lenticular_debug);
#define GST_CAT_DEFAULT lf_lenticular_debug

G_BEGIN_DECLS
#define LF_TYPE_LENTICULAR (lf_lenticular_get_type())
G_DECLARE_FINAL_TYPE(LfLenticular, lf_lenticular, LF, LENTICULAR, GstVideoFilter)
G_END_DECLS

namespace {

struct Settings {
  std::string calibration;
  guint cols = 8, rows = 6, views = 0;  // views 0: cols * rows
  lf::Backend backend = lf::Backend::kAuto;
};

struct Priv {
  Settings settings;
  // From start to stop (streaming thread and caps queries, under the
  // object lock for `cal` and `have_cal`).
  lf::DisplayCalibration cal;
  bool have_cal = false;
  lf::Quilt layout;
  std::unique_ptr<lf::Renderer> renderer;  // lib/lf/render/renderer.h, by `backend`
};

lfgst::Properties<Settings> props;

}  // namespace

struct _LfLenticular {
  GstVideoFilter parent;
  Priv* priv;
};

G_DEFINE_TYPE(LfLenticular, lf_lenticular, GST_TYPE_VIDEO_FILTER)
GST_ELEMENT_REGISTER_DEFINE(lflenticular, "lflenticular", GST_RANK_NONE, LF_TYPE_LENTICULAR)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("RGBA")));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE(
    "src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("RGBA")));

static void lf_lenticular_property_set(GObject*, GParamSpec*, const GValue*) {}
LF_DEFINE_ELEMENT_GLUE(lf_lenticular, LF_LENTICULAR)

static gboolean lf_lenticular_start(GstBaseTransform* bt) {
  LfLenticular* self = LF_LENTICULAR(bt);
  Priv* p = self->priv;
  const Settings s = lfgst::snapshot(GST_OBJECT(self), p->settings);
  lf::DisplayCalibration cal;
  GError* err = nullptr;
  if (s.calibration.empty()) {
    GST_ELEMENT_ERROR(self, RESOURCE, NOT_FOUND, ("No display calibration"),
                      ("set calibration to the display's calibration JSON (visual.json)"));
    return FALSE;
  }
  if (!lfgst::guard([&] { cal = lf::load_display_calibration(s.calibration); }, &err)) {
    GST_ELEMENT_ERROR(self, RESOURCE, READ, ("Cannot use the display calibration"),
                      ("%s", err->message));
    g_error_free(err);
    return FALSE;
  }
  if (!lfgst::open_renderer(GST_ELEMENT(self), s.backend, p->renderer)) return FALSE;
  GST_OBJECT_LOCK(self);
  p->cal = cal;
  p->have_cal = true;
  GST_OBJECT_UNLOCK(self);
  p->layout.cols = static_cast<int>(s.cols), p->layout.rows = static_cast<int>(s.rows);
  p->layout.views = s.views ? static_cast<int>(s.views) : p->layout.cols * p->layout.rows;
  GST_INFO_OBJECT(self, "panel %dx%d, %d views in %dx%d tiles, %s", cal.screen_w, cal.screen_h,
                  p->layout.views, p->layout.cols, p->layout.rows,
                  lf::backend_name(p->renderer->backend()));
  return TRUE;
}

static gboolean lf_lenticular_stop(GstBaseTransform* bt) {
  LfLenticular* self = LF_LENTICULAR(bt);
  GST_OBJECT_LOCK(self);
  self->priv->have_cal = false;
  GST_OBJECT_UNLOCK(self);
  self->priv->renderer.reset();
  return TRUE;
}

// Sink to source: the panel's size (once the calibration is read); source
// to sink: any size (the quilt's is checked in set_info).
static GstCaps* lf_lenticular_transform_caps(GstBaseTransform* bt, GstPadDirection dir,
                                             GstCaps* caps, GstCaps* filter) {
  LfLenticular* self = LF_LENTICULAR(bt);
  GstCaps* out = gst_caps_copy(caps);
  GST_OBJECT_LOCK(self);
  const bool have = self->priv->have_cal;
  const int w = self->priv->cal.screen_w, h = self->priv->cal.screen_h;
  GST_OBJECT_UNLOCK(self);
  for (guint i = 0; i < gst_caps_get_size(out); ++i) {
    GstStructure* st = gst_caps_get_structure(out, i);
    if (dir == GST_PAD_SINK && have)
      gst_structure_set(st, "width", G_TYPE_INT, w, "height", G_TYPE_INT, h, nullptr);
    else
      gst_structure_set(st, "width", GST_TYPE_INT_RANGE, 1, G_MAXINT, "height", GST_TYPE_INT_RANGE,
                        1, G_MAXINT, nullptr);
    gst_structure_remove_field(st, "pixel-aspect-ratio");
  }
  if (filter) {
    GstCaps* t = gst_caps_intersect_full(filter, out, GST_CAPS_INTERSECT_FIRST);
    gst_caps_unref(out);
    out = t;
  }
  return out;
}

static gboolean lf_lenticular_set_info(GstVideoFilter* vf, GstCaps*, GstVideoInfo* in, GstCaps*,
                                       GstVideoInfo*) {
  LfLenticular* self = LF_LENTICULAR(vf);
  GError* err = nullptr;
  if (!lfgst::guard(
          [&] {
            lf::validate_quilt(self->priv->layout, GST_VIDEO_INFO_WIDTH(in),
                               GST_VIDEO_INFO_HEIGHT(in));
          },
          &err)) {
    GST_ELEMENT_ERROR(self, STREAM, FORMAT, ("The input is not a quilt of this layout"),
                      ("%s (set quilt-columns, quilt-rows and quilt-views as the quilt's "
                       "lfviewrequest has them)",
                       err->message));
    g_error_free(err);
    return FALSE;
  }
  return TRUE;
}

static GstFlowReturn lf_lenticular_transform_frame(GstVideoFilter* vf, GstVideoFrame* in,
                                                   GstVideoFrame* out) {
  LfLenticular* self = LF_LENTICULAR(vf);
  Priv* p = self->priv;
  const cv::Mat quilt(GST_VIDEO_FRAME_HEIGHT(in), GST_VIDEO_FRAME_WIDTH(in), CV_8UC4,
                      GST_VIDEO_FRAME_PLANE_DATA(in, 0), GST_VIDEO_FRAME_PLANE_STRIDE(in, 0));
  cv::Mat panel(GST_VIDEO_FRAME_HEIGHT(out), GST_VIDEO_FRAME_WIDTH(out), CV_8UC4,
                GST_VIDEO_FRAME_PLANE_DATA(out, 0), GST_VIDEO_FRAME_PLANE_STRIDE(out, 0));
  uint8_t* const into = panel.data;
  GError* err = nullptr;
  if (!lfgst::guard(
          [&] {
            p->renderer->interleave(p->cal, p->layout, quilt, panel);
            if (panel.data != into) throw std::logic_error("the panel was reallocated");
          },
          &err)) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Cannot interleave the quilt"), ("%s", err->message));
    g_error_free(err);
    return GST_FLOW_ERROR;
  }
  return GST_FLOW_OK;
}

static void lf_lenticular_init(LfLenticular* self) {
  self->priv = new Priv();
}

static void lf_lenticular_class_init(LfLenticularClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* bt = GST_BASE_TRANSFORM_CLASS(klass);
  GstVideoFilterClass* vfc = GST_VIDEO_FILTER_CLASS(klass);
  oc->set_property = lf_lenticular_set_property;
  oc->get_property = lf_lenticular_get_property;
  oc->finalize = lf_lenticular_finalize;
  const GParamFlags rw = lfgst::kReadWriteReady;
  props.add(oc, &Settings::calibration,
            g_param_spec_string("calibration", "Calibration",
                                "The display's calibration JSON (Looking Glass visual.json: "
                                "pitch, slope, center, DPI, screenW, screenH, invView, "
                                "flipImageX, flipSubp; {\"value\": x} or plain numbers)",
                                nullptr, rw));
  props.add(oc, &Settings::cols,
            g_param_spec_uint("quilt-columns", "Quilt columns", "Tiles across the input quilt", 1,
                              lf::Quilt::kMaxTiles, 8, rw));
  props.add(oc, &Settings::rows,
            g_param_spec_uint("quilt-rows", "Quilt rows", "Tiles down the input quilt", 1,
                              lf::Quilt::kMaxTiles, 6, rw));
  props.add(oc, &Settings::views,
            g_param_spec_uint("quilt-views", "Quilt views",
                              "Views in the quilt, the first at the bottom-left (0: columns x "
                              "rows)",
                              0, lf::Quilt::kMaxViews, 0, rw));
  props.add(oc, &Settings::backend,
            g_param_spec_enum("backend", "Backend", "Where the interleave runs",
                              lfgst::backend_type(), static_cast<gint>(lf::Backend::kAuto), rw));
  gst_element_class_add_static_pad_template(ec, &sink_template);
  gst_element_class_add_static_pad_template(ec, &src_template);
  gst_element_class_set_static_metadata(
      ec, "Light field lenticular interleave", "Filter/Effect/Video",
      "Interleaves a quilt of views for a lenticular light-field display (Looking Glass) from "
      "its calibration: each sub-pixel shows the view under its lenticule",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess width=1280 height=720 "
      "quilt-views=48 num-buffers=30 ! lfarray rig=../shared/data/stanford-chess ! lflenticular "
      "calibration=docs/examples/lenticular-calibration.json ! videoconvert ! autovideosink");
  bt->start = lf_lenticular_start;
  bt->stop = lf_lenticular_stop;
  bt->transform_caps = lf_lenticular_transform_caps;
  vfc->set_info = lf_lenticular_set_info;
  vfc->transform_frame = lf_lenticular_transform_frame;
  GST_DEBUG_CATEGORY_INIT(lf_lenticular_debug, "lflenticular", 0,
                          "light field lenticular interleave");
}
