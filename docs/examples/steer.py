#!/usr/bin/python3
"""steer.py: embeds the lightfield plugin from Python (PyGObject, Debian's
python3-gst-1.0) and steers the virtual camera while the pipeline plays, as
steer.c does: a property change, the lf-view upstream event (written by
lfviewrequest's view-event action, which refuses a bad field), a GstController
camera move. Prints one line per step and exits 0 after FRAMES frames.

usage: steer.py RIG.json [MODE] [FRAMES]   (MODE: lfcamsrc mode, default dataset)
"""
import sys

import gi

gi.require_version("Gst", "1.0")
gi.require_version("GstController", "1.0")
from gi.repository import Gst, GstController  # noqa: E402


def main():
    Gst.init(None)
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    rig = sys.argv[1]
    mode = sys.argv[2] if len(sys.argv) > 2 else "dataset"
    frames = int(sys.argv[3]) if len(sys.argv) > 3 else 60
    pipe = Gst.parse_launch(
        f"lfviewrequest name=view rig={rig} is-live=true framerate=30/1 width=160 height=120 ! "
        f"lfarray rig={rig} mode={mode} is-live=true framerate=30/1 ! "
        "appsink name=out sync=false max-buffers=4 drop=true")
    view = pipe.get_by_name("view")
    sink = pipe.get_by_name("out")
    pipe.set_state(Gst.State.PLAYING)
    move = None
    for got in range(1, frames + 1):
        sample = sink.emit("try-pull-sample", 5 * Gst.SECOND)
        if sample is None:
            print("steer.py: no frame for 5 s", file=sys.stderr)
            return 1
        pts = sample.get_buffer().pts
        if got == 10:  # a property, while playing
            view.set_property("eye-s", 0.01)
            print("eye-s", view.get_property("eye-s"))
        elif got == 20:  # a whole view at once, sent at the sink
            # The fields, made into a checked, versioned lf-view event by
            # lfviewrequest's view-event action (the collection's codec).
            event = view.emit("view-event", Gst.Structure.new_from_string(
                "lf-view, position=<0.0, 0.0, 0.0>, focal-depth=2.5"))
            if event is None:
                print("steer.py: the view was refused", file=sys.stderr)
                return 1
            sink.send_event(event)
            print("focal-depth", view.get_property("focal-depth"))
            # A bad field (misspelt) is refused: no event.
            if view.emit("view-event", Gst.Structure.new_from_string("lf-view, focal-dept=2.0")) is None:
                print("refused focal-dept")
        elif got == 30:  # a camera move: eye-t from 0 to 0.02 over 1 s
            move = GstController.InterpolationControlSource.new()
            move.set_property("mode", GstController.InterpolationMode.LINEAR)
            move.set(pts, 0.0)
            move.set(pts + Gst.SECOND, 0.02)
            view.add_control_binding(
                GstController.DirectControlBinding.new_absolute(view, "eye-t", move))
        elif got > 30:
            print(f"eye-t {pts / Gst.SECOND:.3f} {view.get_property('eye-t')}")
    pipe.set_state(Gst.State.NULL)
    print("frames", frames)
    return 0


if __name__ == "__main__":
    sys.exit(main())
