#include "lfarrival.h"

#include <algorithm>
#include <memory>
#include <stdexcept>

#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/render/fragment.h"
#include "lf/session/frame_assembly.h"
#include "lf/wire/wire.h"
#include "lfbundle.h"
#include "lfguard.h"
#include "lfmeta.h"
#include "lftrace.h"

namespace lfgst {
namespace {

// A fragment buffer decoded on arrival: raw, sealed here,
// GST_BUFFER_OFFSET_END the decoding time in ns.
constexpr GstBufferFlags kDecodedOnArrival = GST_BUFFER_FLAG_LAST;

// A fragment's arrival at a sink pad (LF_TRACE), before any queueing: each
// part of a bundle.
GstPadProbeReturn trace_arrival(GstPad* pad, GstPadProbeInfo* info, gpointer) {
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  GstObject* parent = buf ? gst_pad_get_parent(pad) : nullptr;
  if (!parent) return GST_PAD_PROBE_OK;
  each_part_bytes(buf, [&](guint, const guint8* data, gsize size) {
    lf::FragmentHeader h;
    // Malformed: not traced here (reported when aggregated).
    if (guard([&] { h = lf::peek_fragment_header(data, size); }, nullptr))
      trace(GST_ELEMENT(parent), "fragment-in", h.viewer_id, h.sequence,
            static_cast<gint>(h.camera_id), static_cast<gint64>(size), h.capture_time_ns);
  });
  gst_object_unref(parent);
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

GstMemory* ArrivalDecoder::decode_one(const guint8* data, gsize size, uint64_t limit) const {
  GstMemory* decoded = nullptr;
  guard(
      [&] {
        const lf::FragmentHeader head = lf::peek_fragment_header(data, size);
        if (head.encoding != lf::Encoding::kJpeg || head.size() != size ||
            lf::is_focus_probe(head.sequence) || lf::is_surface_probe(head.sequence))
          return;
        const int64_t viewer = viewer_.load();
        if (viewer < 0 ||
            !(head.viewer_id == viewer || (stereo_.load() && head.viewer_id == viewer + 1)))
          return;
        if (!lf::RequestWindow::inside(after_.load(), head.sequence)) return;
        std::unique_ptr<GstMemory, decltype(&gst_memory_unref)> out(nullptr, gst_memory_unref);
        GstMapInfo map{};
        // Unmapped before it is dropped, on a throw too.
        auto unmap = [&] {
          if (map.memory) gst_memory_unmap(map.memory, &map), map.memory = nullptr;
        };
        try {
          lf::decode_jpeg_to_raw(data, size, limit, [&](size_t n) {
            out.reset(gst_allocator_alloc(nullptr, n, nullptr));
            if (!out || !gst_memory_map(out.get(), &map, GST_MAP_WRITE))
              throw std::runtime_error("cannot map a decoded fragment");
            return map.data;
          });
        } catch (...) {
          unmap();
          throw;
        }
        unmap();
        decoded = out.release();
      },
      nullptr);
  return decoded;
}

GstPadProbeReturn ArrivalDecoder::decode(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* p = static_cast<ArrivalDecoder*>(data);
  GstBuffer* buf = GST_PAD_PROBE_INFO_BUFFER(info);
  const uint64_t limit = p->pixels_.load();
  if (!buf || limit == 0) return GST_PAD_PROBE_OK;
  guint32 sealed = 0;
  const bool bundle = is_bundle(buf, &sealed);
  const gint64 t0 = g_get_monotonic_time();
  // Each part decoded into a memory of its own (sealed by the decoder), or
  // kept as it came.
  GstMemory* parts[kMaxBundleParts] = {};
  guint n = 0, decoded = 0;
  each_part_bytes(buf, [&](guint k, const guint8* bytes, gsize size) {
    if (k >= kMaxBundleParts) return;
    n = k + 1;
    if ((parts[k] = p->decode_one(bytes, size, limit))) ++decoded;
  });
  if (decoded == 0) return GST_PAD_PROBE_OK;
  if (bundle) n = std::min(gst_buffer_n_memory(buf), kMaxBundleParts);  // every part kept
  GstBuffer* raw = gst_buffer_new();
  for (guint k = 0; k < n; ++k) {
    if (parts[k]) sealed |= 1u << k;
    gst_buffer_append_memory(raw, parts[k] ? parts[k] : gst_buffer_get_memory(buf, k));
  }
  if (bundle)
    add_bundle_meta(raw, sealed);
  else
    add_sealed_meta(raw);  // while it is writable
  gst_buffer_copy_into(raw, buf, GST_BUFFER_COPY_METADATA, 0, -1);
  GST_BUFFER_FLAG_SET(raw, kDecodedOnArrival);
  GST_BUFFER_OFFSET_END(raw) = static_cast<guint64>((g_get_monotonic_time() - t0) * 1000);
  gst_buffer_unref(buf);
  GST_PAD_PROBE_INFO_DATA(info) = raw;
  return GST_PAD_PROBE_OK;
}

}  // namespace lfgst
