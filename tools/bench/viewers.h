// lf-gst-bench's several-viewers run: V viewers sharing one camera host.
#pragma once

#include <gst/gst.h>

#include <cstddef>
#include <string>
#include <utility>

namespace lfbench {

// V viewers sharing the cameras (lfcamerahost: one fragment stream, routed
// by lffragmentdemux to each viewer's lfcompositor, or with `tee` to every
// one), non-live: viewer v's requests orbit with a phase of its own. `fr`:
// the fragments' properties ("encoding=...").
std::string viewers_pipeline(const std::string& rig, int W, int H, const std::string& fr,
                             int viewers, int frames, bool tee);

// Runs V appsinks out0..out{V-1} to EOS; returns (frames, seconds) of the
// steady part (after each sink's first frame). Throws std::runtime_error on
// a pipeline that does not parse or posts an error.
std::pair<size_t, double> run_viewers(const std::string& desc, int viewers);

}  // namespace lfbench
