// Fragment bundles: one buffer for several cameras' answers to one request,
// so that a compositor is handed a request thread's fragments in a push or
// two instead of one push per camera. GstAggregator wakes its thread for
// every buffer that comes (64 a frame with 64 cameras, though it can only
// use the last of a request's); with one bundle per request thread it wakes
// a few times a frame (docs/results.md, "Where the pipeline's CPU goes").
//
// A bundle is a buffer whose memories are each one camera's answer (a
// fragment buffer's bytes, lib/lf/wire/wire.h), at most kMaxBundleParts
// (GStreamer's limit of memories per buffer), with the first part's
// timestamps and an LfBundleMeta. The meta, like LfSealedMeta (gst/lfmeta.h),
// is never copied with a buffer, so only buffers made in this process are
// bundles: bytes from the network are always one answer per buffer.
//
// lfcamerahost (lfarray) puts an lffragmentbundle between each request
// thread's lffragments and lfcompositor; lfcompositor's arrival decoder
// (gst/lfarrival.h) decodes a bundle's JPEG parts, and it takes the parts
// one by one (each_bundled(), in gst/lffragmentaggregator.cpp).
#pragma once

#include <gst/gst.h>

namespace lfgst {

constexpr guint kMaxBundleParts = 16;  // GST_BUFFER_MEM_MAX

// Marks `buf` as a bundle whose part k is sealed (gst/lfmeta.h) where bit k
// of `sealed` is set. `whole`, when not null, holds kMaxBundleParts
// entries: part k's own buffer where it must come back whole (a drawing
// left to the compositor: its LfDeferredMeta, which a memory does not
// carry), held by the bundle (a reference taken), or null.
void add_bundle_meta(GstBuffer* buf, guint32 sealed, GstBuffer* const* whole = nullptr);
// Whether `buf` is a bundle; its sealed parts' bits in `*sealed`.
bool is_bundle(GstBuffer* buf, guint32* sealed);

// Part k of a bundle whose sealed parts are `sealed`, as a buffer of its
// own (new): the part's own buffer where the bundle holds it (a new
// reference), else its memory, the bundle's timestamps, offsets and flags,
// LfSealedMeta where the part is sealed.
GstBuffer* bundle_part(GstBuffer* bundle, guint k, guint32 sealed);

// Calls `fn(GstBuffer*)` with each part of a bundle (bundle_part()), or with
// `buf` itself when it is not a bundle. (So each part of a bundle decoded on
// arrival carries the whole bundle's decoding time in GST_BUFFER_OFFSET_END,
// which LF_TRACE's "decoded" events report.) A template: on every fragment
// buffer's path, with no std::function to allocate.
template <class Fn>
void each_bundled(GstBuffer* buf, Fn&& fn) {
  guint32 sealed = 0;
  if (!is_bundle(buf, &sealed)) return fn(buf);
  for (guint k = 0, n = gst_buffer_n_memory(buf); k < n; ++k) {
    GstBuffer* part = bundle_part(buf, k, sealed);
    fn(part);
    gst_buffer_unref(part);
  }
}

// Calls `fn(k, data, size)` with the bytes of each part k of a bundle (its
// memories, each mapped alone), or of `buf` itself (k 0) when it is not a
// bundle; a part that cannot be mapped is left out.
template <class Fn>
void each_part_bytes(GstBuffer* buf, Fn&& fn) {
  GstMapInfo map;
  if (!is_bundle(buf, nullptr)) {
    if (!gst_buffer_map(buf, &map, GST_MAP_READ)) return;
    fn(0u, map.data, map.size);
    gst_buffer_unmap(buf, &map);
    return;
  }
  for (guint k = 0, n = gst_buffer_n_memory(buf); k < n; ++k) {
    GstMemory* mem = gst_buffer_peek_memory(buf, k);
    if (!gst_memory_map(mem, &map, GST_MAP_READ)) continue;
    fn(k, static_cast<const guint8*>(map.data), map.size);
    gst_memory_unmap(mem, &map);
  }
}

// The request sequence of `buf`'s first fragment (a bundle's first part), or
// -1 when it has none that parses; maps no more than that memory. `viewer`:
// null, or where its viewer id goes.
gint64 first_sequence(GstBuffer* buf, guint32* viewer = nullptr);

}  // namespace lfgst

G_BEGIN_DECLS
// lffragmentbundle: request sink pads `sink_%u` (fragment buffers, each one
// camera's answer, all pushed from one thread), one `src` pad: the buffers
// of one request (a viewer's sequence; in stereo each eye its own), bundled
// when every sink pad has given one for it (or
// kMaxBundleParts have come); a buffer of another request, an event, EOS or
// a buffer that cannot be bundled sends what is held first. Only
// lfcamerahost makes it (not registered with a factory).
#define LF_TYPE_FRAGMENT_BUNDLE (lf_fragment_bundle_get_type())
G_DECLARE_FINAL_TYPE(LfFragmentBundle, lf_fragment_bundle, LF, FRAGMENT_BUNDLE, GstElement)
G_END_DECLS
