#!/usr/bin/python3
"""A WHEP player (RFC 9725) written with GStreamer's webrtcbin and urllib,
knowing nothing of lf-web's own signalling: it POSTs an SDP offer (a
receive-only VP8 video m-line and a data channel), takes the 201's answer
and Location, plays the view, steers it over the data channel with the
page's control protocol (docs/web.md), and DELETEs the session.

usage: whep-client.py URL [--frames N] [--token T] [--timeout S]
Prints one JSON line of what it measured; exit status 0 when every check
held, 1 otherwise (the failed checks are named)."""
import argparse
import json
import sys
import threading
import time
import urllib.error
import urllib.request

import gi

gi.require_version("Gst", "1.0")
gi.require_version("GstSdp", "1.0")
gi.require_version("GstWebRTC", "1.0")
from gi.repository import GLib, Gst, GstSdp, GstWebRTC  # noqa: E402


def http(method, url, body=None, ctype=None, token=None):
    req = urllib.request.Request(url, data=body, method=method)
    if ctype:
        req.add_header("Content-Type", ctype)
    if token:
        req.add_header("Authorization", "Bearer " + token)
    try:
        with urllib.request.urlopen(req, timeout=20) as r:
            return r.status, dict(r.headers), r.read().decode()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read().decode()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("url")
    ap.add_argument("--frames", type=int, default=15)
    ap.add_argument("--token")
    ap.add_argument("--timeout", type=float, default=30)
    a = ap.parse_args()
    Gst.init(None)
    failed, out = [], {}

    def check(ok, what):
        if not ok:
            failed.append(what)

    base = a.url.split("/whep")[0]
    # Refusals first: a wrong type, no SDP, an unknown view, trickle ICE.
    out["wrong_type"] = http("POST", a.url, b"v=0", "text/plain", a.token)[0]
    check(out["wrong_type"] == 415, "text/plain offer gets 415")
    out["not_sdp"] = http("POST", a.url, b"hello", "application/sdp", a.token)[0]
    check(out["not_sdp"] == 400, "a body that is no SDP gets 400")
    out["unknown_view"] = http("POST", base + "/whep/nowhere", b"v=0", "application/sdp",
                               a.token)[0]
    check(out["unknown_view"] == 404, "an unknown view gets 404")

    pipe = Gst.Pipeline.new("player")
    w = Gst.ElementFactory.make("webrtcbin", "w")
    w.set_property("bundle-policy", GstWebRTC.WebRTCBundlePolicy.MAX_BUNDLE)
    pipe.add(w)
    frames = {"n": 0, "size": None, "first": None}
    t0 = time.monotonic()

    def on_decoded(pad, info):
        frames["n"] += 1
        if frames["first"] is None:
            frames["first"] = time.monotonic() - t0
            s = pad.get_current_caps().get_structure(0)
            frames["size"] = (s.get_value("width"), s.get_value("height"))
        return Gst.PadProbeReturn.OK

    def on_pad(_, pad):
        if pad.direction != Gst.PadDirection.SRC:
            return
        tail = Gst.parse_bin_from_description(
            "rtpvp8depay ! vp8dec ! videoconvert ! fakesink name=sink sync=false", True)
        pipe.add(tail)
        tail.sync_state_with_parent()
        pad.link(tail.get_static_pad("sink"))
        tail.get_by_name("sink").get_static_pad("sink").add_probe(Gst.PadProbeType.BUFFER,
                                                                  on_decoded)

    w.connect("pad-added", on_pad)
    caps = Gst.Caps.from_string(
        "application/x-rtp,media=video,encoding-name=VP8,payload=96,clock-rate=90000")
    w.emit("add-transceiver", GstWebRTC.WebRTCRTPTransceiverDirection.RECVONLY, caps)
    pipe.set_state(Gst.State.READY)
    channel = w.emit("create-data-channel", "control", None)
    stats = []
    opened = threading.Event()
    channel.connect("on-open", lambda ch: opened.set())
    channel.connect("on-message-string", lambda ch, m: stats.append(json.loads(m)))
    pipe.set_state(Gst.State.PLAYING)

    # The offer, with every candidate (no trickle), then the POST.
    done = threading.Event()
    w.connect("notify::ice-gathering-state",
              lambda e, _: done.set() if e.get_property("ice-gathering-state") ==
              GstWebRTC.WebRTCICEGatheringState.COMPLETE else None)
    promise = Gst.Promise.new()
    w.emit("create-offer", None, promise)
    promise.wait()
    reply = promise.get_reply()  # kept: the offer lives in it
    offer = reply.get_value("offer")
    w.emit("set-local-description", offer, None)
    done.wait(10)
    sdp = w.get_property("local-description").sdp.as_text()
    status, headers, answer = http("POST", a.url, sdp.encode(), "application/sdp", a.token)
    out["post"] = status
    check(status == 201, "the offer gets 201 Created")
    location = headers.get("Location") or headers.get("location") or ""
    out["location"] = location
    check(location.startswith("/whep/resource/"), "a Location for the session")
    check((headers.get("Content-Type") or headers.get("content-type") or "").startswith(
        "application/sdp"), "the answer is application/sdp")
    if status == 201:
        ok, msg = GstSdp.SDPMessage.new_from_text(answer)
        remote = GstWebRTC.WebRTCSessionDescription.new(GstWebRTC.WebRTCSDPType.ANSWER, msg)
        w.emit("set-remote-description", remote, None)
        out["patch"] = http("PATCH", base + location, b"", "application/trickle-ice-sdpfrag",
                            a.token)[0]
        check(out["patch"] == 405, "no trickle ICE: PATCH gets 405")
        # Play until enough frames are decoded, steer, and read the stats back.
        ctx = GLib.MainContext.default()
        deadline = time.monotonic() + a.timeout
        while frames["n"] < a.frames and time.monotonic() < deadline:
            ctx.iteration(False)
            time.sleep(0.01)
        out["frames"] = frames["n"]
        out["first_frame_s"] = frames["first"]
        out["size"] = frames["size"]
        check(frames["n"] >= a.frames, f"{a.frames} frames decoded within {a.timeout} s")
        steered = None
        if opened.wait(5):
            channel.emit("send-string", json.dumps({"type": "set", "eye-s": 0.125}))
            until = time.monotonic() + 10
            while time.monotonic() < until and steered is None:
                for m in list(stats):
                    if m.get("type") == "stats" and abs(m["eye"][0] - 0.125) < 1e-9:
                        steered = m
                time.sleep(0.05)
        out["stats_messages"] = len(stats)
        out["steered"] = steered is not None
        check(steered is not None, "a 'set' over the data channel moves the eye (stats say so)")
        out["delete"] = http("DELETE", base + location, token=a.token)[0]
        check(out["delete"] == 200, "DELETE ends the session with 200")
        out["delete_again"] = http("DELETE", base + location, token=a.token)[0]
        check(out["delete_again"] == 404, "a second DELETE gets 404")
    pipe.set_state(Gst.State.NULL)
    out["failed"] = failed
    print(json.dumps(out))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
