#include "lfmeta.h"

#include <stdexcept>

namespace lfgst {

static const GstMetaInfo* capture_meta_info() {
  static const GstMetaInfo* info = nullptr;
  static gsize once = 0;
  if (g_once_init_enter(&once)) {
    static const gchar* tags[] = {nullptr};
    info = gst_meta_register_custom("LfCaptureMeta", tags, nullptr, nullptr, nullptr);
    g_once_init_leave(&once, 1);
  }
  return info;
}

void add_capture_meta(GstBuffer* buf, int camera_id, guint64 capture_time) {
  capture_meta_info();
  GstCustomMeta* m = gst_buffer_add_custom_meta(buf, "LfCaptureMeta");
  if (!m) return;
  gst_structure_set(gst_custom_meta_get_structure(m), "camera-id", G_TYPE_INT, camera_id,
                    "capture-time", G_TYPE_UINT64, capture_time, nullptr);
}

bool read_capture_meta(GstBuffer* buf, int* camera_id, guint64* capture_time) {
  capture_meta_info();
  GstCustomMeta* m = gst_buffer_get_custom_meta(buf, "LfCaptureMeta");
  if (!m) return false;
  const GstStructure* s = gst_custom_meta_get_structure(m);
  return gst_structure_get_int(s, "camera-id", camera_id) &&
         gst_structure_get_uint64(s, "capture-time", capture_time);
}

// No fields: a bare GstMeta.
static LocalMeta sealed_meta{"LfSealedMetaAPI", "LfSealedMeta", sizeof(GstMeta),
                             [](GstMeta*, gpointer, GstBuffer*) -> gboolean { return TRUE; },
                             nullptr};
void add_sealed_meta(GstBuffer* buf) {
  gst_buffer_add_meta(buf, sealed_meta.registered(), nullptr);
}

bool has_sealed_meta(GstBuffer* buf) {
  sealed_meta.registered();
  return gst_buffer_get_meta(buf, sealed_meta.api) != nullptr;
}

namespace {
struct DeferredMeta {
  GstMeta meta;
  std::shared_ptr<const DeferredDraw>* draw;
};
}  // namespace

// It refers to this process's memory: never copied.
static LocalMeta deferred_meta{
    "LfDeferredMetaAPI", "LfDeferredMeta", sizeof(DeferredMeta),
    [](GstMeta* m, gpointer, GstBuffer*) -> gboolean {
      reinterpret_cast<DeferredMeta*>(m)->draw = nullptr;
      return TRUE;
    },
    [](GstMeta* m, GstBuffer*) { delete reinterpret_cast<DeferredMeta*>(m)->draw; }};

void add_deferred_meta(GstBuffer* buf, std::shared_ptr<const DeferredDraw> draw) {
  auto* m = reinterpret_cast<DeferredMeta*>(
      gst_buffer_add_meta(buf, deferred_meta.registered(), nullptr));
  if (m) m->draw = new std::shared_ptr<const DeferredDraw>(std::move(draw));
}

std::shared_ptr<const DeferredDraw> deferred_of(GstBuffer* buf) {
  deferred_meta.registered();
  auto* m = reinterpret_cast<DeferredMeta*>(gst_buffer_get_meta(buf, deferred_meta.api));
  return m && m->draw ? *m->draw : nullptr;
}

std::vector<std::shared_ptr<const lf::DeferredDrawing>> deferred_drawings(GstBuffer* buf,
                                                                          int camera_id, int width,
                                                                          int height) {
  std::shared_ptr<const DeferredDraw> d = deferred_of(buf);
  if (!d || d->camera.id != camera_id || d->plan.out_width != width || d->plan.out_height != height)
    return {};
  std::vector<std::shared_ptr<const lf::DeferredDrawing>> all{d};
  if (!d->layer1.plan.empty()) all.emplace_back(d, &d->layer1);  // shares d's lifetime
  return all;
}

int64_t capture_time_of(GstBuffer* frame, int camera_id, GstObject* warn_on) {
  int meta_cam = -1;
  guint64 meta_time = 0;
  if (read_capture_meta(frame, &meta_cam, &meta_time)) {
    if (meta_cam != camera_id)
      GST_WARNING_OBJECT(warn_on, "frames come from camera %d, this is camera %d", meta_cam,
                         camera_id);
    return static_cast<int64_t>(meta_time);
  }
  return GST_BUFFER_PTS_IS_VALID(frame) ? static_cast<int64_t>(GST_BUFFER_PTS(frame)) : -1;
}

std::shared_ptr<DeferredDraw> deferred_draw(GstBuffer* frame, const GstVideoInfo& info,
                                            const cv::Mat& image, const lf::Camera& cam, int slot,
                                            lf::FragmentPlan plan, lf::FragmentPlan layer1) {
  auto d = std::make_shared<DeferredDraw>();
  if (image.empty()) {  // the frame itself: mapped while the drawing waits
    if (!gst_video_frame_map(&d->frame, &info, frame, GST_MAP_READ))
      throw std::runtime_error("cannot map the camera frame");
    d->mapped = true;
    d->image = cv::Mat(GST_VIDEO_FRAME_HEIGHT(&d->frame), GST_VIDEO_FRAME_WIDTH(&d->frame), CV_8UC4,
                       GST_VIDEO_FRAME_PLANE_DATA(&d->frame, 0),
                       GST_VIDEO_FRAME_PLANE_STRIDE(&d->frame, 0));
  } else {
    d->image = image;
  }
  d->frame_key = frame;
  d->frame_pts = GST_BUFFER_PTS(frame);
  d->camera = cam;
  d->slot = slot;
  d->plan = std::move(plan);
  if (!layer1.empty()) {
    lf::DeferredDrawing& l = d->layer1;
    l.image = d->image, l.frame_key = d->frame_key, l.frame_pts = d->frame_pts;
    l.camera = cam, l.slot = slot, l.plan = std::move(layer1);
  }
  return d;
}

}  // namespace lfgst
