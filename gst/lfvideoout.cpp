#include "lfvideoout.h"

#include <cstring>

#include "lfcaps.h"

namespace lfgst {

RawVideoOutput::~RawVideoOutput() {
  if (convert_) gst_video_converter_free(convert_);
  drop_pool();
}

void RawVideoOutput::drop_last() {
  if (last_) gst_buffer_unref(last_), last_ = nullptr;
}

void RawVideoOutput::drop_pool() {
  drop_last();
  if (!pool_) return;
  gst_buffer_pool_set_active(pool_, FALSE);
  gst_object_unref(pool_);
  pool_ = nullptr;
}

bool RawVideoOutput::negotiate(GstAggregator* agg, int width, int height, Fraction fps) {
  if (negotiated_ && width_ == width && height_ == height) return true;
  GstCaps* peer = gst_pad_peer_query_caps(GST_AGGREGATOR_SRC_PAD(agg), nullptr);
  GstCaps* chosen = nullptr;
  for (const char* fmt : {"RGBA", "RGBx", "I420"}) {
    GstCaps* c = gst_caps_new_simple("video/x-raw", "format", G_TYPE_STRING, fmt, "width",
                                     G_TYPE_INT, width, "height", G_TYPE_INT, height, "framerate",
                                     GST_TYPE_FRACTION, fps.n, fps.d, nullptr);
    if (!peer || gst_caps_can_intersect(c, peer)) {
      chosen = c;
      break;
    }
    gst_caps_unref(c);
  }
  if (!chosen && peer) {
    GstCaps* any = gst_caps_from_string(
        "video/x-raw, format = (string) { RGBA, RGBx, I420 }, width = (int) [ 2, 8192 ], "
        "height = (int) [ 2, 8192 ]");
    gst_caps_set_simple(any, "framerate", GST_TYPE_FRACTION, fps.n, fps.d, nullptr);
    GstCaps* t = gst_caps_intersect_full(peer, any, GST_CAPS_INTERSECT_FIRST);
    gst_caps_unref(any);
    if (!gst_caps_is_empty(t)) {
      t = gst_caps_truncate(t);
      t = gst_caps_make_writable(t);
      GstStructure* ts = gst_caps_get_structure(t, 0);
      gst_structure_fixate_field_nearest_int(ts, "width", width);
      gst_structure_fixate_field_nearest_int(ts, "height", height);
      chosen = gst_caps_fixate(t);
      GST_INFO_OBJECT(agg, "downstream asks for another size: scaling %dx%d to %" GST_PTR_FORMAT,
                      width, height, chosen);
    } else {
      gst_caps_unref(t);
    }
  }
  if (!chosen) {
    gchar* want = peer ? gst_caps_to_string(peer) : g_strdup("(nothing)");
    GST_ELEMENT_ERROR(agg, CORE, NEGOTIATION, ("Downstream does not accept the view's video"),
                      ("the view is %dx%d at %d/%d fps (RGBA, RGBx or I420; set lfviewrequest "
                       "width, height and framerate to change it); downstream accepts %s",
                       width, height, fps.n, fps.d, want));
    g_free(want);
    if (peer) gst_caps_unref(peer);
    return false;
  }
  if (peer) gst_caps_unref(peer);
  gst_video_info_from_caps(&out_, chosen);
  if (convert_) gst_video_converter_free(convert_), convert_ = nullptr;
  const GstVideoFormat fmt = GST_VIDEO_INFO_FORMAT(&out_);
  if (fmt == GST_VIDEO_FORMAT_I420 || GST_VIDEO_INFO_WIDTH(&out_) != width ||
      GST_VIDEO_INFO_HEIGHT(&out_) != height) {
    // GStreamer's converter (any size, odd ones included), built once.
    GstVideoInfo rgba;
    gst_video_info_set_format(&rgba, GST_VIDEO_FORMAT_RGBA, width, height);
    GST_VIDEO_INFO_FPS_N(&rgba) = GST_VIDEO_INFO_FPS_N(&out_);
    GST_VIDEO_INFO_FPS_D(&rgba) = GST_VIDEO_INFO_FPS_D(&out_);
    convert_ = gst_video_converter_new(&rgba, &out_, nullptr);
    if (!convert_) {
      GST_ELEMENT_ERROR(agg, CORE, NEGOTIATION, ("Cannot convert to the negotiated video"),
                        ("%" GST_PTR_FORMAT, chosen));
      gst_caps_unref(chosen);
      return false;
    }
  }
  drop_pool();
  pool_ = gst_video_buffer_pool_new();
  GstStructure* config = gst_buffer_pool_get_config(pool_);
  gst_buffer_pool_config_set_params(config, chosen, GST_VIDEO_INFO_SIZE(&out_), 2, 0);
  if (!gst_buffer_pool_set_config(pool_, config) || !gst_buffer_pool_set_active(pool_, TRUE))
    drop_pool();  // frame() allocates then
  gst_aggregator_set_src_caps(agg, chosen);
  gst_caps_unref(chosen);
  width_ = width, height_ = height;
  negotiated_ = true;
  return true;
}

GstBuffer* RawVideoOutput::acquire() {
  GstBuffer* out = nullptr;
  if (!pool_ || gst_buffer_pool_acquire_buffer(pool_, &out, nullptr) != GST_FLOW_OK)
    out = gst_buffer_new_allocate(nullptr, GST_VIDEO_INFO_SIZE(&out_), nullptr);
  return out;
}

bool RawVideoOutput::begin_frame(cv::Mat* into, cv::Mat* last) {
  if (convert_ || !negotiated_) return false;
  const auto as_mat = [this](GstVideoFrame& vf) {
    return cv::Mat(height_, width_, CV_8UC4, GST_VIDEO_FRAME_PLANE_DATA(&vf, 0),
                   GST_VIDEO_FRAME_PLANE_STRIDE(&vf, 0));
  };
  GstBuffer* out = acquire();
  if (!gst_video_frame_map(&into_map_, &out_, out, GST_MAP_WRITE)) {
    gst_buffer_unref(out);
    return false;
  }
  *into = as_mat(into_map_);
  last_mapped_ = last_ && gst_video_frame_map(&last_map_, &out_, last_, GST_MAP_READ);
  *last = last_mapped_ ? as_mat(last_map_) : cv::Mat();
  if (into->isContinuous() && (last->empty() || last->isContinuous())) return true;
  // A padded stride: frame() copies row by row.
  gst_video_frame_unmap(&into_map_);
  if (last_mapped_) gst_video_frame_unmap(&last_map_), last_mapped_ = false;
  gst_buffer_unref(out);
  return false;
}

GstBuffer* RawVideoOutput::end_frame(bool keep) {
  GstBuffer* out = into_map_.buffer;
  gst_video_frame_unmap(&into_map_);
  if (last_mapped_) gst_video_frame_unmap(&last_map_), last_mapped_ = false;
  drop_last();
  if (keep) last_ = gst_buffer_ref(out);
  return out;
}

GstBuffer* RawVideoOutput::make_frame(bool direct, const MakeFrame& make) {
  cv::Mat into, last;
  if (!direct || !begin_frame(&into, &last)) return frame(make(nullptr, nullptr));
  try {
    make(&into, &last);
  } catch (...) {
    gst_buffer_unref(end_frame(false));  // half made: not a last frame
    throw;
  }
  return end_frame(true);
}

GstBuffer* RawVideoOutput::frame(const cv::Mat& rgba) {
  drop_last();  // frames from here on are copies: the next begin_frame() has no last
  GstBuffer* out = acquire();
  GstVideoFrame vf;
  gst_video_frame_map(&vf, &out_, out, GST_MAP_WRITE);
  if (convert_) {
    GstVideoInfo info;
    gst_video_info_set_format(&info, GST_VIDEO_FORMAT_RGBA, rgba.cols, rgba.rows);
    GST_VIDEO_INFO_FPS_N(&info) = GST_VIDEO_INFO_FPS_N(&out_);
    GST_VIDEO_INFO_FPS_D(&info) = GST_VIDEO_INFO_FPS_D(&out_);
    GstBuffer* src =
        gst_buffer_new_wrapped_full(GST_MEMORY_FLAG_READONLY, rgba.data, rgba.total() * 4, 0,
                                    rgba.total() * 4, nullptr, nullptr);
    GstVideoFrame sf;
    gst_video_frame_map(&sf, &info, src, GST_MAP_READ);
    gst_video_converter_frame(convert_, &sf, &vf);
    gst_video_frame_unmap(&sf);
    gst_buffer_unref(src);
  } else {
    auto* dst = static_cast<uint8_t*>(GST_VIDEO_FRAME_PLANE_DATA(&vf, 0));
    const int dstride = GST_VIDEO_FRAME_PLANE_STRIDE(&vf, 0);
    for (int y = 0; y < rgba.rows; ++y) std::memcpy(dst + y * dstride, rgba.ptr(y), 4 * rgba.cols);
  }
  gst_video_frame_unmap(&vf);
  return out;
}

bool ViewFormat::take_caps(GstElement* el, const GstCaps* caps, int max_side) {
  const GstStructure* cs = gst_caps_get_structure(caps, 0);
  gint w = 0, h = 0;
  if (gst_structure_get_int(cs, "width", &w) && gst_structure_get_int(cs, "height", &h)) {
    if (w < 1 || h < 1 || w > max_side || h > max_side) {
      GST_ELEMENT_WARNING(el, STREAM, FORMAT, ("Ignoring a view size out of range"),
                          ("fragment caps announce %dx%d (1..%d)", w, h, max_side));
    } else if (width_ <= 0 || height_ <= 0) {
      if (caps_width_ > 0 && (w != caps_width_ || h != caps_height_))
        GST_WARNING_OBJECT(el, "fragment caps change the view size from %dx%d to %dx%d",
                           caps_width_, caps_height_, w, h);
      caps_width_ = w, caps_height_ = h;
    }
  }
  gint n, d;
  if (!caps_framerate(caps, &n, &d) || Fraction{n, d} == caps_rate_) return false;
  if (caps_rate_.n > 0)
    GST_WARNING_OBJECT(el, "fragment caps change the request rate from %d/%d to %d/%d",
                       caps_rate_.n, caps_rate_.d, n, d);
  caps_rate_ = {n, d};
  return true;
}

Fraction ViewFormat::fps() const {
  if (rate_.n > 0) return rate_;
  if (caps_rate_.n > 0) return caps_rate_;
  return {30, 1};
}

bool ViewFormat::view_size(int* w, int* h) const {
  *w = width_ > 0 ? width_ : caps_width_;
  *h = height_ > 0 ? height_ : caps_height_;
  return *w > 0 && *h > 0;
}

}  // namespace lfgst
