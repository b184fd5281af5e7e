// lf-launch's guard of plain RTP, on a udpsrc's src pad: when its caps are
// RTP (application/x-rtp, not SRTP) and name the stream's SSRC ("ssrc", and
// "rtx-ssrc" for its retransmissions), each packet of that SSRC passes only
// if its sequence number and timestamp are the stream's: RFC 3550 appendix
// A.1's probation and window, a jump taken only by a sequence heard in more
// 10 ms slots than the stream's, and timestamps within a second of the
// stream's clock (lf::RtpSequenceGuard, lib/lf/wire/rtp_guard.h). A forged
// packet that carries the documented SSRC but not the live sequence number
// and timestamp is dropped before the jitter buffer and the depayloader,
// where it would have cost the packets around it. When a sequence takes
// the window (a stream's start, or a restarted sender taking it from forged
// packets that came first), its packets refused before it did go on first
// (the last 128 refused are kept: a sender's first packet carries its
// in-band caps). Drops are counted on stderr (a line a second at most).
// Authenticated streams (SRTP) need none of this.
#pragma once

#include <gst/gst.h>

// Adds the guard's probe to a udpsrc's src pad (caps of another kind, or
// without an SSRC, pass untouched).
void guard_plain_rtp(GstPad* udpsrc_src);
