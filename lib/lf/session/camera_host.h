// The camera host's answer to a view request (Yang et al. 2002, Section
// 4.1, the random access camera: a camera warps only the part of its image
// that the requested view needs): request -> plans -> fragments on the
// wire (lib/lf/wire/wire.h).
//
// Plain C++, no GStreamer: lffragment is the glue (the camera's frames,
// threads, buffers, limits). Output pixels, rig units and the wire format
// as in lib/lf/render/plan.h and lib/lf/wire/wire.h.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"
#include "lf/render/fragment.h"
#include "lf/render/plan.h"
#include "lf/render/renderer.h"

namespace lf {

// The request's geometry for camera `index` of `rig`, shared between the
// cameras of one process that answer the same request (`key`: the
// request's bytes; empty: not shared). Through one focal plane or a focal
// surface (per-tile planes) the whole rig's geometry (every camera's
// homographies, the surface's tiling) is made once, by the first camera to
// ask, and the others wait for it (64 cameras each making their own cost
// 63 times the shared part: the request's checks, the facets at the eye,
// the tiling); with the ULR aperture the camera's own, with the blending
// field shared (it depends on the whole rig). The last
// 16 requests are kept; keys over kMaxSharedKeyBytes (a 1920x1080
// request with second planes in every 16-pixel tile: 16.5 KB; 3840x2160:
// 65 KB) are not shared. Thread-safe.
constexpr size_t kMaxSharedKeyBytes = 32768;
std::shared_ptr<const ViewGeometry> shared_geometry(const std::shared_ptr<const Rig>& rig,
                                                    const ViewRequest& req, int index,
                                                    const std::string& key);
// The requests of a request buffer (lf::parse_requests: one, or a probe
// bundle's steps), each with its bytes as its shared_geometry key (empty
// over kMaxSharedKeyBytes). Throws WireError as parse_requests does.
using KeyedRequests = std::vector<std::pair<ViewRequest, std::string>>;
KeyedRequests parse_keyed_requests(const uint8_t* data, size_t size);
// parse_keyed_requests shared by the process's cameras, which are sent the
// same request buffer (lfarray's tee): the first parses, the others take
// its requests. Keyed by the buffer's bytes; the last 16 buffers up to
// kMaxSharedKeyBytes are kept (larger ones are parsed alone). Thread-safe;
// throws as parse_keyed_requests does, every time for the same bytes.
std::shared_ptr<const KeyedRequests> shared_keyed_requests(const uint8_t* data, size_t size);
// Camera `camera_id`'s explicitly empty fragment for `req` (wire kEmpty):
// an answer without pixels (capture_time_ns -1: none), so that the
// compositor knows the camera answered.
std::vector<uint8_t> empty_answer(const ViewRequest& req, int camera_id,
                                  int64_t capture_time_ns = -1);

// What camera `index` answers to `req`: one fragment; its layer-0 and
// layer-1 fragments for a focal surface with second planes (back to back
// in one buffer); or for a quilt request (lib/lf/render/quilt.h) its
// fragment of each eye it sees, each moved into the eye's tile of the
// quilt frame.
class CameraAnswer {
 public:
  // `geometry`: the request's (shared_geometry), or null to make the
  // camera's own; a quilt's eyes are each planned with their own.
  CameraAnswer(const Rig& rig, const ViewRequest& req, int index,
               std::shared_ptr<const ViewGeometry> geometry = nullptr);
  // Whether the camera sees none of the view (a quilt: none of its eyes).
  bool sees_nothing() const { return plans_.empty() || (plans_.size() == 1 && plans_[0].empty()); }
  size_t count() const { return plans_.size(); }
  const FragmentPlan& plan(size_t k) const { return plans_.at(k); }
  FragmentPlan take_plan(size_t k) { return std::move(plans_.at(k)); }
  bool quilt() const { return quilt_; }
  // Output pixels drawn in all.
  size_t pixel_count() const;
  // Fragment k's header: `base`'s viewer, sequence and capture time, this
  // camera's id, the output size, rect and spans (in the quilt frame for a
  // quilt), no pixels.
  Fragment header(size_t k, const Fragment& base, int camera_id) const;

  // Every fragment's header (header(k) for each k), made once per answer.
  std::vector<Fragment> headers(const Fragment& base, int camera_id) const;
  // Raw: the bytes of the fragments with `heads` (headers()) in
  // write_raw_fragment's layout, and those bytes written at `out` (exactly
  // raw_size() of them: std::invalid_argument otherwise), each fragment's
  // pixels drawn by `renderer` from the image in `slot` and sealed
  // (lib/lf/wire/wire.h seal_fragment).
  static size_t raw_size(const std::vector<Fragment>& heads);
  void write_raw(const std::vector<Fragment>& heads, const Camera& camera, Renderer& renderer,
                 int slot, uint8_t* out, size_t size) const;
  // JPEG: every fragment encoded (serialize_jpeg_fragment), each drawn
  // straight into the rectangle the encoder takes (`scratch`, kept by the
  // caller from answer to answer: no allocation per fragment).
  std::vector<uint8_t> encode_jpeg(const Fragment& base, const Camera& camera, Renderer& renderer,
                                   int slot, int quality, std::vector<uint8_t>& scratch) const;

 private:
  std::vector<FragmentPlan> plans_;
  bool quilt_ = false;
  std::vector<cv::Point> tile_of_;  // a quilt's: each plan's tile origin
  int width_ = 0, height_ = 0;      // the output (the quilt frame for a quilt)
};

}  // namespace lf
