// The capture meta that lfcamsrc puts on camera frames, the sealed meta
// that lffragment puts on the fragments it serialises, and the deferred
// drawing that it puts on fragments whose pixels it leaves to lfcompositor.
#pragma once

#include <gst/gst.h>
#include <gst/video/video.h>

#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "lf/geometry/camera.h"
#include "lf/render/plan.h"
#include "lf/render/renderer.h"

namespace lfgst {

// Capture meta on camera frames (lfcamsrc): a GstCustomMeta "LfCaptureMeta"
// with fields camera-id (int) and capture-time (guint64, running time in ns).
// In-process only (metas do not cross the network; fragments carry the same
// in their header).
void add_capture_meta(GstBuffer* buf, int camera_id, guint64 capture_time);
bool read_capture_meta(GstBuffer* buf, int* camera_id, guint64* capture_time);
// A camera frame's capture time (ns): its capture meta's, else its PTS, else
// -1. A meta naming another camera than `camera_id` is logged on `warn_on`.
int64_t capture_time_of(GstBuffer* frame, int camera_id, GstObject* warn_on);

// A meta of this process only: registered once, with no tags and no
// transform, so that every copy of a buffer drops it.
struct LocalMeta {
  const char* api_name;
  const char* name;
  gsize size;
  GstMetaInitFunction init;
  GstMetaFreeFunction free;
  GType api = 0;
  const GstMetaInfo* info = nullptr;
  gsize once = 0;
  const GstMetaInfo* registered() {
    if (g_once_init_enter(&once)) {
      static const gchar* tags[] = {nullptr};
      api = gst_meta_api_type_register(api_name, tags);
      info = gst_meta_register(api, name, size, init, free, nullptr);
      g_once_init_leave(&once, 1);
    }
    return info;
  }
};

// Sealed meta (LfSealedMeta): on a fragment buffer that lffragment
// serialised and sealed (CRC written) in this process. Never copied with a
// buffer (no transform), so only that buffer object carries it, and nothing
// from the network can: lfcompositor skips the CRC check of such a buffer,
// the bytes never having left the process (every other check still runs).
void add_sealed_meta(GstBuffer* buf);
bool has_sealed_meta(GstBuffer* buf);

// A fragment's drawing left to the compositor (lffragment `defer`,
// lfarray's whole-view mode: lf::DeferredDrawing). On an
// empty fragment buffer (lib/lf/wire/wire.h kEmpty) as LfDeferredMeta, which,
// like LfSealedMeta, no copy of the buffer carries: only buffers that stay
// in this process have it, and anywhere else the fragment is just empty.
struct DeferredDraw : lf::DeferredDrawing {
  // `image` is the frame itself, mapped in `frame` while this lives, or its
  // colour-corrected copy.
  GstVideoFrame frame{};  // holds a reference to the frame buffer while mapped
  bool mapped = false;
  // A layer pair (a focal surface with second planes): the layer-1
  // drawing, of the same image (its plan empty otherwise).
  lf::DeferredDrawing layer1;
  DeferredDraw() = default;
  DeferredDraw(const DeferredDraw&) = delete;
  DeferredDraw& operator=(const DeferredDraw&) = delete;
  ~DeferredDraw() {
    if (mapped) gst_video_frame_unmap(&frame);
  }
};
// The drawing of `plan` (camera `cam`, renderer slot `slot`) from camera
// frame `frame` (`info`): `image` when it is a copy (colour-corrected,
// shared), else (empty) the frame itself, mapped while the drawing lives;
// `layer1`, when not empty, a layer pair's layer-1 plan, drawn from the
// same image. Throws std::runtime_error when the frame cannot be mapped.
std::shared_ptr<DeferredDraw> deferred_draw(GstBuffer* frame, const GstVideoInfo& info,
                                            const cv::Mat& image, const lf::Camera& cam, int slot,
                                            lf::FragmentPlan plan, lf::FragmentPlan layer1 = {});
void add_deferred_meta(GstBuffer* buf, std::shared_ptr<const DeferredDraw> draw);
// The drawing on `buf`, or null.
std::shared_ptr<const DeferredDraw> deferred_of(GstBuffer* buf);
// The drawings on `buf` when it carries one for camera `camera_id` and a
// `width` x `height` view (only an empty fragment this process made: the
// meta is never copied): its plan's, then a layer pair's layer 1; else none.
std::vector<std::shared_ptr<const lf::DeferredDrawing>> deferred_drawings(GstBuffer* buf,
                                                                          int camera_id, int width,
                                                                          int height);

}  // namespace lfgst
