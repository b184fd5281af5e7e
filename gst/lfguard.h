// The one boundary between the C++ core (which reports errors as exceptions:
// std::invalid_argument, std::runtime_error, lf::WireError, cv::Exception)
// and GLib/GStreamer (which report them as GError and element messages).
// Every call from an element into C++ that may throw goes through guard();
// no exception crosses into GStreamer.
#pragma once

#include <glib.h>
#include <gst/gst.h>

#include <cstdint>
#include <exception>
#include <stdexcept>
#include <utility>

namespace lfgst {

GQuark error_quark();

// Runs `fn`. TRUE if it returned; FALSE with `*error` set (domain
// error_quark(), code 0, message = the exception's what()) if it threw.
template <class F>
gboolean guard(F&& fn, GError** error) noexcept {
  try {
    fn();
    return TRUE;
  } catch (const std::exception& e) {
    g_set_error_literal(error, error_quark(), 0, e.what());
  } catch (...) {
    g_set_error_literal(error, error_quark(), 0, "unknown C++ exception");
  }
  return FALSE;
}

// A counted reference to a GstBuffer (a copy is a new reference; none
// converts to false): a frame handle for lib templates (lf::CameraFrames).
class BufferRef {
 public:
  BufferRef() = default;
  explicit BufferRef(GstBuffer* b) : b_(b ? gst_buffer_ref(b) : nullptr) {}
  BufferRef(const BufferRef& o) : BufferRef(o.b_) {}
  BufferRef(BufferRef&& o) noexcept : b_(o.b_) { o.b_ = nullptr; }
  BufferRef& operator=(BufferRef o) noexcept {
    std::swap(b_, o.b_);
    return *this;
  }
  ~BufferRef() {
    if (b_) gst_buffer_unref(b_);
  }
  GstBuffer* get() const { return b_; }
  explicit operator bool() const { return b_ != nullptr; }

 private:
  GstBuffer* b_ = nullptr;
};

// A buffer mapped for the lifetime of this object (also when an exception
// leaves the scope). Throws std::runtime_error if it cannot be mapped. Holds
// its own reference to the buffer, taken after mapping (a write mapping
// needs the caller's buffer writable).
class MappedBuffer {
 public:
  MappedBuffer(GstBuffer* buffer, GstMapFlags flags) : buf_(nullptr) {
    if (!gst_buffer_map(buffer, &map_, flags)) throw std::runtime_error("cannot map a buffer");
    buf_ = gst_buffer_ref(buffer);
  }
  ~MappedBuffer() {
    if (buf_) {
      gst_buffer_unmap(buf_, &map_);
      gst_buffer_unref(buf_);
    }
  }
  MappedBuffer(MappedBuffer&& o) noexcept : buf_(o.buf_), map_(o.map_) { o.buf_ = nullptr; }
  MappedBuffer(const MappedBuffer&) = delete;
  MappedBuffer& operator=(const MappedBuffer&) = delete;
  MappedBuffer& operator=(MappedBuffer&&) = delete;
  uint8_t* data() const { return map_.data; }
  size_t size() const { return map_.size; }

 private:
  GstBuffer* buf_;
  GstMapInfo map_{};
};

// An element made by factory name (and instance name, or null); throws
// std::runtime_error naming the factory when GStreamer lacks it. For code
// that runs inside guard().
GstElement* make_element(const char* factory, const char* name = nullptr);

// Links the first video pad that `decoder` (decodebin, uridecodebin) adds to
// `convert`'s sink pad.
void link_decoded_video(GstElement* decoder, GstElement* convert);

}  // namespace lfgst
