// lf-trace: reads the event traces the elements write under LF_TRACE (see
// gst/lftrace.h for the format) on one or many hosts and prints
//  * output: requests issued and composited, complete and incomplete (a
//    partial sum counts its cameras), the longest gap between output
//    frames, a per-second timeline, the pixels per frame that no fragment
//    covered (taken from the frame before: filled-pixels-per-frame);
//  * bandwidth: fragment bytes entering the compositor per output frame
//    (the paper's Figure 6 quantity);
//  * latency: round trip (request issued by the viewer -> frame composited)
//    and its components (the paper's Figure 5): request broadcast, warp,
//    encode, network, decode, composite; per fragment and along each
//    request's critical path (its last fragment), median and 95th percentile;
//  * capture alignment: spread of the actual capture instants of one frame
//    number across all cameras, against the frame period;
//  * with --reference: composited frames compared (CRC-32 of the RGBA frame)
//    with another run's, e.g. the single-machine pipeline;
//  * with --rejoin-after T: how long after clock time T (e.g. a camera
//    host's restart, taken with --clock-now) the first complete frame left
//    the compositor, and how many of the frames after it were complete.
// All times come from the hosts' shared pipeline clock (tools/lf-launch).
// Ends with machine-readable "key value" lines after "## summary".
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "cli.h"

namespace {

const char* kHelp = R"(lf-trace: latency, bandwidth and output of a traced run (LF_TRACE files).

usage: lf-trace [options] TRACE...
  --cameras N        fragments in a complete request (default: the most seen)
  --fps F            capture rate, for the alignment check (default 15)
  --skip N           ignore the first N requests of each viewer (warm-up; default 3),
                     after those issued before every camera had captured (startup)
  --reference TRACE  compare composited frames (CRC-32) with this trace's
  --plot FILE        write the latency breakdown as a PNG
  --timeline         print output frames and fragments per second
  --rejoin-after NS  time from clock time NS (ns) to the first complete frame composited
                     after it (e.g. a restarted camera host's; summary: rejoin-ms, and
                     rejoin-complete-after: the share of later frames that were complete)

usage: lf-trace --clock-now
  prints this machine's monotonic clock in ns: the clock the hosts' pipelines share
  (GStreamer's system clock, served by the compositor host), for --rejoin-after

usage: lf-trace --bandwidth-plot FILE SERIES...
  writes the paper's Figure 6 as a PNG: bytes per output frame (log scale)
  against the number of cameras; SERIES is LABEL=CAMERAS:BYTES,CAMERAS:BYTES,...
)";

struct Event {
  std::string name;
  unsigned viewer = 0;
  uint64_t seq = 0;
  int camera = -1;
  int64_t t = 0, a = 0, b = 0, c = 0;
};

std::vector<Event> read_trace(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read trace '" + path + "'");
  std::vector<Event> ev;
  std::string line;
  size_t bad = 0;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    Event e;
    if (ss >> e.name >> e.viewer >> e.seq >> e.camera >> e.t >> e.a >> e.b >> e.c)
      ev.push_back(e);
    else if (!line.empty())
      ++bad;  // a host killed mid-line
  }
  if (bad) std::fprintf(stderr, "warning: %s: %zu malformed lines skipped\n", path.c_str(), bad);
  return ev;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  const double f = pos - i;
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

struct Fragment {
  int64_t request_in = -1, warped = -1, encoded = -1, arrived = -1;
  int64_t bytes = 0, capture = -1, decode_ns = -1, decoded = -1;
};
struct Request {
  int64_t issued = -1, composited = -1, composite_ns = 0;
  int64_t filled = 0;  // pixels the compositor took from the last frame (no weight came)
  int fragments = 0;
  uint32_t crc = 0;
  std::map<int, Fragment> cams;
};
using Key = std::pair<unsigned, uint64_t>;

std::map<Key, Request> collect(const std::vector<Event>& events) {
  std::map<Key, Request> req;
  for (const Event& e : events) {
    if (e.name == "capture") continue;
    Request& r = req[{e.viewer, e.seq}];
    if (e.name == "issue") {
      r.issued = e.t;
    } else if (e.name == "composited") {
      r.composited = e.t;
      r.fragments = static_cast<int>(e.a);
      r.crc = static_cast<uint32_t>(e.b);
      r.composite_ns = e.c;
    } else if (e.name == "filled") {
      r.filled = e.a;
    } else if (e.camera >= 0) {
      Fragment& f = r.cams[e.camera];
      if (e.name == "request-in") f.request_in = e.t;
      if (e.name == "warped") f.warped = e.t;
      if (e.name == "encoded") f.encoded = e.t;
      if (e.name == "fragment-in") f.arrived = e.t, f.bytes = e.a, f.capture = e.b;
      if (e.name == "decoded") f.decode_ns = e.a, f.decoded = e.t;
    }
  }
  return req;
}

// Grouped bars, log-scale bytes, one group per camera count.
void bandwidth_plot(const std::string& file, const std::vector<std::string>& series) {
  std::vector<std::string> labels;
  std::map<int, std::map<int, double>> value;  // cameras -> series -> bytes
  for (size_t i = 0; i < series.size(); ++i) {
    const auto eq = series[i].find('=');
    if (eq == std::string::npos)
      throw std::invalid_argument("series '" + series[i] + "' has no '='");
    labels.push_back(series[i].substr(0, eq));
    std::stringstream ss(series[i].substr(eq + 1));
    std::string item;
    while (std::getline(ss, item, ',')) {
      const auto colon = item.find(':');
      if (colon == std::string::npos) throw std::invalid_argument("bad item '" + item + "'");
      value[std::stoi(item.substr(0, colon))][static_cast<int>(i)] =
          std::stod(item.substr(colon + 1));
    }
  }
  double lo = 1e300, hi = 0;
  for (const auto& [n, m] : value)
    for (const auto& [i, v] : m) lo = std::min(lo, v), hi = std::max(hi, v);
  if (!(hi > 0)) throw std::invalid_argument("nothing to plot");
  const double l0 = std::floor(std::log10(std::max(lo * 0.5, 1.0))), l1 = std::ceil(std::log10(hi));
  const int W = 760, H = 420, left = 80, right = 20, top = 50, bottom = 70;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
  auto ypix = [&](double v) {
    return top + (H - top - bottom) * (1 - (std::log10(v) - l0) / std::max(l1 - l0, 1.0));
  };
  for (double e = l0; e <= l1; ++e) {
    const int y = static_cast<int>(ypix(std::pow(10, e)));
    cv::line(img, {left, y}, {W - right, y}, cv::Scalar(220, 220, 220));
    char t[32];
    std::snprintf(t, sizeof t, "1e%d B", static_cast<int>(e));
    cv::putText(img, t, {8, y + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
  }
  const cv::Scalar colours[] = {{180, 119, 31}, {14, 127, 255}, {40, 39, 214}, {44, 160, 44}};
  const int groups = static_cast<int>(value.size()), nser = static_cast<int>(labels.size());
  const double gw = (W - left - right) / static_cast<double>(std::max(groups, 1));
  int g = 0;
  for (const auto& [n, m] : value) {
    const double bw = gw * 0.8 / nser;
    for (const auto& [i, v] : m) {
      const int x = static_cast<int>(left + g * gw + gw * 0.1 + i * bw);
      cv::rectangle(img, {x, static_cast<int>(ypix(v))}, {static_cast<int>(x + bw - 3), H - bottom},
                    colours[i % 4], cv::FILLED);
    }
    cv::putText(img, std::to_string(n) + " cameras",
                {static_cast<int>(left + g * gw + gw * 0.3), H - bottom + 22},
                cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    ++g;
  }
  for (int i = 0; i < nser; ++i)
    cv::putText(img, labels[i], {left + 10 + i * 220, H - 15}, cv::FONT_HERSHEY_SIMPLEX, 0.5,
                colours[i % 4], 1, cv::LINE_AA);
  cv::putText(img, "Bytes entering the compositor per output frame (Figure 6)", {left, 30},
              cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  if (!cv::imwrite(file, img)) throw std::runtime_error("cannot write " + file);
  std::printf("plot: %s\n", file.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  if (cli::help_requested(argc, argv, kHelp)) return 0;
  if (argc == 2 && std::string(argv[1]) == "--clock-now") {
    // CLOCK_MONOTONIC (libstdc++'s steady_clock), as GstSystemClock's
    // default GST_CLOCK_TYPE_MONOTONIC.
    std::printf("%lld\n",
                static_cast<long long>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                           std::chrono::steady_clock::now().time_since_epoch())
                                           .count()));
    return 0;
  }
  if (argc >= 3 && std::string(argv[1]) == "--bandwidth-plot") {
    try {
      bandwidth_plot(argv[2], std::vector<std::string>(argv + 3, argv + argc));
      return 0;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "lf-trace: error: %s\n", e.what());
      return 1;
    }
  }
  try {
    std::vector<std::string> files;
    std::vector<char*> opt_argv{argv[0]};
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a.rfind("--", 0) == 0) {
        opt_argv.push_back(argv[i]);
        if (a != "--timeline" && i + 1 < argc) opt_argv.push_back(argv[++i]);
      } else {
        files.push_back(a);
      }
    }
    const cli::Args args(
        static_cast<int>(opt_argv.size()), opt_argv.data(),
        {"--cameras", "--fps", "--skip", "--reference", "--plot", "--rejoin-after"},
        {"--timeline"});
    if (files.empty()) throw std::invalid_argument("no trace files (see --help)");
    std::vector<Event> events;
    for (const auto& f : files) {
      auto e = read_trace(f);
      events.insert(events.end(), e.begin(), e.end());
    }
    std::map<Key, Request> req = collect(events);
    const int skip = args.integer("--skip", 3);
    // Startup: requests issued before every camera had captured its first
    // frame cannot have all fragments (hosts start at their own pace), so
    // they are left out like the first --skip ones.
    std::map<int, int64_t> first_capture;
    for (const Event& e : events)
      if (e.name == "capture" && e.camera >= 0) {
        auto [it, fresh] = first_capture.emplace(e.camera, e.t);
        if (!fresh) it->second = std::min(it->second, e.t);
      }
    int64_t all_up = INT64_MIN;
    for (const auto& [c, t] : first_capture) all_up = std::max(all_up, t);
    size_t startup = 0;
    for (auto it = req.begin(); it != req.end();)
      if (it->second.issued >= 0 && it->second.issued < all_up)
        it = req.erase(it), ++startup;
      else
        ++it;
    {
      std::map<unsigned, uint64_t> first;
      for (const auto& [k, r] : req)
        if (r.issued >= 0 && (!first.count(k.first) || k.second < first[k.first]))
          first[k.first] = k.second;
      for (auto it = req.begin(); it != req.end();) {
        const auto f = first.find(it->first.first);
        if (f != first.end() && it->first.second < f->second + skip)
          it = req.erase(it);
        else
          ++it;
      }
    }
    int most = 0;
    for (const auto& [k, r] : req) most = std::max(most, r.fragments);
    const int expected = args.integer("--cameras", most);

    // ---- output -----------------------------------------------------------
    size_t issued = 0, composited = 0, complete = 0;
    double filled = 0;
    std::vector<int64_t> out_times;
    for (const auto& [k, r] : req) {
      if (r.issued >= 0) ++issued;
      if (r.composited >= 0) {
        ++composited;
        filled += static_cast<double>(r.filled);
        out_times.push_back(r.composited);
        if (r.fragments >= expected) ++complete;
      }
    }
    std::sort(out_times.begin(), out_times.end());
    double max_gap = 0;
    for (size_t i = 1; i < out_times.size(); ++i)
      max_gap = std::max(max_gap, (out_times[i] - out_times[i - 1]) / 1e6);
    std::printf(
        "## Output\n\n| requests issued | composited | complete (%d fragments) | "
        "incomplete | longest gap between frames (ms) |\n|---|---|---|---|---|\n",
        expected);
    std::printf("| %zu | %zu | %zu | %zu | %.1f |\n", issued, composited, complete,
                composited - complete, max_gap);
    std::printf(
        "\nLeft out: %zu requests issued before all %zu cameras had captured (startup), then "
        "the first %d.\n",
        startup, first_capture.size(), skip);

    if (args.has("--timeline") && !out_times.empty()) {
      std::printf("\n| second | frames | mean fragments per frame |\n|---|---|---|\n");
      std::map<int64_t, std::pair<int, int>> per_s;
      for (const auto& [k, r] : req)
        if (r.composited >= 0) {
          auto& p = per_s[(r.composited - out_times.front()) / 1000000000];
          p.first++;
          p.second += r.fragments;
        }
      for (const auto& [s, p] : per_s)
        std::printf("| %lld | %d | %.1f |\n", static_cast<long long>(s), p.first,
                    static_cast<double>(p.second) / p.first);
    }

    // ---- bandwidth --------------------------------------------------------
    // Bytes entering the compositor, and bytes in the frame: the fragments
    // it took (decoded) before it composited the request; one that came
    // after the deadline entered but was not composited.
    std::vector<double> bytes_per_frame;
    double composited_bytes = 0;
    for (const auto& [k, r] : req) {
      if (r.composited < 0) continue;
      double b = 0;
      for (const auto& [c, f] : r.cams) {
        b += f.bytes;
        if (f.decoded >= 0 && f.decoded <= r.composited) composited_bytes += f.bytes;
      }
      bytes_per_frame.push_back(b);
    }
    if (!bytes_per_frame.empty()) composited_bytes /= bytes_per_frame.size();
    double mean_bytes = 0;
    for (double b : bytes_per_frame) mean_bytes += b;
    if (!bytes_per_frame.empty()) mean_bytes /= bytes_per_frame.size();
    std::printf(
        "\n## Bandwidth\n\nfragment bytes entering the compositor per output frame: "
        "mean %.0f, median %.0f (%zu frames)\n",
        mean_bytes, quantile(bytes_per_frame, 0.5), bytes_per_frame.size());

    // ---- latency ----------------------------------------------------------
    std::vector<double> rt, bc, wp, en, nw, dc, cp;      // per fragment / request
    std::vector<double> c_bc, c_wp, c_en, c_nw, c_rest;  // critical path
    for (const auto& [k, r] : req) {
      if (r.issued < 0 || r.composited < 0) continue;
      rt.push_back((r.composited - r.issued) / 1e6);
      cp.push_back(r.composite_ns / 1e6);
      const Fragment* last = nullptr;
      for (const auto& [c, f] : r.cams) {
        if (f.bytes <= 56) continue;  // empty fragment (header only)
        if (f.request_in >= 0) bc.push_back((f.request_in - r.issued) / 1e6);
        if (f.warped >= 0 && f.request_in >= 0) wp.push_back((f.warped - f.request_in) / 1e6);
        if (f.encoded >= 0 && f.warped >= 0) en.push_back((f.encoded - f.warped) / 1e6);
        if (f.arrived >= 0 && f.encoded >= 0) nw.push_back((f.arrived - f.encoded) / 1e6);
        if (f.decode_ns >= 0) dc.push_back(f.decode_ns / 1e6);
        if (f.arrived >= 0 && f.encoded >= 0 && f.warped >= 0 && f.request_in >= 0 &&
            f.arrived <= r.composited && (!last || f.arrived > last->arrived))
          last = &f;
      }
      if (last) {
        c_bc.push_back((last->request_in - r.issued) / 1e6);
        c_wp.push_back((last->warped - last->request_in) / 1e6);
        c_en.push_back((last->encoded - last->warped) / 1e6);
        c_nw.push_back((last->arrived - last->encoded) / 1e6);
        c_rest.push_back((r.composited - last->arrived) / 1e6);
      }
    }
    std::printf(
        "\n## Latency (ms; shared clock; components over non-empty fragments)\n\n"
        "| component | median | p95 | samples |\n|---|---|---|---|\n");
    auto row = [](const char* name, const std::vector<double>& v) {
      std::printf("| %s | %.2f | %.2f | %zu |\n", name, quantile(v, 0.5), quantile(v, 0.95),
                  v.size());
    };
    row("request broadcast (viewer -> camera host)", bc);
    row("warp (incl. waiting for the warper)", wp);
    row("encode (serialize, JPEG)", en);
    row("network (camera host -> compositor pad)", nw);
    row("decode (parse, JPEG)", dc);
    row("composite (add + resolve + convert)", cp);
    row("**round trip** (issued -> composited)", rt);
    std::printf(
        "\nCritical path (each request's last fragment to arrive; sums to the round "
        "trip):\n\n| component | median | p95 |\n|---|---|---|\n");
    const std::vector<std::pair<const char*, const std::vector<double>*>> crit = {
        {"broadcast", &c_bc},
        {"warp", &c_wp},
        {"encode", &c_en},
        {"network", &c_nw},
        {"compositor (decode, wait, composite)", &c_rest}};
    for (const auto& [n, v] : crit)
      std::printf("| %s | %.2f | %.2f |\n", n, quantile(*v, 0.5), quantile(*v, 0.95));

    // ---- capture alignment --------------------------------------------------
    const double fps = args.number("--fps", 15);
    std::map<uint64_t, std::pair<int64_t, int64_t>> capture;  // frame -> min, max clock
    std::map<uint64_t, int> capture_n;
    for (const Event& e : events) {
      if (e.name != "capture") continue;
      auto it = capture.find(e.seq);
      if (it == capture.end())
        capture[e.seq] = {e.t, e.t};
      else
        it->second = {std::min(it->second.first, e.t), std::max(it->second.second, e.t)};
      capture_n[e.seq]++;
    }
    std::vector<double> spread;
    int most_cams = 0;
    for (const auto& [k, n] : capture_n) most_cams = std::max(most_cams, n);
    for (const auto& [k, mm] : capture)
      if (capture_n[k] == most_cams && most_cams > 1)
        spread.push_back((mm.second - mm.first) / 1e6);
    // Per request: capture times (scheduled) of the frames its fragments used.
    std::vector<double> used_spread;
    for (const auto& [k, r] : req) {
      int64_t lo = INT64_MAX, hi = INT64_MIN;
      if (r.composited < 0) continue;
      for (const auto& [c, f] : r.cams)  // the fragments that made it into the frame
        if (f.capture >= 0 && f.arrived <= r.composited)
          lo = std::min(lo, f.capture), hi = std::max(hi, f.capture);
      if (hi >= lo) used_spread.push_back((hi - lo) / 1e6);
    }
    const double period = 1000.0 / fps;
    std::printf("\n## Capture alignment (frame period %.1f ms)\n\n", period);
    std::printf(
        "actual capture instants of one frame across %d cameras: median spread %.2f ms, "
        "max %.2f ms (%zu frames)\n",
        most_cams, quantile(spread, 0.5), spread.empty() ? 0 : quantile(spread, 1), spread.size());
    std::printf("frames used by one request's fragments: max capture-time spread %.1f ms\n",
                used_spread.empty() ? 0 : quantile(used_spread, 1));

    // ---- comparison -----------------------------------------------------------
    size_t compared = 0, identical = 0;
    if (args.has("--reference")) {
      const std::map<Key, Request> ref = collect(read_trace(args.get("--reference")));
      for (const auto& [k, r] : req) {
        if (r.composited < 0 || r.fragments < expected) continue;
        const auto it = ref.find(k);
        if (it == ref.end() || it->second.composited < 0) continue;
        ++compared;
        if (it->second.crc == r.crc) ++identical;
      }
      std::printf("\n## Comparison with %s\n\ncomplete frames compared %zu, identical %zu\n",
                  args.get("--reference").c_str(), compared, identical);
    }

    if (args.has("--plot")) {
      // Stacked bar of the critical path's median components.
      const int W = 900, H = 260, x0 = 20, bar_y = 90, bar_h = 60;
      cv::Mat img(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
      double total = 0;
      for (const auto& [n, v] : crit) total += quantile(*v, 0.5);
      const cv::Scalar colours[] = {
          {180, 119, 31}, {14, 127, 255}, {44, 160, 44}, {40, 39, 214}, {189, 103, 148}};
      double x = x0;
      const double scale = (W - 2.0 * x0) / std::max(total, 1e-9);
      for (size_t i = 0; i < crit.size(); ++i) {
        const double w = quantile(*crit[i].second, 0.5) * scale;
        cv::rectangle(img, cv::Point(int(x), bar_y), cv::Point(int(x + w), bar_y + bar_h),
                      colours[i], cv::FILLED);
        char label[96];
        std::snprintf(label, sizeof label, "%s %.1f", crit[i].first,
                      quantile(*crit[i].second, 0.5));
        cv::putText(img, label,
                    cv::Point(x0 + int(i % 3) * 290, bar_y + bar_h + 35 + int(i / 3) * 25),
                    cv::FONT_HERSHEY_SIMPLEX, 0.5, colours[i], 1, cv::LINE_AA);
        x += w;
      }
      char title[160];
      std::snprintf(title, sizeof title,
                    "Round trip, critical path medians (ms): total %.1f, measured median %.1f, "
                    "p95 %.1f",
                    total, quantile(rt, 0.5), quantile(rt, 0.95));
      cv::putText(img, title, cv::Point(x0, 50), cv::FONT_HERSHEY_SIMPLEX, 0.55,
                  cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
      if (!cv::imwrite(args.get("--plot"), img))
        throw std::runtime_error("cannot write " + args.get("--plot"));
      std::printf("\nplot: %s\n", args.get("--plot").c_str());
    }

    std::printf("\n## summary\n");
    std::printf("issued %zu\ncomposited %zu\ncomplete %zu\nexpected-fragments %d\n", issued,
                composited, complete, expected);
    std::printf("startup-left-out %zu\n", startup);
    std::printf("max-gap-ms %.2f\nbytes-per-frame %.0f\n", max_gap, mean_bytes);
    std::printf("composited-bytes-per-frame %.0f\n", composited_bytes);
    std::printf("filled-pixels-per-frame %.0f\n", composited ? filled / composited : 0.0);
    std::printf("round-trip-median-ms %.2f\nround-trip-p95-ms %.2f\n", quantile(rt, 0.5),
                quantile(rt, 0.95));
    std::printf("capture-spread-max-ms %.3f\ncapture-spread-p95-ms %.3f\nperiod-ms %.3f\n",
                spread.empty() ? -1.0 : quantile(spread, 1),
                spread.empty() ? -1.0 : quantile(spread, 0.95), period);
    std::printf("used-capture-spread-max-ms %.3f\n",
                used_spread.empty() ? -1.0 : quantile(used_spread, 1));
    // Output frames in the order they were composited: (time, fragments).
    std::vector<std::pair<int64_t, int>> by_time;
    for (const auto& [k, r] : req)
      if (r.composited >= 0) by_time.push_back({r.composited, r.fragments});
    std::sort(by_time.begin(), by_time.end());
    {
      // Fragments per output frame: how many frames had each count, and how
      // many of the last 15 frames were complete.
      std::map<int, int> hist;
      for (const auto& [t, n] : by_time) hist[n]++;
      int last_complete = 0;
      for (size_t i = by_time.size() > 15 ? by_time.size() - 15 : 0; i < by_time.size(); ++i)
        last_complete += by_time[i].second >= expected;
      std::printf("fragments-per-frame");
      for (const auto& [n, c] : hist) std::printf(" %d:%d", n, c);
      std::printf("\nlast-15-complete %d\n", last_complete);
    }
    if (args.has("--reference")) std::printf("compared %zu\nidentical %zu\n", compared, identical);
    if (args.has("--rejoin-after")) {
      // The first complete frame composited after T, and the frames after it.
      const int64_t t0 = std::stoll(args.get("--rejoin-after"));
      size_t first =
          std::lower_bound(by_time.begin(), by_time.end(), std::make_pair(t0, 0)) - by_time.begin();
      while (first < by_time.size() && by_time[first].second < expected) ++first;
      int later_complete = 0;
      for (size_t i = first; i < by_time.size(); ++i)
        later_complete += by_time[i].second >= expected;
      const bool found = first < by_time.size();
      std::printf("rejoin-ms %.1f\nrejoin-complete-after %.3f\n",
                  found ? (by_time[first].first - t0) / 1e6 : -1.0,
                  found ? later_complete / double(by_time.size() - first) : 0.0);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lf-trace: error: %s\n", e.what());
    return 1;
  }
}
