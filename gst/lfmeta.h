// The capture meta that lfcamsrc puts on camera frames.
#pragma once

#include <gst/gst.h>

namespace lfgst {

// Capture meta on camera frames (lfcamsrc): a GstCustomMeta "LfCaptureMeta"
// with fields camera-id (int) and capture-time (guint64, running time in ns).
// In-process only (metas do not cross the network; fragments carry the same
// in their header).
void add_capture_meta(GstBuffer* buf, int camera_id, guint64 capture_time);
bool read_capture_meta(GstBuffer* buf, int* camera_id, guint64* capture_time);

}  // namespace lfgst
