// The capture meta that lfcamsrc puts on camera frames, and the sealed meta
// that lffragment puts on the fragments it serialises.
#pragma once

#include <gst/gst.h>

namespace lfgst {

// Capture meta on camera frames (lfcamsrc): a GstCustomMeta "LfCaptureMeta"
// with fields camera-id (int) and capture-time (guint64, running time in ns).
// In-process only (metas do not cross the network; fragments carry the same
// in their header).
void add_capture_meta(GstBuffer* buf, int camera_id, guint64 capture_time);
bool read_capture_meta(GstBuffer* buf, int* camera_id, guint64* capture_time);

// Sealed meta (LfSealedMeta): on a fragment buffer that lffragment
// serialised and sealed (CRC written) in this process. Never copied with a
// buffer (no transform), so only that buffer object carries it, and nothing
// from the network can: lfcompositor skips the CRC check of such a buffer,
// the bytes never having left the process (every other check still runs).
void add_sealed_meta(GstBuffer* buf);
bool has_sealed_meta(GstBuffer* buf);

}  // namespace lfgst
