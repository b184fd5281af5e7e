// lfcamerahost's own properties as gst-inspect-1.0 shows them (lfarray's
// whole-view aside), each declared once with its GParamSpec over
// CameraHostSettings; the children's forwarded properties are in
// gst/lfcamerahost.cpp.
#pragma once

#include <gst/gst.h>

#include <string>

#include "lfprops.h"

namespace lfgst {

#define LF_DEFAULT_RECORD_QUALITY 0
#define LF_DEFAULT_REQUEST_MAX_AGE 0
#define LF_DEFAULT_SUM_LATENCY (20 * GST_MSECOND)
#define LF_DEFAULT_WHOLE_VIEW TRUE
#define LF_DEFAULT_REQUEST_THREADS 0

// The bin's own properties (object lock).
struct CameraHostSettings {
  std::string rig, cameras;
  std::string record, playback;  // file name patterns (camera_file_name)
  gint record_quality = LF_DEFAULT_RECORD_QUALITY;
  guint64 request_max_age = LF_DEFAULT_REQUEST_MAX_AGE;  // ns
  bool partial_sums = false;
  guint64 sum_latency = LF_DEFAULT_SUM_LATENCY;  // ns
  // Threads answering requests, each for every n-th camera (0: one per
  // processor core; at least the camera count: one per camera).
  guint request_threads = LF_DEFAULT_REQUEST_THREADS;
  bool whole_view = LF_DEFAULT_WHOLE_VIEW;  // lfarray
};

// Installs the camera host's own properties on `oc`, bound in `props` (ids
// 1..9, in this order).
void install_camera_host_properties(GObjectClass* oc, Properties<CameraHostSettings>* props);

}  // namespace lfgst
