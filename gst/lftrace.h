// Event traces of the elements (LF_TRACE), read by tools/lf-trace.
#pragma once

#include <gst/gst.h>

namespace lfgst {

// Event trace for the latency and bandwidth measurements (tools/lf-trace).
// When the environment variable LF_TRACE names a file, the elements append
// one line per event to it:
//   EVENT VIEWER SEQUENCE CAMERA CLOCK_NS A B C
// CLOCK_NS is the element's pipeline clock time (the shared network clock
// under tools/lf-launch, so comparable across hosts); CAMERA is -1 for
// whole-request events. Events and their values A, B, C:
//   capture    lfcamsrc: frame emitted; SEQUENCE = frame number, A = scheduled
//              running time
//   issue      lfviewrequest: request sent; A = its running time
//   request-in lffragment: request received
//   warped     lffragment: fragment rendered; A = pixels
//   encoded    lffragment: serialized; A = bytes
//   fragment-in lfcompositor: fragment arrived at a sink pad; A = bytes,
//              B = capture time of its source frame (running time, ns)
//   decoded    lfcompositor: fragment parsed/decoded; A = ns spent
//   composited lfcompositor: output frame done; A = fragments, B = CRC-32
//              of the RGBA frame, C = ns spent compositing
//   filled     lfcompositor: an incomplete frame; A = pixels taken from the
//              last frame
bool trace_enabled();
void trace(GstElement* el, const char* event, guint viewer, guint64 sequence, gint camera,
           gint64 a = 0, gint64 b = 0, gint64 c = 0);
// lfcompositor's "composited" and (when `filled` > 0) "filled" events of
// one frame: `rgba`, `bytes` long, made from `fragments` in `ns`.
void trace_frame(GstElement* el, guint viewer, guint64 sequence, gint64 fragments,
                 const guint8* rgba, gsize bytes, gint64 ns, gsize filled);

}  // namespace lfgst
