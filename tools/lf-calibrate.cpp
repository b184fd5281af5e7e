// lf-calibrate: calibration of a camera array from a point light (Yang et
// al. 2002, 4.4.2): Zhang intrinsics of one camera (checkerboard images, or
// given), point-light tracks from a folder of frames or a video per camera,
// self-calibration with a Ceres bundle adjustment, grid topology; writes the
// rig file the renderer and the GStreamer elements read, and a report (text
// and PNG plots: residuals per camera, error histogram, camera layout).
// Degenerate data is reported and no rig is written (exit code 3).
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/colour.h"
#include "calib/intrinsics.h"
#include "calib/selfcal.h"
#include "calib/tracking.h"
#include "cli.h"
#include "lf/geometry/rig.h"
#include "lf/io/rig_file.h"

namespace fs = std::filesystem;

namespace {

const char* kHelp = R"(lf-calibrate: calibrate a camera array from point-light tracks -> rig file.

usage: lf-calibrate (--tracks DIR | --sources FILE) (--zhang DIR --square S | --zhang-intrinsics F,CX,CY,K1,K2)
                    [options] --out RIG.json
  --tracks DIR          one entry per camera, in name order: a folder of frames or a video
                        file; frame k of every camera is capture instant k (dark scene, one
                        moving point light)
  --sources FILE        instead of --tracks: one source per line: a folder, a video file, or
                        gst:PIPELINE (a live GStreamer source; frame k must be the same
                        capture instant in every source)
  --zhang DIR           checkerboard images of the Zhang camera (Zhang's method, OpenCV)
  --square S            checkerboard square size (any unit)
  --pattern CxR         inner corners (default: detected)
  --zhang-intrinsics F,CX,CY,K1,K2   the Zhang camera's intrinsics, already measured
  --zhang-camera K      which camera (index in --tracks order) the Zhang intrinsics belong to (0)
  --pitch P             median distance between grid neighbours in the output (default 1)
  --unit NAME           length unit written to the rig file (default "unit")
  --f-prior REL         sigma of each camera's f around the Zhang camera's, relative
                        (default 0.001; 0: one shared free f, accepted only if determined)
  --colour-samples CSV  colour calibration: lines "camera,r,g,b" (8-bit RGB of shared target
                        patches or scene points, in the same sample order for every camera);
                        corrections against the array median go into the rig file, cameras
                        with implausible corrections are flagged and left uncorrected
  --colour-images DIR   colour calibration from one image per camera (name order) of a shared
                        flat target or the common scene, at --colour-depth Z (rig units along
                        the Zhang camera's axis) or inf (a distant scene; default)
  --report DIR          report.txt, residuals.png, histogram.png, layout.png (default: next
                        to the rig file)
  --out FILE            the rig file
exit status: 0 rig written, 1 error, 3 degenerate data (reported, no rig written)
)";

void progress(int done, int total) {
  cli::progress("tracking", done, total);
}

void bar_plot(const std::string& file, const std::vector<double>& v, const std::string& title) {
  const int W = 900, H = 320, l = 50, b = 40;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
  double hi = 1e-9;
  for (double x : v) hi = std::max(hi, x);
  const double bw = (W - l - 10.0) / std::max<size_t>(1, v.size());
  for (size_t i = 0; i < v.size(); ++i) {
    const int h = static_cast<int>((H - b - 40) * v[i] / hi);
    cv::rectangle(img, {static_cast<int>(l + i * bw), H - b - h},
                  {static_cast<int>(l + (i + 1) * bw) - 1, H - b}, cv::Scalar(180, 119, 31),
                  cv::FILLED);
  }
  char t[64];
  std::snprintf(t, sizeof t, "%.3g", hi);
  cv::putText(img, t, {5, 45}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  cv::putText(img, "0", {30, H - b}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  cv::putText(img, title, {l, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  if (!cv::imwrite(file, img)) throw std::runtime_error("cannot write " + file);
}

void layout_plot(const std::string& file, const lf::Rig& rig) {
  const int S = 600, m = 60;
  cv::Mat img(S, S, CV_8UC3, cv::Scalar(255, 255, 255));
  double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
  for (const auto& c : rig.cameras)
    for (int j = 0; j < 2; ++j)
      lo[j] = std::min(lo[j], c.center()[j]), hi[j] = std::max(hi[j], c.center()[j]);
  const double span = std::max({hi[0] - lo[0], hi[1] - lo[1], 1e-9});
  for (const auto& c : rig.cameras) {
    const cv::Vec3d C = c.center(), F = c.forward();
    const cv::Point p(static_cast<int>(m + (S - 2 * m) * (C[0] - lo[0]) / span),
                      static_cast<int>(m + (S - 2 * m) * (C[1] - lo[1]) / span));
    // The optical axis' tilt, exaggerated 20x.
    cv::arrowedLine(
        img, p, p + cv::Point(static_cast<int>(20 * 20 * F[0]), static_cast<int>(20 * 20 * F[1])),
        cv::Scalar(40, 39, 214), 1, cv::LINE_AA);
    cv::circle(img, p, 4, cv::Scalar(180, 119, 31), cv::FILLED);
    cv::putText(img, std::to_string(c.id), p + cv::Point(5, -5), cv::FONT_HERSHEY_SIMPLEX, 0.35,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  cv::putText(img, "Camera centres (x right, y down; red: optical-axis tilt x20)", {10, 25},
              cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  if (!cv::imwrite(file, img)) throw std::runtime_error("cannot write " + file);
}

}  // namespace

int main(int argc, char** argv) {
  if (cli::help_requested(argc, argv, kHelp)) return 0;
  try {
    const cli::Args args(
        argc, argv,
        {"--tracks", "--sources", "--zhang", "--square", "--pattern", "--zhang-intrinsics",
         "--zhang-camera", "--pitch", "--unit", "--f-prior", "--report", "--out",
         "--colour-samples", "--colour-images", "--colour-depth"},
        {});
    if ((!args.has("--tracks") && !args.has("--sources")) || !args.has("--out"))
      throw std::invalid_argument("--tracks or --sources, and --out, are required (see --help)");
    std::vector<std::string> sources;
    if (args.has("--tracks")) {
      for (const auto& e : fs::directory_iterator(args.get("--tracks")))
        sources.push_back(e.path().string());
      std::sort(sources.begin(), sources.end());
    } else {
      std::ifstream in(args.get("--sources"));
      if (!in) throw std::runtime_error("cannot read --sources " + args.get("--sources"));
      for (std::string line; std::getline(in, line);)
        if (!line.empty() && line[0] != '#') sources.push_back(line);
    }
    if (sources.size() < 2) throw std::invalid_argument("fewer than 2 cameras (sources)");
    const std::string out = args.get("--out");
    const std::string report_dir =
        args.get("--report",
                 fs::path(out).parent_path().empty() ? "." : fs::path(out).parent_path().string());
    fs::create_directories(report_dir);
    std::ostringstream rep;

    // 1. Intrinsics of the Zhang camera.
    lf::Intrinsics zhang;
    if (args.has("--zhang")) {
      std::vector<std::string> files;
      for (const auto& e : fs::directory_iterator(args.get("--zhang")))
        files.push_back(e.path().string());
      std::sort(files.begin(), files.end());
      cv::Size pattern;
      if (args.has("--pattern"))
        cli::parse_size(args.get("--pattern"), pattern.width, pattern.height);
      const auto views = lf::calib::detect_chessboards(files, pattern);
      std::string why;
      const auto fit = lf::calib::choose_radial_model(views, args.number("--square", 1), &why);
      zhang.fx = fit.fx, zhang.fy = fit.fy, zhang.cx = fit.cx, zhang.cy = fit.cy;
      zhang.k1 = fit.k1, zhang.k2 = fit.k2;
      rep << "## Zhang intrinsics (" << views.used.size() << " views, pattern "
          << views.pattern.width << "x" << views.pattern.height << ")\n"
          << why << "\nfx " << fit.fx << " +- " << fit.sigma[0] << ", fy " << fit.fy << " +- "
          << fit.sigma[1] << ", cx " << fit.cx << " +- " << fit.sigma[2] << ", cy " << fit.cy
          << " +- " << fit.sigma[3] << ", k1 " << fit.k1 << ", k2 " << fit.k2 << ", RMS "
          << fit.rms_px << " px\n";
      if (fit.k3 != 0)
        rep << "note: the data supports k3 = " << fit.k3 << "; the rig model keeps k1, k2\n";
      for (const auto& r : views.rejected) rep << "rejected: " << r << "\n";
      zhang.fy = zhang.fx = 0.5 * (fit.fx + fit.fy);  // the rig model has one f
    } else if (args.has("--zhang-intrinsics")) {
      const auto v = args.numbers("--zhang-intrinsics", 5, 5);
      zhang.fx = zhang.fy = v[0], zhang.cx = v[1], zhang.cy = v[2], zhang.k1 = v[3],
      zhang.k2 = v[4];
      rep << "## Zhang intrinsics (given)\nf " << v[0] << ", c (" << v[1] << ", " << v[2]
          << "), k1 " << v[3] << ", k2 " << v[4] << "\n";
    } else {
      throw std::invalid_argument("give --zhang DIR --square S, or --zhang-intrinsics");
    }

    // 2. Point-light tracks.
    std::vector<lf::calib::TrackStats> stats;
    const auto obs = lf::calib::track_point_light(sources, &stats, {}, progress);
    rep << "\n## Tracking (" << obs.size()
        << " observations)\n| camera | source | frames | spot | "
           "no spot | several | streak/saturated |\n|---|---|---|---|---|---|---|\n";
    std::vector<lf::Camera> cams;
    for (size_t c = 0; c < sources.size(); ++c) {
      lf::Camera cam;
      cam.id = static_cast<int>(c);
      cam.name = fs::path(sources[c]).stem().string();
      cam.width = stats[c].image_size.width;
      cam.height = stats[c].image_size.height;
      cams.push_back(cam);
      rep << "| " << c << " | " << cam.name << " | " << stats[c].frames << " | " << stats[c].found
          << " | " << stats[c].none << " | " << stats[c].several << " | " << stats[c].streak
          << " |\n";
    }

    // 3-4. Structure and refinement.
    lf::calib::SelfCalOptions opt;
    opt.pitch = args.number("--pitch", 1);
    opt.f_prior = args.number("--f-prior", opt.f_prior);
    std::fprintf(stderr, "self-calibrating %zu cameras from %zu observations...\n", cams.size(),
                 obs.size());
    const auto r =
        lf::calib::self_calibrate(cams, args.integer("--zhang-camera", 0), zhang, obs, opt);
    rep << "\n## Self-calibration\n" << r.log;
    for (const auto& w : r.warnings) rep << "warning: " << w << "\n";
    if (r.degenerate) {
      std::ofstream(report_dir + "/report.txt") << rep.str();
      std::fprintf(stderr,
                   "lf-calibrate: degenerate data: %s\nno rig written; report: %s/report.txt\n",
                   r.degenerate_reason.c_str(), report_dir.c_str());
      return 3;
    }
    rep << "\n| camera | observations | RMS px | f px (sigma) | k1 (sigma) | k2 (sigma) | "
           "rotation sigma deg | centre (t sigma) |\n|---|---|---|---|---|---|---|---|\n";
    std::vector<double> cam_rms;
    for (const auto& c : r.rig.cameras) {
      const cv::Vec3d C = c.center(), sd = r.intrinsics_sigma[c.id];
      rep << "| " << c.id << " | " << r.camera_observations[c.id] << " | " << r.camera_rms_px[c.id]
          << " | " << c.intrinsics.fx << " (" << sd[0] << ") | " << c.intrinsics.k1 << " (" << sd[1]
          << ") | " << c.intrinsics.k2 << " (" << sd[2] << ") | " << r.rotation_sigma_deg[c.id]
          << " | " << C[0] << ", " << C[1] << ", " << C[2] << " (" << r.translation_sigma[c.id]
          << ") |\n";
      cam_rms.push_back(r.camera_rms_px[c.id]);
    }
    lf::Rig rig = r.rig;
    rig.unit = args.get("--unit", "unit");
    std::vector<std::vector<cv::Vec3d>> colour_samples;
    if (args.has("--colour-images")) {
      std::vector<std::string> files;
      for (const auto& e : fs::directory_iterator(args.get("--colour-images")))
        files.push_back(e.path().string());
      std::sort(files.begin(), files.end());
      if (files.size() != cams.size())
        throw std::invalid_argument("--colour-images: " + std::to_string(files.size()) +
                                    " images for " + std::to_string(cams.size()) + " cameras");
      std::vector<cv::Mat> images;
      for (const auto& f : files) {
        cv::Mat im = cv::imread(f, cv::IMREAD_COLOR);
        if (im.empty()) throw std::runtime_error("cannot read " + f);
        cv::cvtColor(im, im, cv::COLOR_BGR2RGB);
        images.push_back(im);
      }
      if (rig.cameras.size() != cams.size())
        throw std::runtime_error("--colour-images needs every camera calibrated");
      const std::string z = args.get("--colour-depth", "inf");
      const lf::FocalPlane plane =
          z == "inf" ? lf::FocalPlane::infinity()
                     : lf::FocalPlane::through({0, 0, cli::parse_numbers(z, "--colour-depth")[0]},
                                               {0, 0, 1});
      colour_samples = lf::calib::colour_samples_from_images(rig, images, plane,
                                                             args.integer("--zhang-camera", 0));
      rep << "\n"
          << colour_samples[0].size() << " colour samples from " << args.get("--colour-images")
          << "\n";
    }
    if (args.has("--colour-samples")) {
      std::ifstream in(args.get("--colour-samples"));
      if (!in) throw std::runtime_error("cannot read " + args.get("--colour-samples"));
      std::vector<std::vector<cv::Vec3d>> samples(cams.size());
      std::string line;
      int ln = 0;
      while (std::getline(in, line)) {
        ++ln;
        if (line.empty() || line[0] == '#') continue;
        const auto v = cli::parse_numbers(line, "colour sample line " + std::to_string(ln));
        if (v.size() != 4 || v[0] < 0 || v[0] >= cams.size())
          throw std::invalid_argument("--colour-samples line " + std::to_string(ln) +
                                      ": expected camera,r,g,b with a camera index < " +
                                      std::to_string(cams.size()));
        samples[static_cast<size_t>(v[0])].push_back({v[1], v[2], v[3]});
      }
      colour_samples = samples;
    }
    if (!colour_samples.empty()) {
      const auto col = lf::calib::calibrate_colours(colour_samples);
      rep << "\n## Colour (deltaE2000 against the array median)\n" << col.report;
      for (auto& cam : rig.cameras) {
        const auto& cc = col.cameras[static_cast<size_t>(cam.id)];
        if (cc.defective)
          std::fprintf(stderr,
                       "warning: camera %d: implausible colour correction (%s): left "
                       "uncorrected\n",
                       cam.id, cc.why.c_str());
        else
          cam.colour = cc.correction;
      }
    }
    lf::save_rig(rig, out);
    // Plots.
    std::vector<double> hist(30, 0);
    for (size_t i = 0; i < r.residual_px.size(); ++i)
      if (r.residual_px[i] >= 0)
        hist[std::min<size_t>(29, static_cast<size_t>(r.residual_px[i] / 0.1))] += 1;
    bar_plot(report_dir + "/residuals.png", cam_rms, "Reprojection RMS per camera (px)");
    bar_plot(report_dir + "/histogram.png", hist,
             "Reprojection error histogram, 0.1 px bins, 0..3 px (last bin: larger)");
    layout_plot(report_dir + "/layout.png", rig);
    std::ofstream(report_dir + "/report.txt") << rep.str();
    std::printf(
        "rig: %s (%zu cameras, %s)\nreprojection RMS %.3f px per coordinate; report: "
        "%s/report.txt\n",
        out.c_str(), rig.cameras.size(),
        rig.grid.empty()
            ? "no grid"
            : (std::to_string(rig.grid.rows) + "x" + std::to_string(rig.grid.cols) + " grid")
                  .c_str(),
        r.rms_px, report_dir.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lf-calibrate: error: %s\n", e.what());
    return 1;
  }
}
