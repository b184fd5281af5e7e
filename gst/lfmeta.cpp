#include "lfmeta.h"

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

}  // namespace lfgst
