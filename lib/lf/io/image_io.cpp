#include "lf/io/image_io.h"

#include <png.h>
#include <turbojpeg.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "lf/io/parse.h"

namespace lf {
namespace {

constexpr int kMaxSide = 32768;

std::runtime_error error(const std::string& path, const std::string& what) {
  return std::runtime_error("image " + path + ": " + what);
}

enum class Kind { kPng, kJpeg, kOther };

Kind kind_of(const unsigned char* head, size_t n) {
  static const unsigned char png[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n >= 8 && std::memcmp(head, png, 8) == 0) return Kind::kPng;
  if (n >= 3 && head[0] == 0xff && head[1] == 0xd8 && head[2] == 0xff) return Kind::kJpeg;
  return Kind::kOther;
}

// libpng reports errors by longjmp: the message goes to the error pointer.
struct PngError {
  char message[256] = "";
};

void png_fail(png_structp png, png_const_charp msg) {
  auto* e = static_cast<PngError*>(png_get_error_ptr(png));
  std::snprintf(e->message, sizeof e->message, "%s", msg);
  png_longjmp(png, 1);
}

void png_warn(png_structp, png_const_charp) {}  // warnings are not errors

// Reads the PNG behind `f`: only its size when `out` is null, else its
// pixels into `out` (created here) through `rows` (sized here). Between
// setjmp and a longjmp only trivially destructible locals live in this
// frame. Returns false with `err` set on any libpng error.
bool read_png(FILE* f, int* width, int* height, cv::Mat* out, std::vector<png_bytep>* rows,
              PngError* err) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, err, png_fail, png_warn);
  if (!png) {
    std::snprintf(err->message, sizeof err->message, "out of memory");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    std::snprintf(err->message, sizeof err->message, "out of memory");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_init_io(png, f);
  png_set_user_limits(png, kMaxSide, kMaxSide);
  png_read_info(png, info);
  const int w = static_cast<int>(png_get_image_width(png, info));
  const int h = static_cast<int>(png_get_image_height(png, info));
  *width = w;
  *height = h;
  if (out) {
    // The transformations of OpenCV 4.6's PngDecoder::readData for an
    // 8-bit, 3-channel image, in its order.
    const int bit_depth = png_get_bit_depth(png, info);
    const int colour = png_get_color_type(png, info);
    if (bit_depth == 16) png_set_strip_16(png);
    png_set_strip_alpha(png);
    if (colour == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if ((colour & PNG_COLOR_MASK_COLOR) == 0 && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (colour & PNG_COLOR_MASK_COLOR)
      png_set_bgr(png);
    else
      png_set_gray_to_rgb(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    if (png_get_rowbytes(png, info) != static_cast<size_t>(w) * 3)
      png_error(png, "unexpected row size after conversion to 8-bit BGR");
    out->create(h, w, CV_8UC3);
    rows->resize(static_cast<size_t>(h));
    for (int y = 0; y < h; ++y) (*rows)[y] = out->ptr<png_byte>(y);
    png_read_image(png, rows->data());
    png_read_end(png, nullptr);
  }
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

cv::Mat read(const std::string& path, bool pixels, cv::Size* size) {
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw error(path, "missing or unreadable");
  unsigned char head[8] = {};
  const size_t n = std::fread(head, 1, sizeof head, f);
  const Kind kind = kind_of(head, n);
  if (kind == Kind::kPng) {
    std::rewind(f);
    cv::Mat m;
    std::vector<png_bytep> rows;
    PngError err;
    int w = 0, h = 0;
    const bool ok = read_png(f, &w, &h, pixels ? &m : nullptr, &rows, &err);
    std::fclose(f);
    if (!ok) throw error(path, std::string("damaged PNG (") + err.message + ")");
    *size = cv::Size(w, h);
    return m;
  }
  std::fclose(f);
  if (kind != Kind::kJpeg) throw error(path, "neither PNG nor JPEG");
  std::ifstream in(path, std::ios::binary);
  const std::vector<unsigned char> data((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  tjhandle tj = tjInitDecompress();
  if (!tj) throw error(path, "cannot start the JPEG decoder");
  int w = 0, h = 0, subsampling = 0, colourspace = 0;
  std::string why;
  cv::Mat m;
  if (tjDecompressHeader3(tj, data.data(), static_cast<unsigned long>(data.size()), &w, &h,
                          &subsampling, &colourspace) != 0) {
    why = std::string("damaged JPEG (") + tjGetErrorStr2(tj) + ")";
  } else if (w < 1 || h < 1) {
    why = "damaged JPEG (no image size)";
  } else if (w > kMaxSide || h > kMaxSide) {
    why = "JPEG of " + std::to_string(w) + "x" + std::to_string(h) + " pixels (at most " +
          std::to_string(kMaxSide) + " a side)";
  } else if (pixels) {
    m.create(h, w, CV_8UC3);
    // TurboJPEG's defaults are libjpeg's, as cv::imread uses them: the
    // accurate integer DCT and fancy upsampling.
    // A warning is an error too: libjpeg warns of a file cut short
    // ("Premature end of JPEG file") or of corrupt data, and still returns
    // an image, grey below the damage. None of the datasets' 107 JPEGs warns.
    if (tjDecompress2(tj, data.data(), static_cast<unsigned long>(data.size()), m.data, w,
                      static_cast<int>(m.step), h, TJPF_BGR, 0) != 0)
      why = std::string(tjGetErrorCode(tj) == TJERR_FATAL ? "damaged JPEG ("
                                                          : "truncated or corrupt JPEG (") +
            tjGetErrorStr2(tj) + ")";
  }
  tjDestroy(tj);
  if (!why.empty()) throw error(path, why);
  *size = cv::Size(w, h);
  return m;
}

}  // namespace

cv::Mat read_image(const std::string& path) {
  cv::Size size;
  return read(path, true, &size);
}

cv::Size read_image_size(const std::string& path) {
  cv::Size size;
  read(path, false, &size);
  return size;
}

bool is_still_image(const std::string& path) {
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  unsigned char head[8] = {};
  const size_t n = std::fread(head, 1, sizeof head, f);
  std::fclose(f);
  return kind_of(head, n) != Kind::kOther;
}

void check_image_fits(const std::string& path, cv::Size image, int width, int height) {
  if (image.width == width && image.height == height) return;
  // The size a uniform resize to `width` columns gives, within a pixel of
  // rounding either way (scale_rig rounds each side on its own).
  const double s = static_cast<double>(width) / image.width;
  if (image.width > 0 && image.height > 0 && std::abs(image.height * s - height) <= 1.0) return;
  throw error(path, std::to_string(image.width) + "x" + std::to_string(image.height) +
                        " pixels, which no uniform resize makes the camera's " +
                        std::to_string(width) + "x" + std::to_string(height) +
                        " (a still of another camera or another rig?)");
}

cv::Mat read_camera_image(const std::string& path, int width, int height) {
  cv::Mat bgr = read_image(path), rgba;
  check_image_fits(path, bgr.size(), width, height);
  if (bgr.cols != width || bgr.rows != height)
    cv::resize(bgr, bgr, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  cv::cvtColor(bgr, rgba, cv::COLOR_BGR2RGBA);
  return rgba;
}

std::string StillSequence::path(int64_t k) const {
  if (!is_sequence()) return location_;
  try {
    return camera_file_name(location_, static_cast<int>(k), "location");
  } catch (const std::exception&) {
    return location_;
  }
}

std::string StillSequence::name(int64_t k) const {
  return is_sequence() ? path(k) + " (frame " + std::to_string(k) + ")" : location_;
}

StillSequence::Next StillSequence::next(cv::Mat* rgba) {
  Next n;
  const bool sequence = is_sequence();
  int wraps = 0;  // back to the first frame in this call: twice, and no frame decodes
  for (;;) {
    const std::string file = path(index_);
    std::error_code ec;
    const bool exists = (sequence || index_ == 0) && std::filesystem::is_regular_file(file, ec);
    if (!exists) {
      if (index_ == 0) {
        n.what = Next::What::kMissing, n.error = file + ": missing or unreadable";
        return n;
      }
      if (!loop_) {
        n.what = Next::What::kEnd;
        return n;
      }
      if (!sequence) {
        n.what = Next::What::kSame;
        return n;
      }
      if (++wraps > 1) {
        n.what = Next::What::kUndecodable;
        n.error = location_ + ": no frame of the sequence decodes";
        return n;
      }
      index_ = 0;
      continue;
    }
    const int64_t k = index_++;
    try {
      *rgba = read_camera_image(file, width_, height_);
      return n;
    } catch (const std::exception& e) {
      if (!skip_bad_ || !sequence) {  // a still is the whole input
        n.what = Next::What::kUndecodable;
        n.error = name(k) + ": " + e.what() + " (skip-bad-frames=true skips such frames)";
        return n;
      }
      n.skipped.push_back(name(k) + ": " + e.what());
    }
  }
}

}  // namespace lf
