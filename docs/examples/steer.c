/* steer: embeds the lightfield plugin in an application and steers the
 * virtual camera while the pipeline plays (issue 14; README "Embedding").
 *
 *   1. gst_parse_launch: lfviewrequest ! lfarray ! appsink, live;
 *   2. a property change while PLAYING (eye-s, rig units on the camera plane);
 *   3. the lf-view upstream event, sent at the sink: several view fields at
 *      once (position, focal-depth), applied together to the next request;
 *      written by lfviewrequest's view-event action, which refuses a bad
 *      field (a misspelt one here: "refused focal-dept");
 *   4. a GstController camera move: eye-t interpolated linearly over 1 s.
 *
 * It prints what it set and what lfviewrequest reports back, one line per
 * step ("eye-s 0.01", "focal-depth 2.5", "refused focal-dept", "eye-t T V"),
 * and exits 0 once FRAMES frames (default 60) were received.
 *
 * usage: steer RIG.json [MODE] [FRAMES]   (MODE: lfcamsrc mode, default dataset)
 * build: cc steer.c $(pkg-config --cflags --libs gstreamer-1.0 gstreamer-app-1.0 \
 *          gstreamer-controller-1.0) -o steer
 */
#include <gst/app/gstappsink.h>
#include <gst/controller/gstdirectcontrolbinding.h>
#include <gst/controller/gstinterpolationcontrolsource.h>
#include <gst/gst.h>
#include <stdio.h>
#include <stdlib.h>

/* A whole view at once: the fields in GStreamer's structure string form,
 * made into an lf-view event by lfviewrequest's view-event action (the
 * collection's event codec: each field checked against the property of the
 * same name, the event versioned), then sent upstream from the sink.
 * Returns 0 when the fields were refused (the log says which was bad). */
static int send_view_event(GstElement* view, GstElement* sink, const char* fields) {
  GstStructure* s = gst_structure_new_from_string(fields);
  GstEvent* event = NULL;
  if (s) g_signal_emit_by_name(view, "view-event", s, &event);
  if (s) gst_structure_free(s);
  if (!event) return 0;
  /* Upstream from the sink, through lfarray, to lfviewrequest. */
  gst_element_send_event(sink, event);
  return 1;
}

int main(int argc, char** argv) {
  gst_init(&argc, &argv);
  if (argc < 2) {
    fprintf(stderr, "usage: %s RIG.json [MODE] [FRAMES]\n", argv[0]);
    return 2;
  }
  const char* rig = argv[1];
  const char* mode = argc > 2 ? argv[2] : "dataset";
  const int frames = argc > 3 ? atoi(argv[3]) : 60;
  gchar* desc = g_strdup_printf(
      "lfviewrequest name=view rig=%s is-live=true framerate=30/1 width=160 height=120 ! "
      "lfarray rig=%s mode=%s is-live=true framerate=30/1 ! "
      "appsink name=out sync=false max-buffers=4 drop=true",
      rig, rig, mode);
  GError* err = NULL;
  GstElement* pipe = gst_parse_launch(desc, &err);
  g_free(desc);
  if (!pipe) {
    fprintf(stderr, "steer: %s\n", err->message);
    return 1;
  }
  GstElement* view = gst_bin_get_by_name(GST_BIN(pipe), "view");
  GstElement* sink = gst_bin_get_by_name(GST_BIN(pipe), "out");
  gst_element_set_state(pipe, GST_STATE_PLAYING);

  GstControlSource* move = NULL;
  int got = 0;
  while (got < frames) {
    GstSample* sample = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 5 * GST_SECOND);
    if (!sample) {
      fprintf(stderr, "steer: no frame for 5 s\n");
      return 1;
    }
    GstClockTime pts = GST_BUFFER_PTS(gst_sample_get_buffer(sample));
    gst_sample_unref(sample);
    ++got;
    if (got == 10) { /* a property, while playing */
      g_object_set(view, "eye-s", 0.01, NULL);
      double s;
      g_object_get(view, "eye-s", &s, NULL);
      printf("eye-s %g\n", s);
    } else if (got == 20) { /* a whole view at once, from the sink */
      if (!send_view_event(view, sink, "lf-view, position=<0.0, 0.0, 0.0>, focal-depth=2.5")) {
        fprintf(stderr, "steer: the view was refused\n");
        return 1;
      }
      double d;
      g_object_get(view, "focal-depth", &d, NULL);
      printf("focal-depth %g\n", d);
      if (!send_view_event(view, sink, "lf-view, focal-dept=2.0")) printf("refused focal-dept\n");
    } else if (got == 30) { /* a camera move: eye-t from 0 to 0.02 over 1 s */
      move = gst_interpolation_control_source_new();
      g_object_set(move, "mode", GST_INTERPOLATION_MODE_LINEAR, NULL);
      GstTimedValueControlSource* tv = GST_TIMED_VALUE_CONTROL_SOURCE(move);
      /* Control values are 0..1, mapped onto the property's range; use an
       * absolute binding to give rig units directly. */
      gst_timed_value_control_source_set(tv, pts, 0.0);
      gst_timed_value_control_source_set(tv, pts + GST_SECOND, 0.02);
      gst_object_add_control_binding(GST_OBJECT(view), gst_direct_control_binding_new_absolute(
                                                           GST_OBJECT(view), "eye-t", move));
    } else if (got > 30) {
      double t;
      g_object_get(view, "eye-t", &t, NULL);
      printf("eye-t %.3f %g\n", (double)pts / GST_SECOND, t);
    }
  }
  gst_element_set_state(pipe, GST_STATE_NULL);
  if (move) gst_object_unref(move);
  gst_object_unref(view);
  gst_object_unref(sink);
  gst_object_unref(pipe);
  printf("frames %d\n", got);
  return 0;
}
