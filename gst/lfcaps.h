// Caps of the collection's in-band formats (byte layouts: lib/lf/wire/wire.h).
//
//   application/x-lf-view-request, framerate = (fraction) N/D,
//                                  width = (int) W, height = (int) H
//   application/x-lf-fragment, encoding = (string) { raw, jpeg },
//                              framerate = (fraction) N/D,
//                              width = (int) W, height = (int) H
//
// `framerate` is the request rate of the viewer and W x H the size of its
// view (lfviewrequest sets them; lffragment copies them into its fragment
// caps; lfcompositor takes its output rate, its deadline and its frame size
// from them, never from what a fragment claims). They are optional in the pad
// templates, so streams from senders that do not set them are still accepted.
#pragma once

#include <gst/gst.h>

#include <initializer_list>

#define LF_FRAGMENT_CAPS "application/x-lf-fragment, encoding = (string) { raw, jpeg }"
#define LF_REQUEST_CAPS "application/x-lf-view-request"

namespace lfgst {

// The `framerate` field of `caps` when it is present and positive.
inline bool caps_framerate(const GstCaps* caps, gint* n, gint* d) {
  if (!caps || gst_caps_get_size(caps) < 1) return false;
  return gst_structure_get_fraction(gst_caps_get_structure(caps, 0), "framerate", n, d) && *n > 0 &&
         *d > 0;
}

// Copies framerate, width and height (those present) from `from` to `to`.
inline void copy_stream_facts(const GstCaps* from, GstCaps* to) {
  if (!from || gst_caps_get_size(from) < 1) return;
  const GstStructure* s = gst_caps_get_structure(from, 0);
  for (const char* f : {"framerate", "width", "height"})
    if (const GValue* v = gst_structure_get_value(s, f)) gst_caps_set_value(to, f, v);
}

}  // namespace lfgst
