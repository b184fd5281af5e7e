#include "lfcamerahostprops.h"

namespace lfgst {

void install_camera_host_properties(GObjectClass* oc, Properties<CameraHostSettings>* props) {
  const GParamFlags rw = kReadWriteReady;
  props->add(oc, &CameraHostSettings::rig,
             g_param_spec_string("rig", "Rig", "Rig file (.json) or dataset folder", nullptr, rw));
  props->add(
      oc, &CameraHostSettings::cameras,
      g_param_spec_string("cameras", "Cameras",
                          "Cameras of this host: rig-order indices and ranges, e.g. \"0-15\" or "
                          "\"0,4,8\" (empty: all)",
                          nullptr, rw));
  props->add(oc, &CameraHostSettings::record,
             g_param_spec_string(
                 "record", "Record",
                 "Record every camera's frames and capture times to a Matroska file (matroskamux, "
                 "nanosecond timecodes): a file name with one %d for the camera id, e.g. "
                 "\"rec/cam%02d.mkv\" (empty: no recording)",
                 nullptr, rw));
  props->add(oc, &CameraHostSettings::record_quality,
             g_param_spec_int("record-quality", "Recording quality",
                              "0: lossless (raw RGB); 1..100: JPEG at that quality", 0, 100,
                              LF_DEFAULT_RECORD_QUALITY, rw));
  props->add(
      oc, &CameraHostSettings::playback,
      g_param_spec_string(
          "playback", "Playback",
          "Play a recording (see record) instead of the cameras: same pattern; each camera's "
          "frames come on their recorded capture schedule (clocksync). The camera properties "
          "(mode, framerate, ...) are then unused. With record or playback, frame-select "
          "defaults to capture-time, so the same requests give the same output",
          nullptr, rw));
  props->add(
      oc, &CameraHostSettings::request_max_age,
      g_param_spec_uint64(
          "request-max-age", "Request max age",
          "Live: a request waiting for the cameras (one queue for all: answered by every camera "
          "or dropped by all) behind one of its viewer this much newer (ns, PTS) is dropped; the "
          "viewers' turns are weighted by output pixels, at most 64 wait (lfrequestqueue). 0: "
          "the newest request wins; 70 ms also keeps a small-view viewer's requests that come "
          "while another's large view holds the cameras (+70 ms latency when overloaded). lfarray "
          "uses at least its latency (a request its compositor still waits for is not stale)",
          0, G_MAXUINT64, LF_DEFAULT_REQUEST_MAX_AGE, rw));
  props->add(
      oc, &CameraHostSettings::partial_sums,
      g_param_spec_boolean(
          "partial-sums", "Partial sums",
          "Add up this host's fragments of each request into one (lfpartialsum: premultiplied "
          "colour and weight, encoded once with encoding and jpeg-quality; the compositor's "
          "renormalisation keeps the frame). Pays when the cameras are a contiguous block of "
          "the grid (their fragments overlap); a dead host then leaves a hole where only its "
          "block sees",
          FALSE, rw));
  props->add(oc, &CameraHostSettings::sum_latency,
             g_param_spec_uint64(
                 "sum-latency", "Partial sum latency",
                 "Live, with partial-sums: how long after a request's time (ns, its PTS) the sum "
                 "leaves with the cameras that answered when one of them has not (lfpartialsum's "
                 "latency); keep it inside the compositor's deadline",
                 0, G_MAXUINT64, LF_DEFAULT_SUM_LATENCY, rw));
  props->add(
      oc, &CameraHostSettings::request_threads,
      g_param_spec_uint(
          "request-threads", "Request threads",
          "Threads that answer the view requests, each drawing the fragments of every n-th "
          "camera in turn (a queue, then a tee): a request costs one hand-off per thread "
          "instead of one per camera, and the cameras a thread serves answer every request "
          "(lffragment answer-empty); in lfarray each thread hands the compositor its fragments "
          "of a request in one buffer for up to 16 cameras. 0: one per processor core and one "
          "more (a core is not left "
          "idle while a thread waits for the compositor); the camera count or more: one "
          "per camera (the paper's: each camera its own machine). Where a request may wait for "
          "its camera's frame (live cameras, is-live; frames picked by capture time: record, "
          "playback, frame-select) each camera keeps its own; lfarray's whole-view mode plans "
          "every camera on one",
          0, G_MAXUINT, LF_DEFAULT_REQUEST_THREADS, rw));
}

}  // namespace lfgst
