/**
 * SECTION:element-lfviewrequest
 * @title: lfviewrequest
 *
 * Produces view requests (Yang et al. 2002, Section 4.3: a virtual view and a
 * focal plane) at a rate, for one viewer: a fixed view from the properties, a
 * keyframed camera path (`path`) or an orbit over the camera plane (`orbit`).
 * Output: `application/x-lf-view-request` buffers (byte layout in
 * lib/lf/wire/wire.h) whose caps carry the request `framerate`, `width` and
 * `height`. Positions are in the rig's units and world frame
 * (lib/lf/geometry/rig.h); views are built by lib/lf/geometry/view_builder.h,
 * as `lf-render` builds them. The viewer's state from request to request
 * (click-to-focus probes, the focal surface's probe cadence, navigation
 * gestures, the assembly of each tick's requests) is lf::ViewerSession
 * (lib/lf/session/viewer_session.h); this element is its glue, and its
 * properties are declared in gst/lfviewprops.cpp.
 *
 * Steering while playing (docs/steering.md): the view properties are
 * changeable in PLAYING and apply from the next request on; some are
 * controllable (interpolated camera moves). An upstream `lf-view` event
 * (gst/lfevents.h) sets several at once, checked whole; the `view-event`
 * action signal writes one from a structure of fields, checked against
 * these properties (for applications: docs/examples/steer.c); navigation events
 * from the video sink drag the eye, move the focal plane with the wheel, and
 * focus where the user right-clicks (a focus probe, answered by
 * `lfcompositor` with an `lf-focus` event).
 *
 * Focal surface (the default; docs/rendering.md): every `surface-interval`
 * requests a surface probe goes out with the tick's request and
 * `lfcompositor` answers with an `lf-surface` event, a plane per 16-pixel
 * tile that the next requests carry (view request version 3). The paper's
 * single focal plane is `focal-surface=false`; refocusing while playing sets
 * it so (notified). Without any answer (no compositor in this pipeline) the
 * probes stop with one warning and `focal-plane` holds.
 *
 * `aperture` / `f-number` widen the paper's tent aperture, `ulr-cameras`
 * uses Unstructured Lumigraph weights, `four-camera` bilinear weights over
 * a grid cell, `sampling=bicubic` Keys' cubic in
 * place of bilinear (lib/lf/geometry/view.h; figures in docs/rendering.md).
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfviewrequest rig=rig.json position="<0,0,0>" focal-plane=depth:2 \
 *   num-buffers=1 ! fakesink dump=true
 * ]|
 */
#include "lfviewprops.h"

#include "lf/focus/focal_surface.h"
#include "lf/render/quilt.h"
#include "lfevents.h"

#define MAX_COORD kMaxCoordinate

namespace lfgst {

#define LF_TYPE_SAMPLING (lf_sampling_get_type())
static GType lf_sampling_get_type() {
  static GType type = 0;
  static const GEnumValue values[] = {
      {static_cast<gint>(lf::Sampling::kBilinear), "Bilinear (the paper's)", "bilinear"},
      {static_cast<gint>(lf::Sampling::kBicubic),
       "Bicubic (Keys, a = -0.5): sharper, slower to warp", "bicubic"},
      {0, nullptr, nullptr}};
  return enum_type(&type, "LfSampling", values);
}

void describe_view_request(GstElementClass* ec) {
  gst_element_class_set_static_metadata(
      ec, "Light field view requests", "Source/Metadata",
      "Produces view requests (virtual view + focal plane) for the light field cameras "
      "(Yang et al. 2002, 4.3). View properties change while playing; an upstream 'lf-view' "
      "event sets several at once. Navigation from the video sink: drag (button 1) moves the "
      "eye on the camera plane, the wheel (buttons 4/5) the focal plane, arrow keys the eye by "
      "1/4 camera spacing, Page_Up/Page_Down (Prior/Next, +/-) along the normal, r resets",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess orbit=0.5 "
      "num-buffers=60 ! lfarray rig=../shared/data/stanford-chess ! videoconvert ! autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "Upstream custom events it takes: lf-view (any view property as a field of the same name and "
      "type, and viewer-id, uint: applied whole, or refused with a warning message naming the bad "
      "field), lf-focus and lf-surface (lfcompositor's answers to its probes), and navigation "
      "events (drag, wheel, keys, click to focus). The view-event action signal (fields, a "
      "GstStructure of view properties -> the lf-view GstEvent, or NULL when a field is bad) "
      "writes one for an application to send at its sink. An error message at READY for each bad "
      "property "
      "value; a warning when the focal plane lies behind the cameras.");
}

// `view-event`: the lf-view event for a structure of fields (any name),
// or null with a warning in the log naming the bad field.
static GstEvent* view_event_action(GstElement* self, const GstStructure* fields) {
  if (!fields) return nullptr;
  std::string why;
  GstEvent* e = view_event(fields, G_OBJECT(self), kMaxCoordinate, &why);
  if (!e) GST_WARNING_OBJECT(self, "view-event: %s", why.c_str());
  return e;
}

void install_view_request_actions(GObjectClass* oc) {
  g_signal_new_class_handler("view-event", G_TYPE_FROM_CLASS(oc),
                             static_cast<GSignalFlags>(G_SIGNAL_RUN_LAST | G_SIGNAL_ACTION),
                             G_CALLBACK(view_event_action), nullptr, nullptr, nullptr,
                             GST_TYPE_EVENT, 1, GST_TYPE_STRUCTURE);
}

ViewRequestSpecs install_view_request_properties(GObjectClass* oc,
                                                 Properties<ViewRequestSettings>* props) {
  const ViewRequestSettings d;  // the defaults: the settings as constructed
  ViewRequestSpecs specs;
  const GParamFlags rw = kReadWriteReady;
  props->add(
      oc, &ViewRequestSettings::rig,
      g_param_spec_string("rig", "Rig", "Rig file (.json) or dataset folder (lf-render --input)",
                          nullptr, rw));
  props->add(oc, &ViewRequestSettings::viewer_id,
             g_param_spec_uint("viewer-id", "Viewer id", "Tag of this viewer's requests and output",
                               0, G_MAXUINT32, d.viewer_id, rw));
  props->add(oc, &ViewRequestSettings::width,
             g_param_spec_int("width", "Width", "Output width, pixels", 2, 16384, d.width, rw));
  props->add(oc, &ViewRequestSettings::height,
             g_param_spec_int("height", "Height", "Output height, pixels", 2, 16384, d.height, rw));
  // View properties: changeable in PLAYING, from the next request on.
  const GParamFlags play = kReadWritePlaying;
  const GParamFlags ctrl = static_cast<GParamFlags>(play | GST_PARAM_CONTROLLABLE);
  auto coordinate = [] {
    return g_param_spec_double(
        "coordinate", "Coordinate", "Rig units", -MAX_COORD, MAX_COORD, 0,
        static_cast<GParamFlags>(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS));
  };
  props->add(oc, &ViewRequestSettings::position,
             gst_param_spec_array("position", "Position",
                                  "Eye <x, y, z>, rig units, world frame (gst-launch: "
                                  "position=\"<0.1, 0, 0>\"; empty: the centroid of the camera "
                                  "centres). The eye offset eye-s/t/w is added to it",
                                  coordinate(), play));
  props->add(oc, &ViewRequestSettings::look_at,
             gst_param_spec_array("look-at", "Look at",
                                  "Target <x, y, z>, rig units, world frame (empty: look like the "
                                  "rig's cameras, with intrinsics interpolated from the "
                                  "surrounding ones)",
                                  coordinate(), play));
  specs.eye_s =
      g_param_spec_double("eye-s", "Eye s",
                          "Eye offset along the camera plane's u axis (its s "
                          "coordinate, lib/lf/geometry/rig.h), rig units; drag and arrow keys "
                          "change it",
                          -MAX_COORD, MAX_COORD, 0, ctrl);
  props->add(oc, &ViewRequestSettings::eye_s, specs.eye_s);
  specs.eye_t = g_param_spec_double("eye-t", "Eye t",
                                    "Eye offset along the camera plane's v axis (t), rig units",
                                    -MAX_COORD, MAX_COORD, 0, ctrl);
  props->add(oc, &ViewRequestSettings::eye_t, specs.eye_t);
  specs.eye_w = g_param_spec_double("eye-w", "Eye w",
                                    "Eye offset along the camera plane's normal, the way the "
                                    "cameras look (dolly), rig units; Page_Up/Page_Down change it",
                                    -MAX_COORD, MAX_COORD, 0, ctrl);
  props->add(oc, &ViewRequestSettings::eye_w, specs.eye_w);
  props->add(oc, &ViewRequestSettings::vfov,
             g_param_spec_double(
                 "vfov", "Vertical FOV",
                 "Vertical field of view, degrees (0: from the cameras, or 50 with look-at)", 0,
                 179.9, d.vfov, ctrl));
  props->add(oc, &ViewRequestSettings::focal_plane,
             g_param_spec_string("focal-plane", "Focal plane",
                                 "infinity | depth:Z (rig units from the camera plane) | param:A "
                                 "(light-slab focal parameter, pixels of shift per unit) | "
                                 "plane:nx,ny,nz,d (world frame, n.X + d = 0); used while "
                                 "focal-depth is 0",
                                 d.focal_plane.c_str(), play));
  props->add(oc, &ViewRequestSettings::continuous_focus,
             g_param_spec_boolean(
                 "continuous-focus", "Continuous focus",
                 "Keep focusing at the last clicked point (the view centre before any click): "
                 "a focus probe every 5 requests, each answer moving the focal plane half way "
                 "(in inverse depth)",
                 FALSE, play));
  props->add(
      oc, &ViewRequestSettings::focal_surface,
      g_param_spec_boolean(
          "focal-surface", "Focal surface",
          "Focus each 16-pixel tile of the view on its own plane, estimated from the "
          "cameras' fragments (lib/lf/focus/surface_probe.h): every surface-interval requests a "
          "surface probe (32 requests for the view at 160 pixels wide, one per candidate "
          "plane, in one buffer) goes out with the request, lfcompositor estimates the "
          "surface from the answers and sends it back (an lf-surface event), and the "
          "requests carry it "
          "from then on (view request version 3) in place of focal-plane and focal-depth. "
          "false: the paper's one focal plane per view (focal-plane, focal-depth); "
          "refocusing while playing (the wheel, a click, focal-depth or focal-plane set) "
          "sets it false. Without "
          "an lfcompositor downstream in this pipeline to answer, the probes stop after "
          "the first few, with a warning, and focal-plane is used",
          TRUE, play));
  props->add(oc, &ViewRequestSettings::surface_interval,
             g_param_spec_uint("surface-interval", "Surface interval",
                               "Requests from one surface probe to the next with focal-surface "
                               "(in between, the view keeps the last surface: meant for a steady "
                               "or slowly moving view)",
                               1, G_MAXINT32, d.surface_interval, play));
  props->add(
      oc, &ViewRequestSettings::surface_planes,
      g_param_spec_uint("surface-planes", "Surface planes",
                        "Distinct planes of the focal surface in the last request (0: "
                        "none, the focal plane)",
                        0, lf::FocalSurface::kMaxPlanes, 0,
                        static_cast<GParamFlags>(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  props->add(
      oc, &ViewRequestSettings::surface_two_plane_tiles,
      g_param_spec_uint("surface-two-plane-tiles", "Two-plane tiles",
                        "Tiles of the focal surface in the last request that have a second "
                        "plane (lfcompositor second-planes: their cameras send them twice)",
                        0, G_MAXUINT, 0,
                        static_cast<GParamFlags>(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  specs.focal_depth = g_param_spec_double(
      "focal-depth", "Focal depth",
      "Focal plane parallel to the camera plane at this depth, rig units along its normal "
      "(0: use focal-plane); the wheel changes it",
      0, MAX_COORD, d.focal_depth, ctrl);
  props->add(oc, &ViewRequestSettings::focal_depth, specs.focal_depth);
  props->add(oc, &ViewRequestSettings::aperture,
             g_param_spec_double(
                 "aperture", "Aperture",
                 "Synthetic aperture diameter on the camera plane, rig units (Isaksen et al. "
                 "2000): the paper's tent spans 2 camera spacings and is the smallest (0 or "
                 "anything up to it: the tent); wider apertures blend more cameras, so what is "
                 "off the focal plane blurs instead of doubling, at more fragment pixels "
                 "(up to 16 tents wide)",
                 0, MAX_COORD, 0, ctrl));
  props->add(oc, &ViewRequestSettings::f_number,
             g_param_spec_double(
                 "f-number", "f-number",
                 "Aperture as a full-frame-equivalent f-number, overriding aperture when > 0: "
                 "N = F / D with F = 36 mm x fx / width, the focal length of a 36 mm wide sensor "
                 "with the view's field of view (such a lens at f/N, focused on the focal plane, "
                 "blurs as this aperture does); needs the rig's unit to be mm, cm or m",
                 0, 1e6, 0, ctrl));
  props->add(
      oc, &ViewRequestSettings::ulr_cameras,
      g_param_spec_uint(
          "ulr-cameras", "ULR cameras",
          "Unstructured Lumigraph weights (Buehler et al. 2001, lib/lf/geometry/view.h) blending "
          "the "
          "k cameras nearest each ray in angle, for rigs without a grid and so that a lost "
          "camera leaves no hole; 0: the tent (aperture, f-number apply), else k (1 counts as 2)",
          0, lf::kMaxUlrCameras, 0, ctrl));
  props->add(
      oc, &ViewRequestSettings::four_camera,
      g_param_spec_boolean(
          "four-camera", "Four-camera weights",
          "Bilinear weights over the grid cell around each ray (lib/lf/geometry/view.h "
          "kFourCamera): a view at a cell's centre blends its four cameras where the paper's "
          "tent blends two; about 1.3x the fragment pixels; on grid rigs, when ulr-cameras, "
          "aperture and f-number are 0 (docs/rendering.md)",
          FALSE, ctrl));
  props->add(oc, &ViewRequestSettings::sampling,
             g_param_spec_enum("sampling", "Sampling",
                               "How the cameras resample their images into fragments (the "
                               "requests carry it; focus and surface probes stay bilinear)",
                               LF_TYPE_SAMPLING, static_cast<gint>(lf::Sampling::kBilinear), ctrl));
  props->add(
      oc, &ViewRequestSettings::path,
      g_param_spec_string("path", "Camera path",
                          "Keyframed camera path (JSON, docs/rendering.md); overrides position",
                          nullptr, play));
  props->add(oc, &ViewRequestSettings::orbit,
             g_param_spec_double("orbit", "Orbit",
                                 "Circular path on the camera plane, radius as a fraction of the "
                                 "array's half extent (0: off)",
                                 0, 10, d.orbit, play));
  props->add(oc, &ViewRequestSettings::dolly,
             g_param_spec_double(
                 "dolly", "Dolly",
                 "With orbit: amplitude of motion along the camera-plane normal, rig units",
                 -MAX_COORD, MAX_COORD, d.dolly, play));
  props->add(oc, &ViewRequestSettings::path_frames,
             g_param_spec_int("path-frames", "Path frames", "Requests per pass over the path/orbit",
                              1, 1000000, d.path_frames, play));
  props->add(oc, &ViewRequestSettings::framerate,
             gst_param_spec_fraction("framerate", "Frame rate",
                                     "Requests per second (also in the src caps)", 1, 1000, 1000, 1,
                                     d.framerate.n, d.framerate.d, rw));
  props->add(oc, &ViewRequestSettings::live,
             g_param_spec_boolean("is-live", "Live",
                                  "Emit requests in real time on the pipeline clock", d.live, rw));
  props->add(oc, &ViewRequestSettings::stereo_baseline,
             g_param_spec_double("stereo-baseline", "Stereo baseline",
                                 "Eye separation in rig units; > 0 emits a left (viewer-id) and a "
                                 "right (viewer-id + 1) request per tick, for lfcompositor "
                                 "stereo=true",
                                 0, MAX_COORD, d.stereo_baseline, ctrl));
  props->add(oc, &ViewRequestSettings::quilt_views,
             g_param_spec_uint(
                 "quilt-views", "Quilt views",
                 "0: one view. 2..128: a quilt for a light-field display (docs/displays.md): this "
                 "many eyes along the view's x axis, each answered by every camera in the same "
                 "request round, tiled in the width x height frame in quilt-columns x "
                 "quilt-rows tiles, the first (leftmost) eye at the bottom-left, then left to "
                 "right and upward; the eyes share the focal plane (no focal surface)",
                 0, lf::Quilt::kMaxViews, 0, rw));
  props->add(oc, &ViewRequestSettings::quilt_cols,
             g_param_spec_uint("quilt-columns", "Quilt columns",
                               "Tiles across the quilt; width must be a multiple", 1,
                               lf::Quilt::kMaxTiles, 8, rw));
  props->add(oc, &ViewRequestSettings::quilt_rows,
             g_param_spec_uint("quilt-rows", "Quilt rows",
                               "Tiles down the quilt; height must be a multiple", 1,
                               lf::Quilt::kMaxTiles, 6, rw));
  props->add(oc, &ViewRequestSettings::view_cone,
             g_param_spec_double("view-cone", "View cone",
                                 "Quilt: the angle (degrees) between the first and the last eye "
                                 "seen from the focal plane's point on the view axis (a "
                                 "display's view cone, e.g. 40); 0: the baseline is the camera "
                                 "array's width along the view's x axis (all the parallax it "
                                 "captured, none made up). quilt-baseline, if set, wins",
                                 0, 120, 0, ctrl));
  props->add(oc, &ViewRequestSettings::quilt_baseline,
             g_param_spec_double("quilt-baseline", "Quilt baseline",
                                 "Quilt: first eye to last in rig units; 0: from view-cone (one "
                                 "camera spacing where the cone is focused at infinity)",
                                 0, MAX_COORD, 0, ctrl));
  return specs;
}

}  // namespace lfgst
