// LfFragmentAggregator: the base of the collection's adding elements
// (lfcompositor, lfpartialsum), as GstVideoAggregator is stock
// compositor's. It owns what both do alike:
//  * taking fragments from the sink pads: not live, one buffer per pad per
//    aggregate() (a pop unblocks the upstream push, so popping in a loop
//    would race ahead on fast pads); live, up to live_batch() per pad (the
//    viewer's clock paces the pads);
//  * at the oldest request's deadline (its running time plus the latency:
//    a silent pad, a dead host), every queued fragment of the requests up
//    to the one due, so the live pads' fragments all make it in;
//  * when aggregate() runs next (live): at once when a pad holds a fragment
//    (one pad may carry many cameras' fragments), else at the earliest
//    deadline;
//  * events from downstream: seeks refused (live light field streams are
//    not seekable); navigation and lf-view events go up every sink pad, to
//    the cameras and on to lfviewrequest (GstAggregator would drop
//    navigation).
// A subclass files what it takes (absorb) and emits what is due (emit_due),
// with its own pending requests (lib/lf/session/frame_assembly.h).
#pragma once

#include <gst/base/gstaggregator.h>

#include "lf/session/frame_assembly.h"

G_BEGIN_DECLS

#define LF_TYPE_FRAGMENT_AGGREGATOR (lf_fragment_aggregator_get_type())
G_DECLARE_DERIVABLE_TYPE(LfFragmentAggregator, lf_fragment_aggregator, LF, FRAGMENT_AGGREGATOR,
                         GstAggregator)

// When this aggregate() runs: on a timeout (GstAggregator's, or data on a
// pad in live pipelines) `now` is the running time; `latency` is the
// aggregator's (live only).
typedef struct {
  gboolean timeout, live;
  GstClockTime now, latency;
} LfDeadline;

// A live adding element frees what it holds this long after its last output
// when nothing comes (a viewer gone quiet: a flood's 4K frames).
#define LF_IDLE_RELEASE (2 * GST_SECOND)

// Whether a request of `running_time` is due: on a timeout, past its
// deadline (running time + latency), or not live, or without times.
gboolean lf_deadline_passed(const LfDeadline* d, GstClockTime running_time);

struct _LfFragmentAggregatorClass {
  GstAggregatorClass parent_class;
  // Optional: called at the start of every aggregate(), before a fragment
  // is taken (settings that may change while playing apply from there on).
  void (*begin)(LfFragmentAggregator* self);
  // Files one fragment buffer (borrowed) taken from `pad`: each part of a
  // bundle (gst/lfbundle.h) on its own. A flow other than GST_FLOW_OK ends
  // the aggregate() with it.
  GstFlowReturn (*absorb)(LfFragmentAggregator* self, GstAggregatorPad* pad, GstBuffer* buf);
  // Buffers taken from each pad per aggregate() when live (at least 1).
  gsize (*live_batch)(LfFragmentAggregator* self);
  // The requests waiting (its lf::PendingRequests), null before start.
  // Called on the aggregate thread, and with the source lock held (when to
  // run next).
  const lf::RequestTimes* (*requests)(LfFragmentAggregator* self);
  // Emits the requests that are due (lfgst::emit_due); GST_FLOW_EOS when
  // `all_eos` and nothing waits.
  GstFlowReturn (*emit_due)(LfFragmentAggregator* self, const LfDeadline* d, gboolean all_eos);
  // Optional: memory the subclass frees once idle (lfcompositor's frames).
  // With `release` FALSE: whether it holds any; TRUE: free it. Called when
  // no request waits, at the end of the stream or, live, LF_IDLE_RELEASE
  // after the last output (aggregate() is woken then for it).
  gboolean (*release_idle)(LfFragmentAggregator* self, gboolean release);
  // Optional: a navigation or lf-view event (transfer full) before it goes
  // up the sink pads; returns the event to send (transfer full).
  GstEvent* (*tag_upstream)(LfFragmentAggregator* self, GstEvent* event);
};

// Sends `event` (transfer full) up every sink pad; TRUE if any took it.
gboolean lf_fragment_aggregator_push_upstream(LfFragmentAggregator* self, GstEvent* event);

G_END_DECLS
