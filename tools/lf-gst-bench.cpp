// lf-gst-bench: throughput and request->frame latency of the single-machine
// GStreamer pipeline (lfviewrequest ! lfarray ! appsink: N x (lfcamsrc,
// lffragment) and an lfcompositor), in process.
//  * throughput: non-live, requests as fast as the pipeline takes them;
//    output frames per second between two frames where the pipeline is
//    full: after a warm-up and kTail frames before the last (not live, the
//    compositor lets the cameras run up to 16 requests ahead; counted to the
//    last frame, the frames drained at the end, whose fragments were drawn
//    before, would add throughput that no work paid for).
//  * kernel bound, in the same run (before and after each throughput run,
//    the mean of the two): the library's plan + render + composite
//    of the same views on one thread, times the number of cores (raw
//    fragments; the faster of the library's two ways: fragments rendered
//    then composited, or drawn band by band into the sums, fused, as
//    lfcompositor draws lfarray's deferred fragments); pipeline efficiency
//    = throughput / kernel bound. It splits into CPU efficiency (the
//    kernels' CPU time per frame / the process's CPU time per frame) times
//    the cores the pipeline keeps busy; the share of the machine stolen by
//    the hypervisor meanwhile is printed beside them (on a shared VM it
//    slows both the pipeline and the bound). JPEG rows get a bound of their
//    own: each fragment drawn into its rectangle and JPEG-encoded
//    (lf::render_rows, lf::serialize_jpeg_fragment, as lffragment does),
//    decoded into the raw wire format (lf::decode_jpeg_to_raw, as
//    lfcompositor does on arrival), then all composited; the ratio of the
//    two bounds is the most of the raw pipeline's throughput that a JPEG
//    pipeline could reach. The same loop on every core at once (a thread
//    each, tools/bench/bound.h) says how much of the bound, which takes
//    the cores as independent, a pipeline can reach on this machine; one
//    view at a time with its bands drawn on every core (OpenCV's threads,
//    as lfcompositor draws) says how much of it a pipeline that splits
//    each view across the cores can reach (the split's own cost: the
//    threads' start and join each view, and their uneven shares).
//  * the process's peak resident set size during each row's pipelines.
//  * latency: a live request source at a fixed rate; for each request, the
//    time from the request leaving lfviewrequest to its frame reaching the
//    sink (pad probes, matched by sequence number); median and 95th
//    percentile.
#include <gst/app/gstappsink.h>
#include <gst/gst.h>
#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <thread>

#include "bench/bound.h"
#include "bench/viewers.h"
#include "cli.h"
#include "lf/geometry/rig_ops.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/datasets.h"
#include "lf/io/parse.h"
#include "lf/io/rig_file.h"
#include "lf/render/composite.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"
#include "lf/wire/wire.h"
#include "measure.h"

namespace {

using namespace measure;  // tools/measure.h: CPU time, peak RSS, quantiles
using lfbench::KernelTime;

const char* kSummary =
    "Throughput (non-live) and request -> frame latency (live) of the single-machine\n"
    "GStreamer pipeline (lfviewrequest ! tee ! N x (queue ! lffragment) ! lfcompositor\n"
    "! appsink), in process.";

struct Probe {
  std::mutex m;
  std::map<guint64, gint64> sent;
  std::vector<double> latency_ms;
};

GstPadProbeReturn on_request(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* p = static_cast<Probe*>(data);
  GstBuffer* b = GST_PAD_PROBE_INFO_BUFFER(info);
  std::lock_guard<std::mutex> l(p->m);
  p->sent[GST_BUFFER_OFFSET(b)] = g_get_monotonic_time();
  return GST_PAD_PROBE_OK;
}

GstPadProbeReturn on_frame(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* p = static_cast<Probe*>(data);
  GstBuffer* b = GST_PAD_PROBE_INFO_BUFFER(info);
  const gint64 now = g_get_monotonic_time();
  std::lock_guard<std::mutex> l(p->m);
  auto it = p->sent.find(GST_BUFFER_OFFSET(b));
  if (it != p->sent.end()) p->latency_ms.push_back((now - it->second) / 1000.0);
  return GST_PAD_PROBE_OK;
}

// The views of the single-viewer runs, for the pipeline (lfviewrequest
// properties) and for the kernel bound (lf::ViewSettings) alike.
constexpr double kOrbit = 0.5;
constexpr int kPathFrames = 120;
// The focal plane: Chess's light-slab parameter -0.2 where the rig has one;
// else (a synthetic rig from lf-rig --synthetic --images) a plane 40 camera
// spacings deep, between the synthetic scene's disc and background. Set in
// main() once the rig is loaded.
std::string g_focal_plane = "param:-0.2";

// `surface` > 0: lfviewrequest focal-surface=true with that surface-interval
// (a focal surface from the fragments, lib/lf/focus/surface_probe.h) instead of
// the fixed focal plane; `props`: more lfviewrequest properties
// ("name=value ...", e.g. "ulr-cameras=4 sampling=bicubic").
// lfarray's properties for `backend`: cpu and gl (its whole-view mode, the
// default: the fragments only plan, on one request thread, and the
// compositor draws them all, fused into its CPU compositing or with GL) or
// cpu-fragments and gl-fragments (whole-view=false: each lffragment draws
// its own fragment, on the bin's request threads, and the compositor adds
// them). More lfarray properties may follow after '+' signs
// ("cpu-fragments+request-max-age=0").
std::string backend_properties(const std::string& spec) {
  const size_t plus = spec.find('+');
  const std::string backend = spec.substr(0, plus);
  std::string more = plus == std::string::npos ? "" : spec.substr(plus);
  std::replace(more.begin(), more.end(), '+', ' ');
  if (backend == "cpu") return "backend=cpu" + more;
  if (backend == "cpu-fragments") return "backend=cpu whole-view=false" + more;
  if (backend == "gl") return "backend=gl" + more;
  if (backend == "gl-fragments") return "backend=gl whole-view=false" + more;
  throw std::invalid_argument("backend '" + backend +
                              "': use cpu, cpu-fragments, gl or gl-fragments");
}

// The quality of a "jpegQ" encoding (1..100); 0 for "raw".
int jpeg_quality(const std::string& enc) {
  if (enc == "raw") return 0;
  if (enc.rfind("jpeg", 0) == 0 && enc.size() > 4 && enc.size() <= 7 &&
      enc.find_first_not_of("0123456789", 4) == std::string::npos) {
    const int q = std::stoi(enc.substr(4));
    if (q >= 1 && q <= 100) return q;
  }
  throw std::invalid_argument("encoding '" + enc + "': use raw or jpegQ (Q: 1..100)");
}

// The fragments' properties for an encoding ("raw" or "jpegQ").
std::string encoding_properties(const std::string& enc) {
  const int q = jpeg_quality(enc);
  return q ? "encoding=jpeg jpeg-quality=" + std::to_string(q) : "encoding=raw";
}

// The pipeline on one machine as lfarray builds it (gst/lfcamerahost.cpp):
// lfviewrequest ! lfarray (64 x lfcamsrc and lffragment, one lfcompositor)
// ! appsink; no request rate limit (max-rate=0: the runs ask for more than
// its default 240 a second).
std::string pipeline(const std::string& rig, int W, int H, const std::string& enc, bool live,
                     int frames, int rate, int surface = 0, const std::string& props = "",
                     const std::string& backend = "cpu") {
  const std::string fr = encoding_properties(enc);
  std::ostringstream d;
  d << "lfviewrequest name=req rig=" << rig << " width=" << W << " height=" << H
    << " orbit=" << kOrbit << " path-frames=" << kPathFrames << " focal-plane=" << g_focal_plane
    << (surface > 0 ? " focal-surface=true surface-interval=" + std::to_string(surface)
                    : " focal-surface=false")
    << (props.empty() ? "" : " " + props) << " framerate=" << rate << "/1"
    << (live ? " is-live=true" : "") << " num-buffers=" << frames << " ! lfarray rig=" << rig
    << " num-buffers=1 max-rate=0 " << fr << " " << backend_properties(backend)
    << (live ? " latency=100000000" : "") << " ! appsink name=out sync=false max-buffers=4";
  return d.str();
}

// One output frame: when it reached the sink (s, monotonic), the process's
// CPU time then (s) and the machine's ticks (read for the first 32 frames,
// the last kTail + 8 of the `expected` and, at EOS, for the last one; 0 for
// the others).
struct Mark {
  double wall = 0, cpu = 0;
  MachineTicks machine;
};

// An output frame's pixels (4 bytes a pixel: the compositor's RGBA or
// BGRx), for the picture's agreement between rows: the frame of request
// kCompareFrame, the same view in every non-live row (a surface row has
// had its first estimate by then).
constexpr size_t kCompareFrame = 10;
cv::Mat frame_of(GstSample* s) {
  gint w = 0, h = 0;
  const GstStructure* st = gst_caps_get_structure(gst_sample_get_caps(s), 0);
  GstMapInfo m;
  GstBuffer* b = gst_sample_get_buffer(s);
  if (!gst_structure_get_int(st, "width", &w) || !gst_structure_get_int(st, "height", &h) ||
      !gst_buffer_map(b, &m, GST_MAP_READ))
    return {};
  cv::Mat out;
  if (m.size >= static_cast<size_t>(w) * h * 4) cv::Mat(h, w, CV_8UC4, m.data).copyTo(out);
  gst_buffer_unmap(b, &m);
  return out;
}

// Runs to EOS; returns a mark per output frame (and in `first` the pixels
// of frame kCompareFrame).
// Frames before the last that end a throughput window (more than the
// requests the compositor lets the cameras run ahead:
// lfgst::CompositorDeadline::kRunAhead = 16, gst/lfdeadline.h).
constexpr size_t kTail = 24;

std::vector<Mark> run(const std::string& desc, Probe* probe, cv::Mat* first = nullptr,
                      size_t expected = 0) {
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  if (!p || err) {  // a missing element is an error too, not a pipeline that never ends
    const std::string msg = std::string("pipeline: ") + (err ? err->message : "?") +
                            " (is GST_PLUGIN_PATH set to build/gst?)";
    g_clear_error(&err);
    if (p) gst_object_unref(p);
    throw std::runtime_error(msg);
  }
  GstElement* req = gst_bin_get_by_name(GST_BIN(p), "req");
  GstElement* out = gst_bin_get_by_name(GST_BIN(p), "out");
  if (probe) {
    GstPad* rp = gst_element_get_static_pad(req, "src");
    gst_pad_add_probe(rp, GST_PAD_PROBE_TYPE_BUFFER, on_request, probe, nullptr);
    gst_object_unref(rp);
    GstPad* op = gst_element_get_static_pad(out, "sink");
    gst_pad_add_probe(op, GST_PAD_PROBE_TYPE_BUFFER, on_frame, probe, nullptr);
    gst_object_unref(op);
  }
  std::vector<Mark> times;
  gst_element_set_state(p, GST_STATE_PLAYING);
  GstBus* bus = gst_element_get_bus(p);
  std::string error;
  while (true) {
    GstSample* s = gst_app_sink_try_pull_sample(GST_APP_SINK(out), 50 * GST_MSECOND);
    if (s) {
      // CPU time and machine ticks at the first and the last frames only
      // (reading them costs; see the end mark below).
      if (times.size() < 32 || (expected > 0 && times.size() + kTail + 8 >= expected))
        times.push_back({g_get_monotonic_time() / 1e6, process_cpu_s(), machine_ticks()});
      else
        times.push_back({g_get_monotonic_time() / 1e6, 0, {}});
      if (first && times.size() == kCompareFrame + 1) *first = frame_of(s);
      gst_sample_unref(s);
    }
    GstMessage* m = gst_bus_pop_filtered(bus, static_cast<GstMessageType>(GST_MESSAGE_ERROR));
    if (m) {
      GError* e = nullptr;
      gst_message_parse_error(m, &e, nullptr);
      error = e->message;
      g_clear_error(&e);
      gst_message_unref(m);
      break;
    }
    if (gst_app_sink_is_eos(GST_APP_SINK(out))) {
      // The last frame's mark: CPU and ticks read at EOS, right after it.
      if (times.size() >= 32)
        times.back().cpu = process_cpu_s(), times.back().machine = machine_ticks();
      break;
    }
  }
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(bus);
  gst_object_unref(req);
  gst_object_unref(out);
  gst_object_unref(p);
  if (!error.empty()) throw std::runtime_error("pipeline error: " + error);
  return times;
}

}  // namespace

int main(int argc, char** argv) {
  gchar *input = nullptr, *block = nullptr, *sizes_opt = nullptr, *encodings_opt = nullptr;
  gint frames = 300, rate = 30;
  gchar* viewers_opt = nullptr;
  gboolean skip_bound = FALSE;
  gchar* focal_opt = nullptr;
  gchar* backends_opt = nullptr;
  const GOptionEntry entries[] = {
      {"input", 0, 0, G_OPTION_ARG_STRING, &input,
       "Dataset folder or rig file (default ../shared/data/stanford-chess)", "PATH"},
      {"block", 0, 0, G_OPTION_ARG_STRING, &block,
       "Grid block of cameras (default 0,0,8,8: 64 cameras)", "R0,C0,ROWS,COLS"},
      {"sizes", 0, 0, G_OPTION_ARG_STRING, &sizes_opt, "Output sizes (default 640x480,320x240)",
       "WxH,..."},
      {"encodings", 0, 0, G_OPTION_ARG_STRING, &encodings_opt,
       "Fragment encodings: raw, jpegQ (default raw,jpeg90)", "ENC,..."},
      {"frames", 0, 0, G_OPTION_ARG_INT, &frames, "Requests per throughput run (default 300)", "N"},
      {"latency-rate", 0, 0, G_OPTION_ARG_INT, &rate,
       "Request rate of the live latency run, Hz (default 30)", "HZ"},
      {"viewers", 0, 0, G_OPTION_ARG_STRING, &viewers_opt,
       "Instead: several viewers sharing the cameras (lfcamerahost, one compositor per "
       "viewer, fragments routed by lffragmentdemux, and teed for comparison), non-live at "
       "the first size and encoding; frames per second per viewer and "
       "in all, and fragments per second",
       "N,..."},
      {"focal", 0, 0, G_OPTION_ARG_STRING, &focal_opt,
       "Focus of the single-viewer runs: plane (one focal plane, default) and/or surface:N "
       "(lfviewrequest focal-surface=true surface-interval=N: a focal surface estimated from "
       "the fragments every N requests), each optionally with more lfviewrequest properties "
       "after '+' signs, e.g. plane,surface:30,plane+ulr-cameras=4,plane+sampling=bicubic; "
       "each row is compared with the first plain plane row",
       "LIST"},
      {"backends", 0, 0, G_OPTION_ARG_STRING, &backends_opt,
       "Renderers of the single-viewer runs, raw fragments (JPEG rows: cpu only): cpu (default) "
       "and gl are lfarray's whole-view mode (the fragments only plan, on one request thread; "
       "the compositor draws them all, fused into its CPU compositing or with EGL/GLES); "
       "cpu-fragments and gl-fragments are whole-view=false (each lffragment draws its own, on "
       "lfarray's request-threads); each optionally with more lfarray properties after '+' "
       "signs, e.g. cpu-fragments+request-max-age=0; each row is compared with the cpu plane row",
       "LIST"},
      {"skip-bound", 0, 0, G_OPTION_ARG_NONE, &skip_bound,
       "Leave out the kernel bound and the pipeline efficiency", nullptr},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  // The plugin next to this program (build/gst) unless GST_PLUGIN_PATH says otherwise.
  if (!g_getenv("GST_PLUGIN_PATH")) {
    const auto exe = std::filesystem::read_symlink("/proc/self/exe");
    const auto dir = exe.parent_path().parent_path() / "gst";
    if (std::filesystem::exists(dir / "libgstlightfield.so"))
      g_setenv("GST_PLUGIN_PATH", dir.c_str(), TRUE);
  }
  GOptionContext* ctx = g_option_context_new(nullptr);
  g_option_context_set_summary(ctx, kSummary);
  g_option_context_add_main_entries(ctx, entries, nullptr);
  g_option_context_add_group(ctx, gst_init_get_option_group());
  GError* opt_err = nullptr;
  const gboolean parsed = g_option_context_parse(ctx, &argc, &argv, &opt_err);
  g_option_context_free(ctx);
  if (!parsed || argc > 1) {
    std::fprintf(stderr, "lf-gst-bench: error: %s (see --help)\n",
                 opt_err ? opt_err->message : "unexpected arguments");
    g_clear_error(&opt_err);
    return 2;
  }
  auto str = [](gchar* s, const char* def) {
    const std::string v = s ? s : def;
    g_free(s);
    return v;
  };
  const std::string input_path = str(input, "../shared/data/stanford-chess");
  const std::string block_spec = str(block, "");
  const std::string sizes_spec = str(sizes_opt, "640x480,320x240");
  const std::string encodings_spec = str(encodings_opt, "raw,jpeg90");
  const std::string viewers_spec = str(viewers_opt, "");
  const std::string focal_spec = str(focal_opt, "plane");
  const std::string backends_spec = str(backends_opt, "cpu");
  try {
    const lf::Rig rig =
        cli::select_cameras(lf::load_rig_or_dataset(input_path), block_spec, 0, 1.0, true);
    if (!rig.has_focal_param) g_focal_plane = "depth:" + std::to_string(40 * rig.typical_spacing());
    const std::string rig_path =
        (std::filesystem::temp_directory_path() / "lf-gst-bench-rig.json").string();
    lf::save_rig(rig, rig_path);
    if (frames < 2 || rate < 1) throw std::invalid_argument("--frames >= 2, --latency-rate >= 1");
    std::vector<std::pair<int, int>> sizes;
    std::vector<std::string> encodings;
    {
      std::stringstream ss(sizes_spec);
      std::string t;
      while (std::getline(ss, t, ',')) {
        int w, h;
        cli::parse_size(t, w, h);
        sizes.emplace_back(w, h);
      }
      std::stringstream es(encodings_spec);
      while (std::getline(es, t, ',')) encodings.push_back(t);
    }
    // Focus: surface 0 for the plane, N for surface:N; props: more
    // lfviewrequest properties ("name=value" words).
    struct Focus {
      int surface = 0;
      std::string props, label;
    };
    std::vector<Focus> focals;
    {
      std::stringstream fs(focal_spec);
      std::string t;
      while (std::getline(fs, t, ',')) {
        Focus f;
        std::stringstream ps(t);
        std::string kind, prop;
        std::getline(ps, kind, '+');
        while (std::getline(ps, prop, '+')) {
          if (prop.find('=') == std::string::npos ||
              prop.find_first_of(" !\"'") != std::string::npos)
            throw std::invalid_argument("--focal '" + t + "': '" + prop +
                                        "' is not a property=value of lfviewrequest");
          f.props += (f.props.empty() ? "" : " ") + prop;
        }
        const std::vector<double> n = kind.rfind("surface:", 0) == 0
                                          ? cli::parse_numbers(kind.substr(8), "--focal")
                                          : std::vector<double>{};
        if (kind == "plane")
          f.surface = 0;
        else if (n.size() == 1 && n[0] >= 1 && n[0] == std::floor(n[0]))
          f.surface = static_cast<int>(n[0]);
        else
          throw std::invalid_argument("--focal '" + t + "': use plane or surface:N (N >= 1)");
        f.label = f.surface ? "surface, a probe every " + std::to_string(f.surface) : "plane";
        if (!f.props.empty()) f.label += ", " + f.props;
        focals.push_back(f);
      }
    }
    std::vector<std::string> backends;
    {
      std::stringstream bs(backends_spec);
      std::string t;
      while (std::getline(bs, t, ',')) {
        backend_properties(t);  // throws for an unknown one
        backends.push_back(t);
      }
      if (std::find(backends.begin(), backends.end(), std::string("cpu")) == backends.end())
        backends.insert(backends.begin(), "cpu");  // the rows' reference
    }
    const int cores = static_cast<int>(std::thread::hardware_concurrency());
    // The kernel bound of a size, measured right before that size's
    // pipelines run (a shared machine's speed drifts: measured minutes
    // apart, the ratio would carry the drift; the camera images it needs
    // are freed before them, so each row's peak RSS is the pipeline's own),
    // and again right after each throughput run it divides: the row's
    // bound is the mean of the two, so a steady drift of the machine's
    // speed over the seconds of a run cancels (on the shared 2-core VM the
    // two differed by up to 13 %: 2.55 against 2.92 ms a view around one
    // 640x480 run). The pipeline's own run-to-run spread stays.
    // Each measurement: the faster of two passes over 40 views, since a
    // busy spell elsewhere on the machine only ever slows a pass down. Wall
    // clock (the bound as defined) and CPU time (for the CPU efficiency).
    std::map<std::pair<int, int>, std::vector<KernelTime>> measured;  // in order; back(): latest
    std::map<std::pair<int, int>, double> together;  // ms a view, on every core at once
    // ms a view with each view drawn band by band on every core
    // (cv::parallel_for_, as lfcompositor draws), and the fused single-core
    // ms of the same pass, measured just before: the split's own cost.
    std::map<std::pair<int, int>, std::pair<double, double>> split;
    int split_threads = 0;
    const bool any_raw = std::find(encodings.begin(), encodings.end(), "raw") != encodings.end();
    std::vector<int> jpeg_qualities;  // of the JPEG rows, for their bounds
    for (const std::string& e : encodings)
      if (const int q = jpeg_quality(e)) jpeg_qualities.push_back(q);
    const bool viewers_run = !viewers_spec.empty();
    auto measure_bound = [&](const std::pair<int, int>& sz) {
      if (skip_bound ||
          !(viewers_run ? encodings.front() == "raw" : any_raw || !jpeg_qualities.empty()))
        return;
      const bool first = !measured.count(sz);  // (every core at once: measured once a size)
      KernelTime b;
      // One core (images load in parallel first); OpenCV's default comes
      // back for the pipelines (lfcompositor composites in parallel).
      std::vector<cv::Mat> images = lf::load_images(rig);
      const int threads = cv::getNumThreads();
      cv::setNumThreads(1);
      lf::ViewSettings vs;
      vs.width = sz.first, vs.height = sz.second;
      vs.orbit = kOrbit, vs.path_frames = kPathFrames;
      for (int pass = 0; pass < 2; ++pass) {
        const KernelTime k = lfbench::kernel_ms(rig, images, vs, g_focal_plane, 40,
                                                viewers_run ? std::vector<int>{} : jpeg_qualities);
        if (pass)
          b.keep_faster(k);
        else
          b = k;
        if (!first) continue;
        const double t = lfbench::kernel_ms_together(rig, images, vs, g_focal_plane, 40, cores);
        together[sz] = pass && together[sz] > 0 ? std::min(together[sz], t) : t;
        cv::setNumThreads(threads);
        split_threads = cv::getNumThreads();
        const double v = lfbench::kernel_ms(rig, images, vs, g_focal_plane, 40, {}).fused_ms;
        cv::setNumThreads(1);
        if (!pass || v < split[sz].first) split[sz] = {v, k.fused_ms};
      }
      cv::setNumThreads(threads);
      // The images freed and the heap trimmed: glibc keeps what the
      // threads that decoded them freed, and the peak RSS of the pipelines
      // that follow would count it (a row's peak is reset to the RSS now).
      images.clear();
      malloc_trim(0);
      measured[sz].push_back(b);
      std::fprintf(stderr,
                   "Kernel bound at %dx%d, single-core ms per view (the library, the same "
                   "views): rendered then composited %.2f, fused %.2f; the bound takes the "
                   "faster.\n",
                   sz.first, sz.second, b.separate_ms, b.fused_ms);
      for (const auto& [q, t] : b.jpeg)
        std::fprintf(stderr,
                     "JPEG q%d bound at %dx%d: %.2f ms per view (rendered, coded, decoded, "
                     "composited): %.2f of the raw bound's throughput, the most a JPEG pipeline "
                     "can reach against a raw one.\n",
                     q, sz.first, sz.second, t.first, b.wall_ms / t.first);
    };
    if (viewers_run) measure_bound(sizes.front());
    if (viewers_run) {
      const auto [W, H] = sizes.front();
      const std::string& enc = encodings.front();
      const std::string fr = encoding_properties(enc);
      const bool has_bound = measured.count({W, H}) > 0;
      const double kb = has_bound ? cores * 1000.0 / measured[{W, H}].back().wall_ms : 0;
      std::printf(
          "## Viewers sharing %zu cameras, %dx%d, %s fragments, non-live, %d requests each "
          "(%d cores); fragments routed to each viewer's compositor by lffragmentdemux, "
          "and for comparison teed to every compositor\n\n| viewers | routing | fps per "
          "viewer | fps in all | kernel bound fps in all (%d cores / single-core time per "
          "view) | pipeline efficiency | fragments/s | time per frame vs the first row | peak "
          "RSS MiB |\n|---|---|---|---|---|---|---|---|---|\n",
          rig.cameras.size(), W, H, enc.c_str(), frames, cores, cores);
      double one[2] = {0, 0};  // frames per second in all of the first row, per routing
      for (const int v : cli::parse_numbers(viewers_spec, "--viewers"))
        for (const bool tee : {false, true}) {
          reset_peak_rss();
          const auto [n, secs] = lfbench::run_viewers(
              lfbench::viewers_pipeline(rig_path, W, H, fr, v, frames, tee), v);
          const double all = secs > 0 ? n / secs : 0;
          if (one[tee] == 0) one[tee] = all;
          std::printf(
              "| %d | %s | %.1f | %.1f | %s | %s | %.0f | %.2f | %.0f |\n", v,
              tee ? "tee" : "demux", all / v, all, has_bound ? cv::format("%.1f", kb).c_str() : "-",
              has_bound ? cv::format("%.2f", all / kb).c_str() : "-",
              all * static_cast<double>(rig.cameras.size()), one[tee] / all, peak_rss_mib());
          std::fflush(stdout);
        }
      return 0;
    }
    std::printf("## GStreamer pipeline, %zu cameras, one machine (%d cores)\n\n",
                rig.cameras.size(), cores);
    std::printf(
        "| output | encoding | focus | throughput fps (non-live, %d requests) | kernel bound fps "
        "(%d cores / single-core time) | pipeline efficiency | CPU ms per frame (process) | "
        "kernel CPU ms per frame (one core) | CPU efficiency | cores used | steal %% | live fps "
        "(%d requests/s) | latency median ms | latency p95 ms (live) | peak RSS MiB | vs the "
        "cpu plane row (throughput, live fps, CPU per frame, PSNR of frame 10) |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        frames, cores, rate);
    for (const auto& [W, H] : sizes) {
      measure_bound({W, H});
      for (const auto& enc : encodings) {
        // The plane row of this size and encoding (run before the surface
        // rows when --focal lists it first): fps, live fps, CPU ms per frame.
        double plane[3] = {0, 0, 0};
        cv::Mat plane_frame;  // its frame kCompareFrame
        for (const Focus& focus : focals)
          for (const std::string& backend : backends) {
            if (backend.substr(0, backend.find('+')) != "cpu" && enc != "raw") continue;
            const int surface = focus.surface;
            const bool baseline = surface == 0 && focus.props.empty() && backend == "cpu";
            reset_peak_rss();
            cv::Mat frame;
            const auto t = run(
                pipeline(rig_path, W, H, enc, false, frames, 1000, surface, focus.props, backend),
                nullptr, &frame, frames);
            // The bound again right after the run it divides (see `measured`).
            const int q = jpeg_quality(enc);
            const bool has_bound = !skip_bound && baseline && measured.count({W, H}) &&
                                   (!q || measured[{W, H}].back().jpeg.count(q));
            KernelTime k;
            double rss = peak_rss_mib();  // the pipelines' own, not the bound's images
            if (has_bound) {
              measure_bound({W, H});
              const std::vector<KernelTime>& m = measured[{W, H}];
              k = m[m.size() - 2].mean_with(m.back());  // before and after
              if (q) std::tie(k.wall_ms, k.cpu_ms) = k.jpeg.at(q);
              reset_peak_rss();
            }
            // From frame `warm` to kTail frames before the last (both with
            // the pipeline full), where there are enough; else to the last.
            const int warm = std::min<int>(20, static_cast<int>(t.size()) / 4);
            const size_t end =
                t.size() > static_cast<size_t>(warm) + kTail + 32 && t[t.size() - 1 - kTail].cpu > 0
                    ? t.size() - 1 - kTail
                    : t.size() - 1;
            const bool steady = t.size() > static_cast<size_t>(warm + 1);
            const Mark& a = steady ? t[warm] : Mark{};
            const Mark& z = steady ? t[end] : Mark{};
            const double frames_steady = steady ? static_cast<double>(end - warm) : 0;
            const double fps = steady ? frames_steady / (z.wall - a.wall) : 0;
            const double cpu_ms = steady ? (z.cpu - a.cpu) * 1000.0 / frames_steady : 0;
            const double cores_used = steady ? (z.cpu - a.cpu) / (z.wall - a.wall) : 0;
            const auto ticks = z.machine.total - a.machine.total;
            const double steal =
                ticks ? 100.0 * static_cast<double>(z.machine.steal - a.machine.steal) / ticks : 0;
            Probe probe;
            const auto live = run(pipeline(rig_path, W, H, enc, true, std::max(60, rate * 4), rate,
                                           surface, focus.props, backend),
                                  &probe);
            // Output frames per second of the live run, after its first quarter.
            const size_t lw = live.size() / 4;
            const double live_fps =
                live.size() > lw + 1
                    ? static_cast<double>(live.size() - 1 - lw) / (live.back().wall - live[lw].wall)
                    : 0;
            std::vector<double> lat(
                probe.latency_ms.begin() + std::min<size_t>(10, probe.latency_ms.size()),
                probe.latency_ms.end());
            // The bound is plan + render + composite of one plane; a JPEG
            // row's also encodes and decodes each fragment.
            const double kb = has_bound ? cores * 1000.0 / k.wall_ms : 0;
            auto num = [&](double v, const char* f) {
              return has_bound ? cv::format(f, v) : std::string("-");
            };
            if (baseline && plane[0] == 0)
              plane[0] = fps, plane[1] = live_fps, plane[2] = cpu_ms, plane_frame = frame;
            // PSNR over the colour channels (the 4th is padding or alpha).
            std::string psnr = "-";
            if (!plane_frame.empty() && frame.size() == plane_frame.size()) {
              cv::Mat a, b;
              cv::cvtColor(plane_frame, a, cv::COLOR_BGRA2BGR);
              cv::cvtColor(frame, b, cv::COLOR_BGRA2BGR);
              const double db = cv::PSNR(a, b);
              psnr = cv::format(db >= 99 ? "identical" : "%.1f dB", db);
            }
            const std::string vs =
                !baseline && plane[0] > 0 && plane[1] > 0 && plane[2] > 0
                    ? cv::format("%.2f, %.2f, %.2fx, %s", fps / plane[0], live_fps / plane[1],
                                 cpu_ms / plane[2], psnr.c_str())
                    : std::string("-");
            std::printf(
                "| %dx%d | %s | %s | %.1f | %s | %s | %.2f | %s | %s | %.2f | %.0f | %.1f | "
                "%.1f | %.1f | %.0f | %s |\n",
                W, H, (backend == "cpu" ? enc : enc + ", " + backend).c_str(), focus.label.c_str(),
                fps, num(kb, "%.1f").c_str(), num(fps / kb, "%.2f").c_str(), cpu_ms,
                num(k.cpu_ms, "%.2f").c_str(), num(k.cpu_ms / cpu_ms, "%.2f").c_str(), cores_used,
                steal, live_fps, percentile(lat, 0.5), percentile(lat, 0.95),
                std::max(rss, peak_rss_mib()), vs.c_str());
            std::fflush(stdout);
          }
      }
    }
    for (const auto& [sz, ks] : measured) {
      std::string raw, jpeg;
      for (const KernelTime& k : ks)
        raw += cv::format("%s%.2f", raw.empty() ? "" : ", ", k.wall_ms);
      for (const auto& [q, unused] : ks.front().jpeg) {
        jpeg += cv::format("; JPEG q%d", q);
        for (size_t i = 0; i < ks.size(); ++i)
          jpeg += cv::format("%s%.2f", i ? ", " : " ", ks[i].jpeg.at(q).first);
      }
      std::printf(
          "\nKernel bound at %dx%d, single-core ms per view, in the order measured (before the "
          "first row, then after each row with a bound; each row's bound is the mean of the "
          "measurements before and after it): raw %s%s.\n",
          sz.first, sz.second, raw.c_str(), jpeg.c_str());
    }
    for (const auto& [sz, ms] : together)  // against the size's first measurement
      if (ms > 0 && measured.count(sz))
        std::printf(
            "\nAll %d cores at once, %dx%d: the library's loop on %d threads together "
            "takes %.2f ms a view each, against %.2f on one core alone: %.2f of the "
            "kernel bound is the most a pipeline can reach on this machine.\n",
            cores, sz.first, sz.second, cores, ms, measured[sz].front().wall_ms,
            measured[sz].front().wall_ms / ms);
    for (const auto& [sz, m] : split)
      if (m.first > 0)
        std::printf(
            "\nOne view at a time on all %d cores, %dx%d (planned on one thread, then drawn "
            "band by band on all, as lfcompositor draws): %.2f ms a view, against %.2f on one "
            "core alone just before (fused): %.2f of the kernel bound, the most a pipeline that "
            "splits each view across the cores reaches on this machine.\n",
            split_threads, sz.first, sz.second, m.first, m.second,
            m.second / split_threads / m.first);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lf-gst-bench: error: %s\n", e.what());
    return 1;
  }
}
