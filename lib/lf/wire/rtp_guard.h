// The sequence number and timestamp checks of an RTP stream received without
// authentication (plain RTP, net-host.sh INSECURE=1), so that a packet
// forged with the stream's SSRC, which is documented and fixed, cannot move
// the stream's sequence window or reach its depayloader unless it also
// carries the stream's live sequence number and timestamp.
//
// Sequence numbers follow RFC 3550 appendix A.1 ("RTP Data Header
// Validity Checks"): a new source is on probation until two packets in
// sequence arrive (MIN_SEQUENTIAL = 2); a packet up to max_dropout (3000)
// ahead of the highest sequence number seen, or up to max_misorder (100)
// behind it, belongs to the stream; anything else is a jump, which moves the
// window only when the next packet in sequence confirms it. Two additions,
// because an attacker's own packets are in sequence too (every packetiser
// numbers its packets consecutively), so A.1's confirmation alone would let
// two forged packets move the window, and the first packets of a stream
// need not be its sender's:
//  * packets outside the window (or in it with a timestamp that is not the
//    stream's) are followed as up to two candidate sequences, and one takes
//    the window only when it has been heard more than the window: in more
//    10 ms slots (`slot_us`), counts decaying with a time constant of 1 s
//    (`rate_window_us`), so a burst of packets counts once. A sender
//    restarted with a new random sequence number takes its window back
//    within about half a second, and so does a stream that started after
//    someone else's packets; forged packets in fewer slots a second than
//    the stream's (a stream of 10 packets a second has 10) never take it;
//  * every packet's timestamp (RTP clock units, `clock_rate` Hz) must be
//    plausible against the last one of its sequence: no more than
//    `timestamp_slack_s` behind it, and ahead of it by no more than the time
//    elapsed since plus that slack. A sender starts its timestamps at a
//    random offset (RFC 3550 5.1), so one who has not seen the stream lands
//    in that range about once in 2 * slack * rate / 2^32 (1 in 23,800 at
//    1 s and 90 kHz), and its sequence number in the window about once in
//    22. The slack covers reordering, retransmission and a reference packet
//    that came late; a sender whose timestamps run ahead of real time (not
//    live) needs a larger one.
// An attacker who sees the stream's packets, or who sends more packets a
// second than the stream, can still forge it; only authentication (SRTP,
// net-host.sh's default) stops that.
//
// Plain C++, no GStreamer. Times are microseconds of a monotonic clock. Not
// thread-safe: one thread uses each guard (a receiver's streaming thread).
#pragma once

#include <cmath>
#include <cstdint>

namespace lf {

class RtpSequenceGuard {
 public:
  struct Limits {
    int max_dropout = 3000;            // RFC 3550 A.1 MAX_DROPOUT (packets ahead)
    int max_misorder = 100;            // RFC 3550 A.1 MAX_MISORDER (packets behind)
    int min_sequential = 2;            // RFC 3550 A.1 MIN_SEQUENTIAL
    int64_t rate_window_us = 1000000;  // decay time constant of the counts
    int64_t slot_us = 10000;           // packets within a slot count once
    double timestamp_slack_s = 1;
  };
  enum class Verdict {
    accept,     // the stream's packet: pass it on
    probation,  // a new source not yet confirmed (RFC 3550 A.1)
    jump,       // outside the window, and its sequence not taken (yet)
    timestamp,  // in the window, but its timestamp is not the stream's (and
                // its sequence not taken, yet)
  };

  // clock_rate: the stream's RTP clock rate in Hz (0: 90000, the rate of
  // video and of rtpgstpay).
  RtpSequenceGuard(uint32_t clock_rate, Limits limits)
      : rate_(clock_rate ? clock_rate : 90000), lim_(limits) {}
  explicit RtpSequenceGuard(uint32_t clock_rate) : RtpSequenceGuard(clock_rate, Limits()) {}

  Verdict check(uint16_t seq, uint32_t ts, int64_t now_us) {
    bool in_window = false;
    if (started_) {
      const uint16_t udelta = static_cast<uint16_t>(seq - win_.seq);
      in_window = udelta < lim_.max_dropout || udelta >= 65536 - lim_.max_misorder;
      if (in_window && plausible(ts, win_, now_us)) {
        const bool ahead = udelta != 0 && udelta < lim_.max_dropout;
        add(win_, ahead ? seq : win_.seq, ahead ? ts : win_.ts, now_us);
        return Verdict::accept;
      }
    }
    // Not the window's (its sequence number, or in it but not its
    // timestamp): the candidate sequence it continues, or a new one in
    // place of the one with fewer packets.
    Sequence* c = nullptr;
    for (Sequence& k : cand_)
      if (k.run > 0 && continues(k, seq, ts, now_us)) c = &k;
    if (c) {
      c->run = static_cast<uint16_t>(seq - c->seq) == 1 ? c->run + 1 : 1;
    } else {
      c = count(cand_[0], now_us) <= count(cand_[1], now_us) ? &cand_[0] : &cand_[1];
      *c = Sequence();
      c->run = 1;
    }
    add(*c, seq, ts, now_us);
    if (c->run >= lim_.min_sequential) c->confirmed = true;
    const Verdict refused = !started_   ? Verdict::probation
                            : in_window ? Verdict::timestamp
                                        : Verdict::jump;
    if (!c->confirmed) return refused;
    if (started_ && count(*c, now_us) <= count(win_, now_us)) return refused;
    if (started_) ++restarts_;
    started_ = true;
    win_ = *c;
    *c = Sequence();
    return Verdict::accept;
  }

  // How many times another sequence took the window (a sender restarted).
  int restarts() const { return restarts_; }

 private:
  // A sequence of packets: its highest sequence number and that packet's
  // timestamp and arrival, and its packet count decaying with time.
  struct Sequence {
    uint16_t seq = 0;
    uint32_t ts = 0;
    int64_t us = 0;
    double count = 0;  // at `us`: slots with packets, decayed
    int64_t slot_start_us = -1;
    int run = 0;             // packets in sequence (each the previous + 1) so far
    bool confirmed = false;  // `run` has reached min_sequential (RFC 3550 A.1)
  };
  // `k`'s count decayed to `now_us`.
  double count(const Sequence& k, int64_t now_us) const {
    if (k.count <= 0) return 0;
    return k.count *
           std::exp(-static_cast<double>(now_us - k.us) / static_cast<double>(lim_.rate_window_us));
  }
  // A packet of `k`: its newest (`s`, `t`), and one more slot heard.
  void add(Sequence& k, uint16_t s, uint32_t t, int64_t now_us) const {
    const bool new_slot = k.slot_start_us < 0 || now_us - k.slot_start_us >= lim_.slot_us;
    k.count = count(k, now_us) + (new_slot ? 1 : 0);
    if (new_slot) k.slot_start_us = now_us;
    k.seq = s;
    k.ts = t;
    k.us = now_us;
  }
  // Whether `ts` may follow the last packet of `k`, `now_us`.
  bool plausible(uint32_t ts, const Sequence& k, int64_t now_us) const {
    const int64_t d = static_cast<int32_t>(ts - k.ts);
    const double slack = lim_.timestamp_slack_s * rate_;
    const int64_t elapsed = now_us > k.us ? now_us - k.us : 0;
    const double ahead = static_cast<double>(elapsed) / 1e6 * rate_;
    return static_cast<double>(d) >= -slack && static_cast<double>(d) <= ahead + slack;
  }
  // Whether a packet outside the window belongs to candidate `k`: ahead of
  // it within the dropout limit, with a plausible timestamp.
  bool continues(const Sequence& k, uint16_t seq, uint32_t ts, int64_t now_us) const {
    const uint16_t udelta = static_cast<uint16_t>(seq - k.seq);
    return udelta != 0 && udelta < lim_.max_dropout && plausible(ts, k, now_us);
  }

  uint32_t rate_;
  Limits lim_;
  bool started_ = false;
  Sequence win_;
  Sequence cand_[2];
  int restarts_ = 0;
};

}  // namespace lf
