// The `backend` property of lffragment, lfcompositor and lflenticular:
// its enum type and the renderer (lib/lf/render/renderer.h) it opens at start; and
// the enum type of the fragment encodings.
#pragma once

#include <gst/gst.h>

#include <memory>
#include <string>

#include "lf/render/gl_render.h"
#include "lf/render/renderer.h"
#include "lf/wire/wire.h"
#include "lfcaps.h"
#include "lfguard.h"
#include "lfprops.h"

namespace lfgst {

// The fragment encodings (lffragment, lfpartialsum `encoding`), and on the
// wire (lib/lf/wire/wire.h).
enum class FragmentEncoding { kRaw = 0, kJpeg = 1 };
inline lf::Encoding wire_encoding(FragmentEncoding e) {
  return e == FragmentEncoding::kJpeg ? lf::Encoding::kJpeg : lf::Encoding::kRaw;
}
// Fragment caps of that encoding with the stream facts of `from` (the
// request rate and view size, lfcaps.h).
inline GstCaps* fragment_caps(FragmentEncoding e, const GstCaps* from) {
  GstCaps* caps = gst_caps_new_simple("application/x-lf-fragment", "encoding", G_TYPE_STRING,
                                      e == FragmentEncoding::kJpeg ? "jpeg" : "raw", nullptr);
  copy_stream_facts(from, caps);
  return caps;
}
// lffragment's fragment caps event for request caps `in` and encoding
// `enc`: one
// GstEvent for all the process's lffragments with equal request caps and
// encoding (a new reference). A funnel joining cameras' fragments
// (lfcamerahost) forwards a pad's sticky events whenever it switches pads,
// and a sticky event only goes downstream when it is another GstEvent than
// the one before: with an equal but distinct caps event per camera, caps
// went down with nearly every fragment and each made rtpgstpay negotiate
// again (15 % of a camera host's CPU in the emulated deployment, perf).
GstEvent* shared_fragment_caps_event(const GstCaps* in, FragmentEncoding enc);

inline GType fragment_encoding_type() {
  static GType type = 0;
  static const GEnumValue values[] = {
      {static_cast<gint>(FragmentEncoding::kRaw), "Raw premultiplied RGBA row spans", "raw"},
      {static_cast<gint>(FragmentEncoding::kJpeg),
       "JPEG: colour (YCbCr 4:2:0) and weight (greyscale) JPEGs, TurboJPEG", "jpeg"},
      {0, nullptr, nullptr}};
  return enum_type(&type, "LfFragmentEncoding", values);
}

inline GType backend_type() {
  static GType type = 0;
  static const GEnumValue values[] = {
      {static_cast<gint>(lf::Backend::kAuto),
       "GL on a hardware GPU, else CPU (a software rasteriser such as llvmpipe is not used)",
       "auto"},
      {static_cast<gint>(lf::Backend::kCpu), "CPU kernels (SSE2/AVX2/AVX-512; the reference)",
       "cpu"},
      {static_cast<gint>(lf::Backend::kGl),
       "EGL/GLES 3: drawn and blended on the GPU; fails to start where no GL context can be made",
       "gl"},
      {0, nullptr, nullptr}};
  return enum_type(&type, "LfBackend", values);
}

// Makes the renderer for `backend` (lib/lf/render/renderer.h) into `renderer`.
// Logs auto's choice at INFO; posts an element error and returns false
// where GL is asked for and cannot be had.
inline bool open_renderer(GstElement* el, lf::Backend backend,
                          std::unique_ptr<lf::Renderer>& renderer) {
  std::string why;
  GError* err = nullptr;
  if (!guard([&] { renderer = lf::make_renderer(backend, &why); }, &err)) {
    GST_ELEMENT_ERROR(el, RESOURCE, FAILED, ("Cannot use the GL backend"), ("%s", err->message));
    g_error_free(err);
    return false;
  }
  if (!why.empty()) GST_INFO_OBJECT(el, "%s", why.c_str());
  return true;
}

}  // namespace lfgst
