// A camera host's recording and playback branches (lfcamerahost record
// and playback): GStreamer's own elements, one Matroska file per camera.
#pragma once

#include <gst/gst.h>

#include <functional>
#include <string>
#include <vector>

#include "lf/geometry/camera.h"

namespace lfgst {

// Adds an element made for the bin to it (and to what the bin tears down).
using Adopt = std::function<GstElement*(GstElement*)>;

// Links a to b; throws std::runtime_error naming `what` where it cannot.
void link_or_throw(GstElement* a, GstElement* b, const std::string& what);

// Playback of one camera's recording: filesrc ! decodebin ! videoconvert !
// RGBA at the camera's size ! clocksync, so frames come on their recorded
// capture schedule (PTS = capture time). The decoder and the file source
// are locked in their state and put in `deferred`, for the bin to start
// once the rest of the graph is PAUSED. Returns the last element.
GstElement* add_playback(const Adopt& adopt, std::vector<GstElement*>& deferred,
                         const std::string& file, const lf::Camera& cam, const std::string& id);

// Recording of one camera: its frames split off to videoconvert ! RGB !
// (jpegenc quality=Q when Q > 0) ! matroskamux (nanosecond timecodes, so
// the capture times are kept exactly) ! filesink. Returns the tee whose
// other branch feeds the fragment.
GstElement* add_recorder(const Adopt& adopt, GstElement* cam, const std::string& file, gint quality,
                         const std::string& id);

}  // namespace lfgst
