/**
 * SECTION:element-lffragment
 * @title: lffragment
 *
 * The paper's random access camera (Yang et al. 2002, Section 4.2). Camera
 * frames arrive on `sink`, view requests on `request`; for every request the
 * newest frame (colour-corrected by the rig's 3x4 `colour` matrix,
 * lib/lf/render/colour.h) is warped into this camera's fragment of the requested
 * view (lib/lf/render/plan.h, lib/lf/render/render.h) and pushed on `src`, tagged in band
 * (lib/lf/wire/wire.h). With `frame-select=capture-time` the frame is instead the
 * one captured at the request's time: the newest whose capture time (its
 * `LfCaptureMeta`, else its PTS) is at or before the request's time (the
 * viewer's PTS, carried in the request, lib/lf/wire/wire.h, so network delay does
 * not change it; else the request buffer's PTS), waiting up to
 * `frame-timeout` for it; so every camera of a deployment warps frames of
 * one capture instant for a request, and a live run and the playback of its
 * recording pair the same frames with the same requests (lfcamerahost
 * `record`/`playback`). Focus probes (lib/lf/focus/focus_probe.h) and surface
 * probes (lib/lf/focus/surface_probe.h) come as one buffer of all their steps
 * (lib/lf/wire/probe_bundle.h), answered with one buffer of this camera's
 * fragment of each step; they always pick by capture time, one frame for
 * all steps of a probe; a camera that no longer holds the frame of the
 * probe's instant (its frame period), or skipped it, sits the probe out.
 * Camera frames may come from any upstream element (e.g. `uridecodebin !
 * videoconvert ! videoscale ! video/x-raw,format=RGBA,width=W,height=H !
 * lffragment`); their PTS is then the capture time.
 * Cameras that do not contribute send an explicitly empty fragment, so the
 * compositor knows the request is complete. The fragment caps carry the
 * request caps' `framerate`; the process's lffragments with equal request
 * caps and encoding share one caps event, so a `funnel` joining cameras
 * (lfcamerahost) sends no new caps downstream when it switches between
 * them. Raw fragments are rendered straight into the
 * output buffer in their wire format (no copy) and carry `LfSealedMeta`
 * (gst/lfmeta.h), by which `lfcompositor` in the same process skips their
 * CRC check. With `defer=true` (lfarray's whole-view mode) a raw
 * fragment (or a layer pair) is only planned here: it leaves as an empty
 * fragment carrying the plan (both plans) and the camera image
 * (`LfDeferredMeta`), for an `lfcompositor` in the same process to draw.
 *
 * The camera is named like lfcamsrc's: `camera-id`, or `row` and `col` of
 * the rig's grid.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfviewrequest rig=rig.json num-buffers=30 ! f.request \
 *   lfcamsrc rig=rig.json camera-id=0 ! f.sink \
 *   lffragment name=f rig=rig.json camera-id=0 encoding=jpeg ! fakesink
 * ]|
 */
#include "lffragmentprops.h"

#include "lfbackend.h"

#define LF_TYPE_FRAGMENT_ENCODING (fragment_encoding_type())
#define LF_TYPE_BACKEND (backend_type())

namespace lfgst {

#define LF_TYPE_FRAGMENT_FRAME_SELECT (lf_fragment_frame_select_get_type())
static GType lf_fragment_frame_select_get_type() {
  static GType type = 0;
  static const GEnumValue values[] = {
      {static_cast<gint>(FrameSelect::kNewest), "The newest camera frame when the request comes",
       "newest"},
      {static_cast<gint>(FrameSelect::kCaptureTime),
       "The frame captured at the request's time: the newest with capture time <= the time the "
       "request carries (the viewer's PTS; deterministic: every camera picks the same capture "
       "instant whatever the network delay, and a recording played back pairs the same frames)",
       "capture-time"},
      {0, nullptr, nullptr}};
  return enum_type(&type, "LfFragmentFrameSelect", values);
}

void describe_fragment(GstElementClass* ec) {
  gst_element_class_set_static_metadata(
      ec, "Light field fragment", "Filter/Video",
      "Random access camera: renders this camera's fragment of each requested view from its "
      "newest frame (Yang et al. 2002, 4.2)",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess num-buffers=60 "
      "focal-surface=false ! f.request "
      "lfcamsrc rig=../shared/data/stanford-chess row=4 col=4 ! lffragment name=f "
      "rig=../shared/data/stanford-chess row=4 col=4 ! lfcompositor ! videoconvert ! "
      "autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "Warning messages, rate-limited, for each kind of request it drops: malformed, larger than "
      "max-pixels, above max-rate for its viewer, or without a camera frame within frame-timeout. "
      "An error at READY when the rig or the camera cannot be read. Nothing a peer sends ends the "
      "element.");
}

void install_fragment_properties(GObjectClass* oc, Properties<FragmentSettings>* props) {
  const FragmentSettings d;  // the defaults: the settings as constructed
  props->add(oc, &FragmentSettings::rig,
             g_param_spec_string("rig", "Rig", "Rig file (.json) or dataset folder", nullptr,
                                 kReadWriteReady));
  add_camera_properties(*props, oc);
  props->add(
      oc, &FragmentSettings::encoding,
      g_param_spec_enum("encoding", "Encoding", "Fragment payload encoding",
                        LF_TYPE_FRAGMENT_ENCODING, static_cast<gint>(d.encoding), kReadWriteReady));
  props->add(
      oc, &FragmentSettings::quality,
      g_param_spec_int("jpeg-quality", "JPEG quality", "JPEG quality (encoding=jpeg), 1..100", 1,
                       100, d.quality, kReadWritePlaying));
  props->add(oc, &FragmentSettings::max_pixels,
             g_param_spec_uint64("max-pixels", "Maximum view size",
                                 "Requests for views of more pixels (width x height) are dropped "
                                 "with a warning",
                                 1, G_MAXUINT64, d.max_pixels, kReadWriteReady));
  props->add(oc, &FragmentSettings::max_rate,
             g_param_spec_double("max-rate", "Maximum request rate",
                                 "Requests per second answered for each viewer (bursts up to one "
                                 "second's worth; one viewer's flood never spends another's); more "
                                 "are dropped with a warning (0: no limit)",
                                 0, 1e6, d.max_rate, kReadWriteReady));
  props->add(oc, &FragmentSettings::max_pixel_rate,
             g_param_spec_double(
                 "max-pixel-rate", "Maximum output pixel rate",
                 "Live: output pixels (width x height of each request) per second answered for "
                 "each viewer, so that a viewer of large views cannot take another's share of the "
                 "host (bursts up to one second's worth; a request larger than one second's worth "
                 "never passes); more are dropped with a warning. Default: 1920x1080 at 60 "
                 "requests a second (0: no limit; not live: none, every request is rendered)",
                 0, 1e12, kDefaultMaxPixelRate, kReadWriteReady));
  props->add(oc, &FragmentSettings::frame_timeout,
             g_param_spec_uint64(
                 "frame-timeout", "Frame timeout",
                 "How long a request waits, in all, for its camera frame (the "
                 "first one; with frame-select=capture-time or for a probe, the "
                 "one of its time), ns, when the camera is live; a request without a frame is "
                 "dropped with a warning (with defer or answer-empty, answered with an empty "
                 "fragment). A non-live camera has no deadline once its caps came "
                 "(before, ten frame-timeouts to start): the request waits for its "
                 "frame, and the camera is held two frames ahead of the requests; the "
                 "requests' end of stream ends the camera's",
                 0, G_MAXUINT64, d.frame_timeout, kReadWriteReady));
  props->add(oc, &FragmentSettings::frame_select,
             g_param_spec_enum("frame-select", "Frame selection",
                               "Which camera frame a request is rendered from",
                               LF_TYPE_FRAGMENT_FRAME_SELECT, static_cast<gint>(d.frame_select),
                               kReadWriteReady));
  gst_type_mark_as_plugin_api(LF_TYPE_FRAGMENT_ENCODING, static_cast<GstPluginAPIFlags>(0));
  props->add(
      oc, &FragmentSettings::backend,
      g_param_spec_enum("backend", "Backend",
                        "Which renderer draws the fragments (lib/lf/render/gl_render.h): the CPU "
                        "kernels or EGL/GLES 3; both give the same pixels within 1 LSB "
                        "(identical on Mesa's llvmpipe)",
                        LF_TYPE_BACKEND, static_cast<gint>(d.backend), kReadWriteReady));
  props->add(
      oc, &FragmentSettings::defer,
      g_param_spec_boolean(
          "defer", "Defer drawing",
          "Leave the drawing to an lfcompositor in this process (lfarray's whole-view "
          "mode): each fragment goes as an empty fragment with its plan and camera image "
          "attached (LfDeferredMeta, gst/lfmeta.h), and the compositor draws all cameras "
          "of a view: with GL in one pass sequence, with no fragment read back; on the CPU "
          "band by band straight into its sums, on all cores (lib/lf/render/composite.h). The "
          "attachment never leaves the process: over RTP or to any other element these "
          "fragments are empty, so use it only with a compositor in the same process. "
          "A layer pair (a focal surface's second planes) goes the same way, both plans on "
          "one empty fragment; the CPU compositor draws the pairs on all cores before "
          "choosing per pixel. Raw encoding only; probes are drawn here as always. A request "
          "without a camera frame (frame-timeout) or that cannot be planned is answered "
          "with an empty fragment (and a warning), not dropped: lfarray plans all cameras "
          "on one thread, whose pads must stay in step",
          FALSE, kReadWriteReady));
  props->add(oc, &FragmentSettings::answer_empty,
             g_param_spec_boolean(
                 "answer-empty", "Answer empty",
                 "Answer a request this camera cannot answer (no camera frame within "
                 "frame-timeout, a fragment it cannot render) with an empty fragment and a "
                 "warning instead of none, so a non-live compositor's pads stay in step. "
                 "lfcamerahost and lfarray set it where a request thread serves several "
                 "cameras: a pad left without the fragment the others have holds "
                 "GstAggregator, and with it the thread and every camera it serves, for ever. "
                 "Always so with defer",
                 FALSE, kReadWriteReady));
  gst_type_mark_as_plugin_api(LF_TYPE_FRAGMENT_FRAME_SELECT, static_cast<GstPluginAPIFlags>(0));
  gst_type_mark_as_plugin_api(LF_TYPE_BACKEND, static_cast<GstPluginAPIFlags>(0));
}

}  // namespace lfgst
