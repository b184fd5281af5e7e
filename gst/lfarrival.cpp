#include "lfarrival.h"

#include <memory>
#include <optional>

#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/render/fragment.h"
#include "lf/session/frame_assembly.h"
#include "lf/wire/wire.h"
#include "lfguard.h"
#include "lfmeta.h"
#include "lftrace.h"

namespace lfgst {
namespace {

// A fragment buffer decoded on arrival: raw, sealed here,
// GST_BUFFER_OFFSET_END the decoding time in ns.
constexpr GstBufferFlags kDecodedOnArrival = GST_BUFFER_FLAG_LAST;

// A fragment's arrival at a sink pad (LF_TRACE), before any queueing.
GstPadProbeReturn trace_arrival(GstPad* pad, GstPadProbeInfo* info, gpointer) {
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  GstMapInfo map;
  if (buf && gst_buffer_map(buf, &map, GST_MAP_READ)) {
    lf::FragmentHeader h;
    // Malformed: not traced here (reported when aggregated).
    if (guard([&] { h = lf::peek_fragment_header(map.data, map.size); }, nullptr)) {
      GstObject* parent = gst_pad_get_parent(pad);
      if (parent) {
        trace(GST_ELEMENT(parent), "fragment-in", h.viewer_id, h.sequence,
              static_cast<gint>(h.camera_id), static_cast<gint64>(map.size), h.capture_time_ns);
        gst_object_unref(parent);
      }
    }
    gst_buffer_unmap(buf, &map);
  }
  return GST_PAD_PROBE_OK;
}

}  // namespace

void ArrivalDecoder::install(GstPad* pad) {
  if (trace_enabled())
    gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, trace_arrival, nullptr, nullptr);
  gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, decode, this, nullptr);
}

void ArrivalDecoder::publish(uint64_t view_pixels, int64_t viewer, bool stereo, int64_t after) {
  viewer_ = viewer, stereo_ = stereo, after_ = after;
  pixels_ = view_pixels;
}

bool ArrivalDecoder::decoded(GstBuffer* buf, gint64* decode_ns) {
  if (!GST_BUFFER_FLAG_IS_SET(buf, kDecodedOnArrival)) return false;
  *decode_ns = static_cast<gint64>(GST_BUFFER_OFFSET_END(buf));
  return true;
}

GstPadProbeReturn ArrivalDecoder::decode(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* p = static_cast<ArrivalDecoder*>(data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  const uint64_t limit = p->pixels_.load();
  if (!buf || limit == 0) return GST_PAD_PROBE_OK;
  GstBuffer* raw = nullptr;
  guard(
      [&] {
        const MappedBuffer in(buf, GST_MAP_READ);
        const lf::FragmentHeader head = lf::peek_fragment_header(in.data(), in.size());
        if (head.encoding != lf::Encoding::kJpeg || head.size() != in.size() ||
            lf::is_focus_probe(head.sequence) || lf::is_surface_probe(head.sequence))
          return;
        const int64_t viewer = p->viewer_.load();
        if (viewer < 0 ||
            !(head.viewer_id == viewer || (p->stereo_.load() && head.viewer_id == viewer + 1)))
          return;
        const int64_t after = p->after_.load();
        if (!lf::RequestWindow::inside(after, head.sequence)) return;
        const gint64 t0 = g_get_monotonic_time();
        // Unmapped before it is dropped (declared after it), on a throw too.
        std::unique_ptr<GstBuffer, decltype(&gst_buffer_unref)> out(nullptr, gst_buffer_unref);
        std::optional<MappedBuffer> map;
        lf::decode_jpeg_to_raw(in.data(), in.size(), limit, [&](size_t size) {
          out.reset(gst_buffer_new_allocate(nullptr, size, nullptr));
          add_sealed_meta(out.get());  // while it is writable (sealed by the decoder)
          map.emplace(out.get(), GST_MAP_WRITE);
          return map->data();
        });
        map.reset();
        gst_buffer_copy_into(out.get(), buf, GST_BUFFER_COPY_METADATA, 0, -1);
        GST_BUFFER_FLAG_SET(out.get(), kDecodedOnArrival);
        GST_BUFFER_OFFSET_END(out.get()) =
            static_cast<guint64>((g_get_monotonic_time() - t0) * 1000);
        raw = out.release();
      },
      nullptr);
  if (raw) {
    gst_buffer_unref(buf);
    GST_PAD_PROBE_INFO_DATA(info) = raw;
  }
  return GST_PAD_PROBE_OK;
}

}  // namespace lfgst
