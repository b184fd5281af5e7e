/**
 * SECTION:element-lfarray
 * @title: lfarray
 *
 * A whole light field camera on one machine: an `lfcamerahost` graph for
 * the selected cameras whose fragments go, one pad per camera, to an
 * `lfcompositor`. View requests in on `sink`, raw video out on `src`:
 * `lfviewrequest rig=R ! lfarray rig=R ! videoconvert ! autovideosink` is
 * the 64-camera pipeline of Figure 2 on one machine. Navigation and
 * `lf-view` events from the sink travel up through it to `lfviewrequest`.
 *
 * Whole-view mode (`whole-view`, the default with raw fragments): the
 * `lffragment`s only plan (`defer=true`) and the compositor draws all
 * cameras of a view from their frames: on the CPU band by band straight
 * into its sums, on all cores (lib/lf/render/composite.h; no fragment in memory),
 * with GL in one pass sequence into one output (each camera frame uploaded
 * once, no fragment read back, no GL context per camera;
 * lib/lf/render/gl_render.h). Planning is cheap, so one request thread plans
 * every camera (not one thread per camera: one hand-off per request
 * instead of 64, which a profile of the pipeline showed to cost), and its
 * plans reach the compositor in one buffer for up to 16 cameras
 * (gst/lfbundle.h); the request
 * limits (`max-rate`, `max-pixel-rate`) are kept once for all cameras; only where frames are
 * picked by capture time (`record`, `playback`, `frame-select`), a request
 * may wait for a camera's frame and each camera keeps its own request
 * thread. The frames equal those of every `lffragment` drawing its own
 * fragment (`whole-view=false`), exactly.
 *
 * Where the fragments draw their own (JPEG, `whole-view=false`,
 * `partial-sums`) from cameras that are not live, `request-threads` threads
 * (one per core and one more by default) each answer every n-th camera (live cameras keep
 * one each: a request may wait for its frame), and the compositor, not
 * live, lets the cameras
 * run up to 16 requests ahead of it (see `lfcompositor`): fewer hand-offs
 * than a thread per camera, and no core idle while one camera's fragment
 * is late (docs/results.md, Pipeline). Each thread hands the compositor its
 * fragments of a request in one buffer for up to 16 cameras (gst/lfbundle.h),
 * so the compositor wakes a few times a frame, not once a camera.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfviewrequest rig=rig.json orbit=0.5 ! lfarray rig=rig.json ! \
 *   videoconvert ! autovideosink
 * ]|
 */
#include <gst/gst.h>

#include "lfcamerahost.h"
#include "lfprops.h"

G_BEGIN_DECLS
#define LF_TYPE_ARRAY (lf_array_get_type())
G_DECLARE_FINAL_TYPE(LfArray, lf_array, LF, ARRAY, LfCameraHost)
G_END_DECLS

struct _LfArray {
  LfCameraHost parent;
};
G_DEFINE_TYPE(LfArray, lf_array, LF_TYPE_CAMERA_HOST)
GST_ELEMENT_REGISTER_DEFINE(lfarray, "lfarray", GST_RANK_NONE, LF_TYPE_ARRAY)

static GstStaticPadTemplate video_src =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS,
                            GST_STATIC_CAPS("video/x-raw, format = (string) { RGBA, RGBx, I420 }"));

static void lf_array_init(LfArray* self) {
  lf_camera_host_replace_src(LF_CAMERA_HOST(self));  // video out instead of fragments
}

static void lf_array_class_init(LfArrayClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  LF_CAMERA_HOST_CLASS(klass)->composite = TRUE;
  lf_camera_host_install_composite_properties(
      oc, g_param_spec_boolean(
              "whole-view", "Whole-view mode",
              "With raw fragments: the fragments only plan, all on one request thread (each on "
              "its own where frames are picked by capture time), and leave their drawing to the "
              "compositor (lffragment defer), which draws all cameras of a view: on the CPU "
              "fused into its compositing, on all cores; with GL in one pass sequence, each "
              "camera frame uploaded once, no fragment read back. FALSE: the request threads "
              "(request-threads), and every lffragment draws its own fragment (in its own GL "
              "context with "
              "the GL backend). The same frames either way. No effect with JPEG fragments or "
              "partial-sums",
              TRUE, lfgst::kReadWriteReady));
  // Video out instead of fragments.
  GstPadTemplate* src = gst_static_pad_template_get(&video_src);
  gst_element_class_add_pad_template(ec, src);
  gst_element_class_set_static_metadata(
      ec, "Light field camera array", "Source/Video/Bin",
      "A light field camera on one machine built from the rig: an lfcamsrc and an lffragment "
      "per selected camera and an lfcompositor; view requests in, composited video out (Yang "
      "et al. 2002, Figure 2)",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess orbit=0.5 num-buffers=60 ! "
      "lfarray rig=../shared/data/stanford-chess ! videoconvert ! autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "Forwards navigation and lf-view events from the video sink to the request source; posts its "
      "children's warnings and errors (see lfcamsrc, lffragment, lfcompositor).");
}
