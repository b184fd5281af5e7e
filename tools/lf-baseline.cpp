// lf-baseline: the all-viewpoints designs (Yang et al. 2002, Section 3.1:
// every camera streams its whole video to the compositor) against fragments,
// in bytes per output frame at equal picture quality of the camera images,
// on the synthetic dynamic scene with sensor noise (lfcamsrc mode=synthetic
// noise=S) seen by the rig's cameras:
//  * fragments: lfviewrequest ! lfcamerahost encoding=jpeg (not live; each
//    request answered from the frames captured at its time), fragment
//    bytes per request;
//  * partial sums: the cameras dealt to --hosts camera hosts in contiguous
//    blocks of the grid (lf/geometry/rig_ops.h host_blocks), each host's fragments
//    added up before they leave (lfcamerahost partial-sums=true, JPEG at
//    the same quality): bytes per request; and the composited frames'
//    PSNR against those of raw per-camera fragments, beside that of
//    per-camera JPEG fragments, on the rig's own images without noise
//    (lfcamsrc mode=dataset: stills, so the frames compared are the same
//    whatever the cameras' pace; the synthetic cameras, not live, run
//    ahead of the requests by a varying number of frames);
//  * all-viewpoints JPEG: every camera's frames through stock jpegenc at the
//    same quality; bytes per frame and PSNR of the decoded frames against
//    the camera's (noisy) frames;
//  * all-viewpoints H.264: stock openh264enc (Debian's H.264 encoder;
//    x264enc is in plugins-ugly) at a sweep of constant quantisers (QP),
//    keyframe every 2 s; bytes per frame at the JPEG's PSNR, interpolated
//    between the two nearest QPs (log bytes linear in PSNR).
// The codecs are measured on a sample of the cameras (spread over the rig)
// and scaled to all of them: every camera sees the same scene. (Debian 12's
// openh264 prints "cmInitParaError" once per stream whatever the settings,
// GStreamer's defaults included; the streams are encoded regardless.)
// Prints a markdown table; ends with "key value" lines after "## summary".
#include <gst/app/gstappsink.h>
#include <gst/gst.h>
#include <gst/video/video.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli.h"
#include "lf/geometry/rig_ops.h"
#include "lf/io/datasets.h"

namespace {

// Runs a non-live pipeline to EOS; sums the bytes of the buffers leaving the
// element named "bytes" (if any) and collects the RGBA frames of the
// appsinks "orig" and "dec" (if any).
struct Run {
  guint64 bytes = 0, buffers = 0;
  std::vector<cv::Mat> orig, dec;
};

GstPadProbeReturn count_bytes(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* r = static_cast<Run*>(data);
  r->bytes += gst_buffer_get_size(GST_PAD_PROBE_INFO_BUFFER(info));
  r->buffers++;
  return GST_PAD_PROBE_OK;
}

// Keeps an I420 frame as its planes' pixels, without row padding: Y, then
// U, then V.
GstFlowReturn keep_frame(GstAppSink* sink, gpointer data) {
  auto* frames = static_cast<std::vector<cv::Mat>*>(data);
  GstSample* s = gst_app_sink_pull_sample(sink);
  if (!s) return GST_FLOW_ERROR;
  GstVideoInfo info;
  GstVideoFrame f;
  if (gst_video_info_from_caps(&info, gst_sample_get_caps(s)) &&
      GST_VIDEO_INFO_FORMAT(&info) == GST_VIDEO_FORMAT_I420 &&
      gst_video_frame_map(&f, &info, gst_sample_get_buffer(s), GST_MAP_READ)) {
    std::vector<uint8_t> planes;
    for (guint c = 0; c < 3; ++c) {
      const int w = GST_VIDEO_FRAME_COMP_WIDTH(&f, c), h = GST_VIDEO_FRAME_COMP_HEIGHT(&f, c);
      const auto* d = static_cast<const uint8_t*>(GST_VIDEO_FRAME_COMP_DATA(&f, c));
      for (int r = 0; r < h; ++r)
        planes.insert(planes.end(), d + r * GST_VIDEO_FRAME_COMP_STRIDE(&f, c),
                      d + r * GST_VIDEO_FRAME_COMP_STRIDE(&f, c) + w);
    }
    frames->push_back(cv::Mat(planes, true));
    gst_video_frame_unmap(&f);
  }
  gst_sample_unref(s);
  return GST_FLOW_OK;
}

Run run(const std::string& desc) {
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  if (!p) {
    const std::string why = err ? err->message : "unknown";
    if (err) g_error_free(err);
    throw std::runtime_error("pipeline: " + why + "\n  " + desc);
  }
  Run r;
  // "bytes", or "bytes0", "bytes1", ... (one per camera host).
  for (int k = -1;; ++k) {
    GstElement* e =
        gst_bin_get_by_name(GST_BIN(p), ("bytes" + (k < 0 ? "" : std::to_string(k))).c_str());
    if (!e && k >= 0) break;
    if (!e) continue;
    GstPad* pad = gst_element_get_static_pad(e, "src");
    gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, count_bytes, &r, nullptr);
    gst_object_unref(pad);
    gst_object_unref(e);
  }
  for (auto [name, frames] : {std::pair{"orig", &r.orig}, std::pair{"dec", &r.dec}})
    if (GstElement* e = gst_bin_get_by_name(GST_BIN(p), name)) {
      GstAppSinkCallbacks cb{};
      cb.new_sample = keep_frame;
      gst_app_sink_set_callbacks(GST_APP_SINK(e), &cb, frames, nullptr);
      gst_object_unref(e);
    }
  gst_element_set_state(p, GST_STATE_PLAYING);
  GstBus* bus = gst_element_get_bus(p);
  GstMessage* msg = gst_bus_timed_pop_filtered(
      bus, 600 * GST_SECOND, static_cast<GstMessageType>(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
  std::string error;
  if (!msg) {
    error = "no end of stream within 600 s";
  } else if (GST_MESSAGE_TYPE(msg) == GST_MESSAGE_ERROR) {
    GError* e = nullptr;
    gst_message_parse_error(msg, &e, nullptr);
    error = e->message;
    g_error_free(e);
  }
  if (msg) gst_message_unref(msg);
  gst_object_unref(bus);
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(p);
  if (!error.empty()) throw std::runtime_error("pipeline: " + error + "\n  " + desc);
  return r;
}

// PSNR (dB) of the I420 samples (Y, U and V, each sample once) over all
// frames, from one mean squared error: the codecs' own measure, free of
// colour conversions (decoders label their output's range differently).
double psnr(const std::vector<cv::Mat>& a, const std::vector<cv::Mat>& b) {
  if (a.empty() || a.size() != b.size())
    throw std::runtime_error(std::to_string(b.size()) + " decoded frames for " +
                             std::to_string(a.size()) + " sent");
  double se = 0, count = 0;
  for (size_t k = 0; k < a.size(); ++k) {
    if (a[k].total() != b[k].total()) throw std::runtime_error("decoded frames differ in size");
    const double d = cv::norm(a[k], b[k], cv::NORM_L2);
    se += d * d;
    count += static_cast<double>(a[k].total());
  }
  return 10 * std::log10(255.0 * 255.0 / std::max(se / count, 1e-12));
}

struct Point {
  double bytes_per_frame, psnr;
};

}  // namespace

int main(int argc, char** argv) {
  gchar *rig_opt = nullptr, *qp_opt = nullptr, *size_opt = nullptr;
  gint frames = 45, quality = 90, sample = 8, fps = 15, hosts = 4, sum_quality = 0;
  gdouble noise = 2.0;
  GOptionEntry entries[] = {
      {"rig", 0, 0, G_OPTION_ARG_STRING, &rig_opt, "Rig file (.json) or dataset folder", "PATH"},
      {"frames", 0, 0, G_OPTION_ARG_INT, &frames, "Frames per camera and requests (default 45)",
       "N"},
      {"fps", 0, 0, G_OPTION_ARG_INT, &fps, "Capture and request rate (default 15)", "HZ"},
      {"noise", 0, 0, G_OPTION_ARG_DOUBLE, &noise,
       "Sensor noise, standard deviation in 8-bit levels (default 2)", "S"},
      {"quality", 0, 0, G_OPTION_ARG_INT, &quality,
       "JPEG quality of the fragments and of the JPEG baseline (default 90)", "Q"},
      {"sample", 0, 0, G_OPTION_ARG_INT, &sample,
       "Cameras the codecs are measured on, spread over the rig (default 8)", "N"},
      {"qp", 0, 0, G_OPTION_ARG_STRING, &qp_opt,
       "H.264 constant quantisers to sweep, 0..51 (default 8,11,14,18,22,26)", "LIST"},
      {"size", 0, 0, G_OPTION_ARG_STRING, &size_opt, "Output view size (default 640x480)", "WxH"},
      {"hosts", 0, 0, G_OPTION_ARG_INT, &hosts,
       "Camera hosts for the partial sums, contiguous blocks of the grid (default 4; 0: none)",
       "N"},
      {"sum-quality", 0, 0, G_OPTION_ARG_INT, &sum_quality,
       "JPEG quality of the partial sums (default: --quality)", "Q"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  GOptionContext* ctx = g_option_context_new(nullptr);
  g_option_context_set_summary(
      ctx,
      "Bytes per output frame: fragments (JPEG) against every camera streaming its video (JPEG, "
      "H.264) at the same PSNR of the camera images, on the synthetic dynamic scene with sensor "
      "noise (Yang et al. 2002, Section 3.1).");
  g_option_context_add_main_entries(ctx, entries, nullptr);
  g_option_context_add_group(ctx, gst_init_get_option_group());
  GError* err = nullptr;
  if (!g_option_context_parse(ctx, &argc, &argv, &err)) {
    std::fprintf(stderr, "lf-baseline: %s\n", err->message);
    return 2;
  }
  g_option_context_free(ctx);
  try {
    if (!rig_opt) throw std::invalid_argument("--rig is required");
    if (frames < 10 || frames > 1000) throw std::invalid_argument("--frames: 10..1000");
    if (quality < 1 || quality > 100) throw std::invalid_argument("--quality: 1..100");
    if (sum_quality == 0) sum_quality = quality;
    if (sum_quality < 1 || sum_quality > 100) throw std::invalid_argument("--sum-quality: 1..100");
    const std::string rig_path = rig_opt;
    const lf::Rig rig = lf::load_rig_or_dataset(rig_path);
    const int n = static_cast<int>(rig.cameras.size());
    int W = 640, H = 480;
    if (size_opt) cli::parse_size(size_opt, W, H);
    std::vector<double> qps = cli::parse_numbers(qp_opt ? qp_opt : "8,11,14,18,22,26", "--qp");
    for (double q : qps)
      if (q < 0 || q > 51 || q != std::floor(q)) throw std::invalid_argument("--qp: 0..51");
    std::sort(qps.begin(), qps.end());
    const std::string cam = " mode=synthetic noise=" + std::to_string(noise) +
                            " framerate=" + std::to_string(fps) + "/1";

    // Fragments: every camera answers every request.
    // The requests: the same orbit for every design.
    const std::string req =
        "lfviewrequest rig=" + rig_path + " framerate=" + std::to_string(fps) +
        "/1 num-buffers=" + std::to_string(frames) +
        " orbit=0.6 dolly=15 path-frames=120 focal-surface=false width=" + std::to_string(W) +
        " height=" + std::to_string(H);
    std::fprintf(stderr, "lf-baseline: fragments from %d cameras (%d requests)\n", n, frames);
    const Run fr =
        run(req + " ! lfcamerahost rig=" + rig_path +
            " frame-select=capture-time encoding=jpeg jpeg-quality=" + std::to_string(quality) +
            cam + " ! identity name=bytes ! fakesink sync=false async=false");
    if (fr.buffers != static_cast<guint64>(frames) * n)
      throw std::runtime_error("fragments: " + std::to_string(fr.buffers) + " of " +
                               std::to_string(frames * n) + " expected");
    const double fragment_bytes = static_cast<double>(fr.bytes) / frames;

    // Partial sums: one camera host per block; then, on the rig's stills,
    // into one compositor, the frames against those of raw per-camera
    // fragments, beside per-camera JPEG's.
    double sum_bytes = -1, sum_psnr = -1, camera_psnr = -1;
    if (hosts > 0) {
      if (hosts > n) throw std::invalid_argument("--hosts: at most the rig's cameras");
      const std::vector<int> host = lf::host_blocks(rig, hosts);
      const std::string to_i420 =
          " ! videoconvert ! video/x-raw,format=I420 ! appsink sync=false name=";
      // A minute for a camera's first frame: 64 cameras decoding their
      // stills on two cores take longer than lffragment's default second,
      // and a request dropped for want of a frame would be a frame short.
      const std::string wait = " frame-select=capture-time frame-timeout=60000000000";
      const std::string opts = wait + " jpeg-quality=" + std::to_string(quality);
      const std::string sum_opts = wait + " jpeg-quality=" + std::to_string(sum_quality);
      // The hosts: "! identity name=bytesK ! SINK" after each.
      auto hosts_into = [&](const std::string& camera, const std::string& sink) {
        std::string d;
        for (int k = 0; k < hosts; ++k) {
          std::string list;
          for (int i = 0; i < n; ++i)
            if (host[i] == k) list += (list.empty() ? "" : ",") + std::to_string(i);
          const std::string kk = std::to_string(k);
          d += " t. ! queue ! lfcamerahost rig=" + rig_path + " cameras=" + list +
               " partial-sums=true encoding=jpeg" + sum_opts + camera + " ! identity name=bytes" +
               kk + " ! " + (sink.empty() ? "fakesink sync=false async=false" : sink + kk);
        }
        return d;
      };
      std::fprintf(stderr, "lf-baseline: partial sums of %d camera hosts\n", hosts);
      const Run sums = run(req + " ! tee name=t" + hosts_into(cam, ""));
      if (sums.buffers != static_cast<guint64>(frames) * hosts)
        throw std::runtime_error("partial sums: " + std::to_string(sums.buffers) + " of " +
                                 std::to_string(frames * hosts) + " expected");
      sum_bytes = static_cast<double>(sums.bytes) / frames;
      std::fprintf(stderr,
                   "lf-baseline: frames from the rig's images: partial sums, per-camera "
                   "fragments raw and JPEG\n");
      const std::string still = " mode=dataset";
      const Run composited = run(req + " ! tee name=t lfcompositor name=c rig=" + rig_path +
                                 to_i420 + "dec" + hosts_into(still, "c.sink_"));
      const Run raw = run(req + " ! lfarray rig=" + rig_path + opts + still + to_i420 + "orig");
      const Run jpg =
          run(req + " ! lfarray encoding=jpeg rig=" + rig_path + opts + still + to_i420 + "dec");
      sum_psnr = psnr(raw.orig, composited.dec);
      camera_psnr = psnr(raw.orig, jpg.dec);
    }

    // The codecs on a sample of the cameras.
    std::vector<int> picks;
    const int m = std::clamp(sample, 1, n);
    for (int i = 0; i < m; ++i) picks.push_back(static_cast<int>((i + 0.5) * n / m));
    auto codec = [&](const std::string& enc, const std::string& dec) {
      Point p{0, 0};  // means over the cameras
      for (size_t i = 0; i < picks.size(); ++i) {
        cli::progress("  " + enc.substr(0, enc.find(' ')), static_cast<int>(i),
                      static_cast<int>(picks.size()));
        const Run r = run("lfcamsrc rig=" + rig_path +
                          " camera-id=" + std::to_string(rig.cameras[picks[i]].id) + cam +
                          " num-buffers=" + std::to_string(frames) +
                          " ! videoconvert ! video/x-raw,format=I420 ! tee name=t t. ! queue ! "
                          "appsink name=orig sync=false t. ! queue ! " +
                          enc + " ! identity name=bytes ! " + dec +
                          " ! video/x-raw,format=I420 ! appsink name=dec sync=false");
        p.bytes_per_frame += static_cast<double>(r.bytes) / frames / picks.size();
        p.psnr += psnr(r.orig, r.dec) / picks.size();
      }
      cli::progress("  " + enc.substr(0, enc.find(' ')), static_cast<int>(picks.size()),
                    static_cast<int>(picks.size()));
      return p;
    };
    std::fprintf(stderr, "lf-baseline: JPEG q%d on %d of %d cameras\n", quality, m, n);
    const Point jpeg = codec("jpegenc quality=" + std::to_string(quality), "jpegdec");
    std::vector<Point> h264;
    for (double qp : qps) {
      const std::string q = std::to_string(static_cast<int>(qp));
      std::fprintf(stderr, "lf-baseline: H.264 at QP %s on %d of %d cameras\n", q.c_str(), m, n);
      h264.push_back(codec("openh264enc rate-control=quality qp-min=" + q + " qp-max=" + q +
                               " gop-size=" + std::to_string(2 * fps) +
                               " complexity=high ! h264parse",
                           "openh264dec"));
    }
    // H.264 bytes at the JPEG's PSNR: between the two nearest points.
    double h264_bytes = -1;
    for (size_t i = 0; i + 1 < h264.size(); ++i) {
      const Point a = h264[i], b = h264[i + 1];
      if ((a.psnr - jpeg.psnr) * (b.psnr - jpeg.psnr) <= 0 && a.psnr != b.psnr) {
        const double t = (jpeg.psnr - a.psnr) / (b.psnr - a.psnr);
        h264_bytes = std::exp(std::log(a.bytes_per_frame) +
                              t * (std::log(b.bytes_per_frame) - std::log(a.bytes_per_frame)));
        break;
      }
    }
    std::printf("## All-viewpoints baselines against fragments, %d cameras\n\n", n);
    std::printf(
        "Synthetic dynamic scene (lfcamsrc mode=synthetic), sensor noise %.1f levels, %d "
        "fps, %d frames; %dx%d views; codecs measured on %d cameras, scaled to %d.\n\n",
        noise, fps, frames, W, H, m, n);
    std::printf("| H.264 QP | bytes per camera frame | PSNR dB |\n|---|---|---|\n");
    for (size_t i = 0; i < qps.size(); ++i)
      std::printf("| %.0f | %.0f | %.2f |\n", qps[i], h264[i].bytes_per_frame, h264[i].psnr);
    std::printf("\n| design | bytes per output frame | PSNR of the camera images (I420) dB |\n");
    std::printf("|---|---|---|\n");
    std::printf("| fragments, JPEG q%d | %.0f | (the JPEG's) |\n", quality, fragment_bytes);
    if (hosts > 0)
      std::printf(
          "| partial sums of %d hosts (contiguous blocks), JPEG q%d | %.0f (%.2fx the "
          "fragments) | (the JPEG's) |\n",
          hosts, sum_quality, sum_bytes, sum_bytes / fragment_bytes);
    std::printf("| all-viewpoints, JPEG q%d | %.0f (%.1fx the fragments) | %.2f |\n", quality,
                jpeg.bytes_per_frame * n, jpeg.bytes_per_frame * n / fragment_bytes, jpeg.psnr);
    if (h264_bytes > 0)
      std::printf(
          "| all-viewpoints, H.264 at the JPEG's PSNR | %.0f (%.2fx the fragments) | "
          "%.2f |\n",
          h264_bytes * n, h264_bytes * n / fragment_bytes, jpeg.psnr);
    else
      std::printf(
          "| all-viewpoints, H.264 | the JPEG's PSNR %.2f dB is outside the sweep "
          "(%.2f..%.2f dB) | - |\n",
          jpeg.psnr, h264.front().psnr, h264.back().psnr);
    if (hosts > 0)
      std::printf(
          "\nComposited frames of the rig's own images (no noise) against those of raw "
          "per-camera fragments (PSNR of I420): per-camera JPEG fragments %.2f dB, partial sums "
          "%.2f dB.\n",
          camera_psnr, sum_psnr);
    std::printf("\n## summary\ncameras %d\nfragment-bytes %.0f\njpeg-bytes %.0f\njpeg-psnr %.3f\n",
                n, fragment_bytes, jpeg.bytes_per_frame * n, jpeg.psnr);
    std::printf("h264-bytes %.0f\n", h264_bytes > 0 ? h264_bytes * n : -1.0);
    if (hosts > 0)
      std::printf("sum-hosts %d\nsum-bytes %.0f\nsum-frame-psnr %.3f\ncamera-frame-psnr %.3f\n",
                  hosts, sum_bytes, sum_psnr, camera_psnr);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lf-baseline: error: %s\n", e.what());
    return 1;
  }
}
