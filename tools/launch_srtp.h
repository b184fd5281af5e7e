// lf-launch's SRTP (RFC 3711) handling: a key of its own for each start of
// a sender, and receivers that follow a restarted sender.
//
// Every host of a session is given one master key (net-host.sh SRTP_KEY,
// 30 bytes for AES-128-ICM + HMAC-SHA1-80). A sender that used it as is
// would, when restarted within the session, encrypt again under the same
// key, SSRC and packet indices (its rollover counter starts at 0 again), so
// an eavesdropper who recorded both runs could XOR the two payloads of one
// index (keystream reuse). So each srtpenc encrypts under a key of this
// start, srtp_start_key(master, mki), with a master key identifier (MKI,
// RFC 3711 3.1) drawn at start that every packet carries in the clear: 4
// random bytes and 4 bytes of HMAC-SHA256 over them under the master key,
// so a receiver tells an MKI of the session from a made-up one without
// decrypting anything (a made-up one passes once in 2^32). A receiver reads
// the MKIs of the packets that reach its srtpdec and answers srtpdec's
// "request-key" with the keys of the session's MKIs it heard last
// (srtp-key/mki, srtp-key2/mki2, ...). Without the master key no one can
// make an MKI or its key, so a forged packet never authenticates, and
// forged MKIs are not even followed.
#pragma once

#include <gst/gst.h>

#include <cstddef>
#include <cstdint>

// MKI length, bytes (carried by every SRTP and SRTCP packet): a random
// nonce and its tag, 4 bytes each.
constexpr size_t kSrtpMkiBytes = 8;

// A new MKI of the session (a random nonce, tagged). False: no randomness.
bool srtp_new_mki(const uint8_t* master, size_t master_len, uint8_t mki[kSrtpMkiBytes]);

// True if the MKI's tag is its nonce's under this master key.
bool srtp_mki_is_sessions(const uint8_t* master, size_t master_len,
                          const uint8_t mki[kSrtpMkiBytes]);

// The key of one sender's start: HKDF-Expand (RFC 5869 2.3) with
// HMAC-SHA256, the master key as PRK, info "lightfield-gst srtp start" ||
// mki; out_len bytes (at most 64: the master key's length, key + salt).
// False if out_len is out of range.
bool srtp_start_key(const uint8_t* master, size_t master_len, const uint8_t* mki, uint8_t* out,
                    size_t out_len);

// An srtpenc: its key property replaced by the key of a new MKI, and that
// MKI set (before the pipeline leaves NULL). An srtpenc without a key is
// left as it is.
void key_srtp_enc(GstElement* srtpenc);

// An srtpdec whose rtp_sink caps carry the master key ("srtp-key") and the
// stream's SSRC: answers request-key with the start keys of the session's
// MKIs heard (see above), and resets a stream when a packet carries a
// session MKI srtpdec was not given, or packets with session MKIs keep
// failing, while none has authenticated for 250 ms (a restarted sender: a
// new MKI, rollover counter 0).
void guard_srtp_dec(GstElement* srtpdec);
