// lfcamsrc's file and V4L2 inputs: an internal pipeline of GStreamer's own
// elements (uridecodebin for a file or URI, multifilesrc ! decodebin for an
// image sequence, v4l2src for a device) ! videoconvert ! videoscale !
// appsink, RGBA at the camera's size. Elements are made and their
// properties set directly: user strings (location, device) are never
// spliced into a pipeline description. Every video decoder inside gets
// max-errors 0 (the first frame it cannot decode is an error) or, with
// skip_bad_frames, no limit, and the frames it skipped are kept as warnings
// for the element to post. Used on the element's streaming thread; the
// warnings arrive on the decoders' threads.
#pragma once

#include <gst/gst.h>

#include <mutex>
#include <string>
#include <vector>

namespace lfgst {

class DecodedInput {
 public:
  struct Options {
    bool v4l2 = false;  // `device`; else `location` (a file, a URI or a %d sequence)
    std::string location, device;
    bool loop = false;  // a sequence starts again at its end
    bool skip_bad_frames = false;
    int width = 0, height = 0;  // the camera's image size (frames are scaled to it)
  };
  // Builds and starts the pipeline. Throws std::runtime_error naming the
  // input and the reason (a missing file, a busy device, an undecodable
  // stream), std::invalid_argument for a location that is no file or URI.
  explicit DecodedInput(const Options& o);
  ~DecodedInput();
  DecodedInput(const DecodedInput&) = delete;
  DecodedInput& operator=(const DecodedInput&) = delete;

  // The next decoded frame, waiting at most `timeout` in 50 ms slices;
  // null at the end of the input, at the timeout, or when the pipeline
  // posted an error (then in *error).
  GstSample* pull(GstClockTime timeout, std::string* error);
  // V4L2: the newest frame already decoded (dropping older ones), or null.
  GstSample* newest();
  bool at_end() const;
  // Back to the start of a file (loop); false if it cannot seek.
  bool rewind();
  // The frames the decoders skipped since the last call (skip_bad_frames).
  std::vector<std::string> take_skipped();

  // lfcamsrc's next frame: V4L2, the newest one decoded (waiting up to 5 s
  // when there is none yet and `have_one` is false); a file, the next one
  // (waiting up to 30 s; at its end the first again with `loop`).
  struct Next {
    GstSample* sample = nullptr;       // owned by the caller; null: none
    bool end = false;                  // the input ended
    std::string error;                 // the pipeline's error, when it posted one
    std::vector<std::string> skipped;  // take_skipped()
  };
  Next next(bool have_one);

 private:
  static GstBusSyncReply on_message(GstBus*, GstMessage* m, gpointer self);
  void teardown();
  // The first error the pipeline posted ("" if none), waiting up to `wait`.
  std::string error(GstClockTime wait = 0);
  Options o_;
  GstElement* pipe_ = nullptr;
  GstElement* sink_ = nullptr;
  std::mutex lock_;
  std::vector<std::string> skipped_;  // under lock_
};

}  // namespace lfgst
