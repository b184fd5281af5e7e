// Caps of the collection's in-band formats (byte layouts: lib/lf/wire.h).
//
//   application/x-lf-view-request, framerate = (fraction) N/D
//   application/x-lf-fragment, encoding = (string) { raw, jpeg },
//                              framerate = (fraction) N/D
//
// `framerate` is the request rate of the viewer (lfviewrequest sets it;
// lffragment copies it into its fragment caps; lfcompositor derives its output
// rate and its deadline from it). It is optional in the pad templates, so
// streams from senders that do not set it are still accepted.
#pragma once

#include <gst/gst.h>

#define LF_FRAGMENT_CAPS "application/x-lf-fragment, encoding = (string) { raw, jpeg }"
#define LF_REQUEST_CAPS "application/x-lf-view-request"

namespace lfgst {

// The `framerate` field of `caps` when it is present and positive.
inline bool caps_framerate(const GstCaps* caps, gint* n, gint* d) {
  if (!caps || gst_caps_get_size(caps) < 1) return false;
  return gst_structure_get_fraction(gst_caps_get_structure(caps, 0), "framerate", n, d) && *n > 0 &&
         *d > 0;
}

}  // namespace lfgst
