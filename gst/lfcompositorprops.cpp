/**
 * SECTION:element-lfcompositor
 * @title: lfcompositor
 *
 * Collects the fragments of each view request and adds them into the output
 * frame (Yang et al. 2002, Section 4.3), renormalised by the accumulated
 * weight (lib/lf/render/composite.h). An LfFragmentAggregator
 * (gst/lffragmentaggregator.h, over GstAggregator): a request is composited
 * when all of its fragments are in, or at the deadline in live pipelines
 * with whatever arrived, so a dead camera never stops the output. A partial
 * sum (`lfpartialsum`, wire version 2) counts as the cameras it holds (at
 * most the rig's). Output: raw video (RGBA, RGBx or I420; gst/lfvideoout.h).
 *
 * Every fragment is validated (lib/lf/wire/wire.h) before anything is
 * decoded: its viewer, camera, sequence window and size; the CRC check is
 * skipped only for buffers `lffragment` sealed in this process
 * (`LfSealedMeta`, which no copy and nothing from the network has). Raw
 * fragments are added straight from the received buffers; JPEG ones are
 * decoded on the streaming thread that brings them (gst/lfarrival.h).
 * Drawings that `lffragment defer=true` left to it (lfarray's whole-view
 * mode, `LfDeferredMeta`) are drawn here by its renderer
 * (lib/lf/render/renderer.h: GL uploads each camera frame once; the CPU
 * fuses the drawing into the compositing, bands of rows on all cores).
 *
 * Live, requests over `max-pixel-rate` (output pixels a second, the camera
 * hosts' budget) are dropped whole at their first fragment, counted in
 * `over-budget`. Live, when requests come faster than it composites, the
 * newest request wins: the requests waiting behind a newer complete one
 * are dropped (counted in `lf-rate`'s `stale`), so the latency stays
 * within a few frame periods of the rate it achieves. When no fragment
 * came for 2 s (LF_IDLE_RELEASE) or the stream ended, the frames, sums and
 * output pool are freed and the heap trimmed (at 3840x2160, two to four
 * frames of 33 MB, 66-133 MB freed in Hostile.AQuietViewersCompositorGivesItsMemoryBack,
 * and 133 MB more of the sums that a surface of two layers keeps; a plane's
 * sums stay band by band in cache); the next frame allocates them again.
 *
 * The output rate is the fragment caps' `framerate` (the viewer's request
 * rate; the `framerate` property overrides it). Live, the deadline after a
 * request's running time (gst_aggregator_set_latency) is one frame period
 * or, with `adaptive-deadline` (the default), longer when the fragments
 * take longer to arrive: the 99th percentile of their arrival times plus a
 * fifth, at most 500 ms (lf::ArrivalDeadline, lib/lf/session/compositor_host.h;
 * each change posts a latency message). The `latency` property, when set,
 * replaces both. The paper's deadline (one period) is `adaptive-deadline=false`.
 *
 * Not live (upstream answers a latency query not live), every request is
 * waited for and throughput is what counts: each sink pad may hold the
 * fragments of up to 16 requests (fewer for large views, about 128 MB of
 * fragments in all), so a camera's request thread that runs ahead does not
 * wait for the compositor fragment by fragment. GstAggregator holds one
 * buffer a pad unless its latency allows more, so this is its
 * `min-upstream-latency`, set to that many request periods unless the user
 * set it; it is dropped again when a latency query comes back live.
 *
 * Probes are scored here, never composited (lib/lf/session/probe_scoring.h):
 * a focus probe gives the depth under a clicked pixel (an upstream
 * `lf-focus` event), a surface probe a focal surface for the whole view (an
 * upstream `lf-surface` event; see `lfviewrequest`'s focal-surface; live,
 * its estimate runs on a thread of its own, 40 ms at 1080p, while the frames
 * go on; not live, at once, so that the frames are reproducible). This is
 * the one place where every camera's contribution arrives separately, so it
 * works unchanged across machines: no camera image leaves its host.
 *
 * With `second-planes` (the default; false gives one plane per tile), tiles
 * next to a depth edge or with a thin structure inside get a second plane
 * (lib/lf/focus/focal_surface.h); a camera then answers with its layer 0 and layer 1 in one buffer,
 * and the frame takes per pixel the layer whose cameras agree (lf::LayerCompositor, on the CPU
 * whatever the backend). A buffer whose second fragment is not the same
 * camera's layer 1 of the same request is dropped with a warning.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfviewrequest rig=rig.json num-buffers=30 ! tee name=t \
 *   t. ! queue ! f0.request lfcamsrc rig=rig.json camera-id=0 ! f0.sink \
 *   lffragment name=f0 rig=rig.json camera-id=0 ! c.sink_0 \
 *   t. ! queue ! f1.request lfcamsrc rig=rig.json camera-id=1 ! f1.sink \
 *   lffragment name=f1 rig=rig.json camera-id=1 ! c.sink_1 \
 *   lfcompositor name=c rig=rig.json ! videoconvert ! autovideosink
 * ]|
 */
#include "lfcompositorprops.h"

#include "lfbackend.h"

namespace lfgst {

void describe_compositor(GstElementClass* ec) {
  gst_element_class_set_static_metadata(
      ec, "Light field compositor", "Filter/Editor/Video/Compositor",
      "Adds the image fragments of each view request into the output frame, renormalised; "
      "composites incomplete requests at the deadline in live pipelines (one request period, "
      "longer when the fragments take longer to arrive (adaptive-deadline), or the 'latency' "
      "property, ns; Yang et al. 2002, 4.3)",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      LF_TWO_CAMERA_EXAMPLE("c") "lfcompositor name=c ! videoconvert ! autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "Upstream custom events it sends: lf-focus (viewer-id, probe-id, inverse-depth, "
      "capture-time) and lf-surface (a focal surface: tile, cols, rows, planes, plane-of) "
      "answering the probes of lfviewrequest; navigation and lf-view events from the video sink go "
      "upstream tagged with its viewer-id. An lf-rate element message once a second while frames "
      "go out: viewer-id, requested-fps, fps, complete-fps, interval, over-budget, stale (the "
      "rate achieved; docs/steering.md). Warning messages, rate-limited, name what was dropped: "
      "a malformed fragment, a fragment of another size or outside the sequence window, a camera's "
      "second fragment for one request, a click that cannot be focused.");
}

void install_compositor_properties(GObjectClass* oc, Properties<CompositorSettings>* props) {
  const CompositorSettings d;  // the defaults: the settings as constructed
  const GParamFlags rw = kReadWriteReady;
  props->add(oc, &CompositorSettings::rig,
             g_param_spec_string("rig", "Rig",
                                 "Rig file or dataset folder: a request is complete when every "
                                 "camera of the rig has answered (unset: one fragment per sink "
                                 "pad)",
                                 nullptr, rw));
  props->add(
      oc, &CompositorSettings::viewer_id,
      g_param_spec_int("viewer-id", "Viewer id", "Composite only this viewer's requests (-1: any)",
                       -1, G_MAXINT, d.viewer_id, rw));
  props->add(oc, &CompositorSettings::width,
             g_param_spec_int("width", "Width",
                              "Width of one view, pixels (0: from the fragment caps, the viewer's "
                              "request size). Set it where fragments arrive from a network: caps "
                              "travel in band and any sender can announce them",
                              0, kMaxOutputSide, d.width, rw));
  props->add(
      oc, &CompositorSettings::height,
      g_param_spec_int("height", "Height", "Height of one view, pixels (0: from the fragment caps)",
                       0, kMaxOutputSide, d.height, rw));
  props->add(oc, &CompositorSettings::framerate,
             gst_param_spec_fraction("framerate", "Frame rate",
                                     "Output frame rate; 0/1: the request rate from the fragment "
                                     "caps (30/1 if they carry none)",
                                     0, 1, 1000, 1, d.framerate.n, d.framerate.d, rw));
  props->add(oc, &CompositorSettings::stereo,
             g_param_spec_boolean("stereo", "Stereo",
                                  "Composite the requests of viewer-id (left) and viewer-id + 1 "
                                  "(right) side by side (lfviewrequest stereo-baseline), output "
                                  "twice as wide; changeable while playing (the output is then "
                                  "renegotiated)",
                                  d.stereo, kReadWritePlaying));
  props->add(
      oc, &CompositorSettings::second_planes,
      g_param_spec_boolean(
          "second-planes", "Second planes",
          "Surface probes (lfviewrequest focal-surface): tiles next to a depth edge get the "
          "neighbouring depth as a second plane, tiles with a thin structure inside (bars, "
          "wires) its depth; the cameras then send those tiles twice "
          "(layer 1: the nearer plane) and this element takes per pixel the layer whose "
          "cameras agree (lib/lf/render/composite.h LayerCompositor, on the CPU); more bytes where "
          "the scene has depth edges or thin structures, none elsewhere; false: one plane per "
          "tile",
          d.second_planes, kReadWritePlaying));
  props->add(oc, &CompositorSettings::adaptive_deadline,
             g_param_spec_boolean(
                 "adaptive-deadline", "Adaptive deadline",
                 "Live: composite a request that is not complete once its fragments are overdue "
                 "by how long they take to arrive (the 99th percentile of the last 2048, plus a "
                 "fifth, at most 500 ms; never under one request period), so that cameras slower "
                 "than a request period still give complete frames. false: at one request period "
                 "(the paper's deadline). The latency property, when set, replaces either",
                 TRUE, kReadWriteReady));
  props->add(
      oc, &CompositorSettings::backend,
      g_param_spec_enum("backend", "Backend",
                        "Which renderer adds the fragments and resolves the frame "
                        "(lib/lf/render/gl_render.h): the CPU (bands of rows on every core) or "
                        "EGL/GLES 3 (blending); the same frame within 1 LSB (identical on "
                        "Mesa's llvmpipe)",
                        backend_type(), static_cast<gint>(lf::Backend::kAuto), kReadWriteReady));
  props->add(oc, &CompositorSettings::max_pixel_rate,
             g_param_spec_double(
                 "max-pixel-rate", "Maximum output pixel rate",
                 "Live: output pixels (width x height, of one eye in stereo) of the requests "
                 "composited per second, the camera hosts' budget (lffragment max-pixel-rate) "
                 "kept again here: a request over it is dropped whole, unparsed, with a warning, "
                 "so requests the camera hosts let through (their budget raised, or forged on "
                 "plain RTP) cost this host at most this much (bursts up to one second's worth). "
                 "Default: 1920x1080 at 60 requests a second (0: no limit; not live: none, every "
                 "request is composited)",
                 0, 1e12, d.max_pixel_rate, kReadWriteReady));
  const GParamFlags ro = static_cast<GParamFlags>(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS);
  props->add(oc, &CompositorSettings::frames,
             g_param_spec_uint64("frames", "Frames", "Frames composited since the element started",
                                 0, G_MAXUINT64, 0, ro));
  props->add(oc, &CompositorSettings::last_cameras,
             g_param_spec_uint("last-cameras", "Cameras in the last frame",
                               "Cameras whose fragment was in the last composited frame (both "
                               "eyes counted in stereo); fewer than the rig's: the deadline "
                               "passed without them",
                               0, G_MAXUINT, 0, ro));
  props->add(oc, &CompositorSettings::over_budget,
             g_param_spec_uint64("over-budget", "Requests over the budget",
                                 "Requests dropped since the element started because they were "
                                 "over max-pixel-rate",
                                 0, G_MAXUINT64, 0, ro));
}

}  // namespace lfgst
