// lf-launch's guard of plain RTP: on every udpsrc whose caps are RTP
// (application/x-rtp, not SRTP) and name the stream's SSRC ("ssrc", and
// "rtx-ssrc" for its retransmissions), each packet of that SSRC passes only
// if its sequence number and timestamp are the stream's: RFC 3550 appendix
// A.1's probation and window, with a jump taken only while the stream is
// young or quiet, and timestamps within a second of the stream's clock
// (lf::RtpSequenceGuard, lib/lf/wire/rtp_guard.h). A forged packet that
// carries the documented SSRC but not the live sequence number and
// timestamp is dropped before the jitter buffer and the depayloader, where
// it would have cost the packets around it. Drops are counted on stderr (a
// line a second at most). Authenticated streams (SRTP) need none of this.
#pragma once

#include <gst/gst.h>

void guard_plain_rtp(GstElement* pipeline);
