// lf-bench: speed against error for the light field renderer.
//  1. Leave-one-out quality (PSNR, SSIM) and time per frame over a grid of
//     settings (output size, encoding, focal-plane choice), including the
//     best single plane of an exhaustive sweep (an oracle that sees the
//     held-out image) and auto-focus (which does not); on an HCI folder,
//     the focal surface's disparity error against the ground truth.
//  2. Bandwidth: fragment pixels and bytes per output frame for 4, 16, 64
//     cameras spread over the array and a synthetic 256-camera rig.
//  3. Speed ratios measured side by side on one core: our fragments vs
//     OpenCV's warpPerspective for the same number of output pixels, and vs
//     the naive approach (warp every camera to the full frame, then blend).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bench/speed.h"
#include "cli.h"
#include "lf/focus/focal_surface.h"
#include "lf/geometry/rig_ops.h"
#include "lf/io/datasets.h"
#include "lf/io/rig_file.h"
#include "lf/quality/synthetic.h"
#include "lf/wire/wire.h"
#include "measure.h"

namespace {

const char* kHelp =
    R"(lf-bench: speed against error (leave-one-out quality, bandwidth, speed ratios).

usage: lf-bench [options]
  --input PATH        dataset folder or rig file (default ../shared/data/stanford-chess)
  --block R0,C0,R,C   grid block to use (default 0,0,8,8 when the grid is that large)
  --input-scale S     resize camera images first (default 1)
  --sizes LIST        output sizes, e.g. 320x240,640x480 (default)
  --encodings LIST    none (in-process), raw (wire format), jpegQ (e.g. jpeg90);
                      default none,jpeg90
  --focal LIST        focal choices: auto, best (exhaustive sweep against the held-out
                      image: an oracle), surface (a focal plane per 16-pixel tile
                      estimated from the images, lf/focus/focal_surface.h), surface2 (the
                      same with a second plane in tiles next to a depth edge or
                      with a thin structure inside, chosen per pixel by the compositor:
                      lf-render's and lfcompositor's default), infinity,
                      depth:Z, param:A (default auto,best,surface)
  --apertures LIST    aperture scales to add to each focal choice (lib/lf/geometry/view.h
                      Aperture: 1 is the paper's tent, 2 twice as wide, ...;
                      ulrK: Unstructured Lumigraph weights over K cameras;
                      four: four-camera weights over a grid cell;
                      default 1): PSNR, time and fragment bytes of each
  --samplings LIST    sampling filters to add to each focal choice: bilinear
                      (default), bicubic (lib/lf/geometry/view.h Sampling)
  --loo N             number of held-out cameras, spread over the block's interior (12)
  --hold-out MODE     one: each held-out view rendered from all the other cameras
                      (default); subgrid: from the sub-grid of every other row and
                      column only (the in-between views of a sparser rig; the
                      held-out cameras are those inside it that it leaves out)
  --sweep-steps N     planes in the exhaustive sweep (default 96)
  --sub-steps N       surface depths between the fine planes, in 1/N steps
                      (lf/focus/focal_surface.h SurfaceOptions::sub_steps; default 1)
  --plot FILE         write a PNG plot (default lf-bench.png)
  --skip-quality, --skip-bandwidth, --skip-speed   leave out a section
  --backend LIST      renderers to time side by side on whole views from all the
                      cameras, at each size of --sizes: cpu, gl (EGL/GLES 3,
                      lib/lf/render/gl_render.h), auto; e.g. cpu,gl adds that table
                      (default cpu: no table)
On an HCI benchmark folder (gt_disp_lowres.pfm) the quality section ends with
the focal surface's per-tile disparity error against the ground truth.
All timings run on one core (OpenCV single-threaded too) except the backend
table's, where the CPU renders cameras on every core and GL uses what its driver
uses (Mesa's llvmpipe: a thread per core); times are medians.
)";

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}
using measure::mean;
using measure::median;

struct Encoding {
  std::string name;
  bool wire = false;
  lf::Encoding enc = lf::Encoding::kRaw;
  int quality = 90;
};

Encoding parse_encoding(const std::string& s) {
  Encoding e;
  e.name = s;
  if (s == "none") return e;
  e.wire = true;
  if (s == "raw") return e;
  if (s.rfind("jpeg", 0) == 0) {
    e.enc = lf::Encoding::kJpeg;
    e.quality = static_cast<int>(cli::parse_numbers(s.substr(4), "jpeg quality")[0]);
    if (e.quality < 1 || e.quality > 100) throw std::invalid_argument("jpeg quality 1..100");
    return e;
  }
  throw std::invalid_argument("encoding '" + s + "': use none, raw or jpegQ");
}

struct FrameResult {
  cv::Mat image;
  double ms = 0;
  size_t fragment_pixels = 0;
  size_t bytes = 0;
};

// One output frame through the finite-viewpoints pipeline in-process:
// plan + render every fragment, optionally through the wire format, composite.
FrameResult render_frame(const lf::Rig& rig, const std::vector<cv::Mat>& images,
                         const lf::ViewRequest& req, const Encoding& e) {
  FrameResult r;
  const auto t0 = Clock::now();
  const lf::ViewGeometry g(rig, req);
  // Layer 1: the second planes of a surface's two-plane tiles (lf/render/plan.h).
  const int layers = req.surface.two_planes() ? 2 : 1;
  lf::Compositor comp;  // one layer: the paper's compositor
  if (layers == 1) comp.reset(req.view.width, req.view.height);
  std::vector<lf::Fragment> kept;  // two layers: composited at the end
  kept.reserve(rig.cameras.size() * 2);
  auto add = [&](lf::Fragment&& frag) {
    if (layers == 1)
      comp.add(frag);
    else
      kept.push_back(std::move(frag));
  };
  lf::Fragment f;
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    std::array<lf::FragmentPlan, 2> plans;
    if (layers == 1)
      plans[0] = lf::plan_fragment(g, static_cast<int>(i));
    else
      plans = lf::plan_fragment_layers(g, static_cast<int>(i));
    for (int layer = 0; layer < layers; ++layer) {
      lf::render_fragment(plans[layer], rig.cameras[i], images[i], f);
      r.fragment_pixels += f.pixel_count();
      if (e.wire) {
        const auto bytes = lf::serialize_fragment(f, e.enc, e.quality);
        r.bytes += bytes.size();
        add(lf::parse_fragment(bytes.data(), bytes.size()));
      } else {
        add(lf::Fragment(f));
      }
    }
  }
  if (layers == 1) {
    comp.resolve(r.image);
  } else {
    std::vector<lf::FragmentPixels> px;
    for (const lf::Fragment& k : kept) px.push_back({&k, k.pixels.data()});
    lf::LayerCompositor().composite(req.view.width, req.view.height, px, r.image);
  }
  r.ms = ms_since(t0);
  return r;
}

// ---------------------------------------------------------------------------
// Plot helpers (OpenCV drawing).
struct Axes {
  cv::Mat img;
  cv::Rect area;
  double x0, x1, y0, y1;
  cv::Point at(double x, double y) const {
    return {area.x + static_cast<int>((x - x0) / (x1 - x0) * area.width),
            area.y + area.height - static_cast<int>((y - y0) / (y1 - y0) * area.height)};
  }
};
Axes axes(cv::Mat& canvas, cv::Rect area, double x0, double x1, double y0, double y1,
          const std::string& title, const std::string& xl, const std::string& yl) {
  Axes a{canvas, area, x0, x1, y0, y1};
  cv::rectangle(canvas, area, cv::Scalar(0, 0, 0), 1);
  for (int k = 0; k <= 4; ++k) {
    const double xv = x0 + (x1 - x0) * k / 4, yv = y0 + (y1 - y0) * k / 4;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", xv);
    cv::putText(canvas, buf, a.at(xv, y0) + cv::Point(-12, 18), cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0));
    std::snprintf(buf, sizeof buf, "%.3g", yv);
    cv::putText(canvas, buf, a.at(x0, yv) + cv::Point(-45, 4), cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0));
    cv::line(canvas, a.at(x0, yv), a.at(x1, yv), cv::Scalar(220, 220, 220));
  }
  cv::putText(canvas, title, {area.x, area.y - 10}, cv::FONT_HERSHEY_SIMPLEX, 0.5,
              cv::Scalar(0, 0, 0), 1);
  cv::putText(canvas, xl, {area.x + area.width / 2 - 60, area.y + area.height + 36},
              cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0));
  cv::putText(canvas, yl, {area.x - 60, area.y - 24}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
              cv::Scalar(0, 0, 0));
  return a;
}

// The focal surface against a ground-truth disparity map (HCI benchmark
// folders: gt_disp_lowres.pfm, the centre camera's, lf/io/datasets.h): the
// centre camera held out, its view's surface estimated from the others at
// the camera's size, and the per-tile disparity error over textured tiles
// (lf::tile_disparity_errors), beside that of the estimate's single plane.
void ground_truth_check(const lf::Rig& rig, const std::vector<cv::Mat>& images,
                        const std::string& folder) {
  const std::string gt_path = folder + "/gt_disp_lowres.pfm";
  if (lf::detect_dataset(folder) != "hci" || !std::filesystem::exists(gt_path)) return;
  int centre = -1;
  for (size_t i = 0; i < rig.cameras.size(); ++i)
    if (cv::norm(rig.cameras[i].center()) < 1e-6 * rig.typical_spacing())
      centre = static_cast<int>(i);
  const cv::Mat gt = lf::read_pfm(gt_path);
  if (centre < 0 || gt.type() != CV_32FC1 ||
      gt.size() != cv::Size(rig.cameras[centre].width, rig.cameras[centre].height)) {
    std::printf(
        "\nGround truth: not compared (needs the centre camera at its own %dx%d size; "
        "--block or --input-scale changed the rig)\n",
        gt.cols, gt.rows);
    return;
  }
  const lf::Rig rj = rig.without({centre});
  std::vector<cv::Mat> ij;
  for (size_t i = 0; i < images.size(); ++i)
    if (static_cast<int>(i) != centre) ij.push_back(images[i]);
  const lf::FocalSurfaceEstimator est(rj, ij);
  lf::ViewRequest req;
  req.view = lf::VirtualView::from_camera(rig.cameras[centre], gt.cols, gt.rows);
  const auto t0 = Clock::now();
  const lf::SurfaceEstimate e = est.estimate(req);
  const double ms = ms_since(t0);
  const double baseline = rig.typical_spacing();
  const int tile = est.options().tile;
  const auto surf = lf::tile_disparity_errors(rj, e, e.tile_q, gt, tile, baseline);
  const auto one = lf::tile_disparity_errors(
      rj, e, std::vector<double>(e.tile_q.size(), e.single_q), gt, tile, baseline);
  if (surf.empty()) {
    std::printf("\nGround truth: no textured tile to compare\n");
    return;
  }
  auto pct = [](const std::vector<double>& v, int p) { return v[v.size() * p / 100]; };
  const double step =
      std::abs(baseline * (lf::focal_param_from_inverse_depth(rj, est.candidate_q(1)) -
                           lf::focal_param_from_inverse_depth(rj, 0)));
  std::printf(
      "\n## Focal surface against the ground-truth disparity (%s, centre camera held out, %dx%d)"
      "\n\n| model | planes | textured tiles | absolute disparity error, median px | 90th "
      "percentile px |\n"
      "|---|---|---|---|---|\n| focal surface | %d | %zu | %.3f | %.3f |\n"
      "| its single plane | 1 | %zu | %.3f | %.3f |\n\n"
      "Coarse sweep step %.3f px of disparity; estimated in %.0f ms.\n",
      gt_path.c_str(), gt.cols, gt.rows, e.planes_used, surf.size(), pct(surf, 50), pct(surf, 90),
      one.size(), pct(one, 50), pct(one, 90), step, ms);
}

struct SettingStats {
  std::vector<double> psnr, ssim, ms, px_ratio, bytes;
};

}  // namespace

int main(int argc, char** argv) {
  if (cli::help_requested(argc, argv, kHelp)) return 0;
  try {
    cli::Args args(argc, argv,
                   {"--input", "--block", "--input-scale", "--sizes", "--encodings", "--focal",
                    "--loo", "--sweep-steps", "--plot", "--backend", "--apertures", "--samplings",
                    "--hold-out", "--sub-steps"},
                   {"--skip-quality", "--skip-bandwidth", "--skip-speed"});
    cv::setNumThreads(1);
    const lf::Rig rig = cli::select_cameras(
        lf::load_rig_or_dataset(args.get("--input", "../shared/data/stanford-chess")), args, true);
    std::fprintf(stderr, "rig '%s': %zu cameras; loading images\n", rig.name.c_str(),
                 rig.cameras.size());
    const auto images = lf::load_images(rig, [](int k, int n) { cli::progress("images", k, n); });

    std::vector<std::pair<int, int>> sizes;
    {
      std::stringstream ss(args.get("--sizes", "320x240,640x480"));
      std::string tok;
      while (std::getline(ss, tok, ',')) {
        int w, h;
        cli::parse_size(tok, w, h);
        sizes.emplace_back(w, h);
      }
    }
    std::vector<Encoding> encodings;
    {
      std::stringstream ss(args.get("--encodings", "none,jpeg90"));
      std::string tok;
      while (std::getline(ss, tok, ',')) encodings.push_back(parse_encoding(tok));
    }
    std::vector<std::string> focals;
    {
      std::stringstream ss(args.get("--focal", "auto,best,surface"));
      std::string tok;
      while (std::getline(ss, tok, ',')) focals.push_back(tok);
    }
    // Aperture scales (> 0) and ULR (-k).
    std::vector<double> apertures = {1};
    if (args.has("--apertures")) {
      apertures.clear();
      std::stringstream ss(args.get("--apertures", "1"));
      std::string tok;
      while (std::getline(ss, tok, ',')) {
        if (tok == "four") {  // four-camera weights: 0
          apertures.push_back(0);
          continue;
        }
        if (tok.rfind("ulr", 0) == 0) {
          const int k = tok.size() > 3 ? std::atoi(tok.c_str() + 3) : 4;
          if (k < lf::kMinUlrCameras || k > lf::kMaxUlrCameras)
            throw std::invalid_argument("--apertures: ulrK with K in 2..16");
          apertures.push_back(-k);
          continue;
        }
        const double k = cli::parse_numbers(tok, "--apertures").at(0);
        if (!(k >= 1 && k <= lf::kMaxApertureScale))
          throw std::invalid_argument("--apertures: scales in 1..16, or ulrK");
        apertures.push_back(k);
      }
    }
    std::vector<lf::Sampling> samplings;
    {
      std::stringstream ss(args.get("--samplings", "bilinear"));
      std::string tok;
      while (std::getline(ss, tok, ',')) samplings.push_back(cli::parse_sampling(tok));
    }
    const int W0 = sizes.back().first, H0 = sizes.back().second;
    cv::Mat canvas(570, 1100, CV_8UC3, cv::Scalar(255, 255, 255));
    const double spacing = rig.typical_spacing();
    std::vector<double> fxs;
    for (const auto& c : rig.cameras) fxs.push_back(c.intrinsics.fx);
    const double q_max = 24.0 / (median(fxs) * spacing);
    auto q_label = [&](double q) {
      return rig.has_focal_param ? lf::focal_param_from_inverse_depth(rig, q) : q;
    };
    const char* q_name = rig.has_focal_param ? "focal parameter a" : "inverse depth";

    // ---------------------------------------------------------------- quality
    if (!args.has("--skip-quality")) {
      // Held-out cameras: interior of the grid (their viewpoint lies inside
      // the remaining cameras' triangulation), spread evenly.
      // With --hold-out subgrid: the cameras on even rows and columns of
      // the grid render, the others inside their hull are held out.
      const std::string hold_out = args.get("--hold-out", "one");
      if (hold_out != "one" && hold_out != "subgrid")
        throw std::invalid_argument("--hold-out: one or subgrid");
      const bool subgrid = hold_out == "subgrid";
      if (subgrid && (rig.grid.rows < 3 || rig.grid.cols < 3))
        throw std::invalid_argument("--hold-out subgrid needs a grid of at least 3x3 cameras");
      std::vector<int> interior, kept;
      for (size_t i = 0; i < rig.cameras.size(); ++i) {
        bool border = false, on_subgrid = false, inside = false;
        if (!rig.grid.empty()) {
          for (int r = 0; r < rig.grid.rows; ++r)
            for (int c = 0; c < rig.grid.cols; ++c)
              if (rig.grid.at(r, c) == static_cast<int>(i)) {
                border = r == 0 || c == 0 || r == rig.grid.rows - 1 || c == rig.grid.cols - 1;
                on_subgrid = r % 2 == 0 && c % 2 == 0;
                inside = r <= (rig.grid.rows - 1) / 2 * 2 && c <= (rig.grid.cols - 1) / 2 * 2;
              }
        }
        if (subgrid) {
          if (on_subgrid)
            kept.push_back(static_cast<int>(i));
          else if (inside)
            interior.push_back(static_cast<int>(i));
        } else if (!border) {
          interior.push_back(static_cast<int>(i));
        }
      }
      std::vector<int> others;  // with subgrid: every camera not kept
      for (size_t i = 0; i < rig.cameras.size(); ++i)
        if (std::find(kept.begin(), kept.end(), static_cast<int>(i)) == kept.end())
          others.push_back(static_cast<int>(i));
      const int n_loo = std::min<int>(args.integer("--loo", 12), interior.size());
      std::vector<int> held;
      for (int k = 0; k < n_loo; ++k)
        held.push_back(
            interior[(k * interior.size() + interior.size() / 2) / n_loo % interior.size()]);
      const int steps = std::max(8, args.integer("--sweep-steps", 96));
      std::map<std::string, SettingStats> stats;
      std::vector<std::string> order;
      std::vector<double> gap_auto, af_ms, nearest_psnr, surface_ms, surface_planes;
      std::vector<double> sweep_mean(steps, 0.0), auto_q, best_q;
      if (subgrid)
        std::printf(
            "\n## In-between views on %s (%zu cameras: the %zu of every other row and column "
            "render, %d of the others held out; border %s)\n\n",
            rig.name.c_str(), rig.cameras.size(), kept.size(), n_loo, "2.5% of the height cut");
      else
        std::printf("\n## Leave-one-out on %s (%zu cameras, %d held out; border %s)\n\n",
                    rig.name.c_str(), rig.cameras.size(), n_loo, "2.5% of the height cut");
      // The rig without the dropped cameras, its images, auto-focus and the
      // surface estimator (which keep pointers to the rig: built in place).
      struct Without {
        lf::Rig rig;
        std::vector<cv::Mat> images;
        std::unique_ptr<lf::AutofocusContext> af;
        std::unique_ptr<lf::FocalSurfaceEstimator> surf;
      };
      auto without = [&](const std::vector<int>& drop) {
        auto w = std::make_unique<Without>();
        w->rig = rig.without(drop);
        for (size_t i = 0; i < images.size(); ++i)
          if (std::find(drop.begin(), drop.end(), static_cast<int>(i)) == drop.end())
            w->images.push_back(images[i]);
        w->af = std::make_unique<lf::AutofocusContext>(w->rig, w->images);
        lf::SurfaceOptions surf_opt;
        surf_opt.second_planes = true;  // "surface" leaves them out
        surf_opt.sub_steps = args.integer("--sub-steps", 1);
        w->surf = std::make_unique<lf::FocalSurfaceEstimator>(w->rig, w->images, surf_opt);
        return w;
      };
      // subgrid: one sub-grid renders every held-out view.
      const std::unique_ptr<Without> shared = subgrid ? without(others) : nullptr;
      for (int k = 0; k < n_loo; ++k) {
        const int j = held[k];
        const std::unique_ptr<Without> own = subgrid ? nullptr : without({j});
        const Without& w = subgrid ? *shared : *own;
        const lf::Rig& rj = w.rig;
        const std::vector<cv::Mat>& ij = w.images;
        const lf::AutofocusContext& af = *w.af;
        const lf::FocalSurfaceEstimator& surf = *w.surf;
        // Exhaustive sweep at the smallest size (an oracle: it sees the truth).
        const auto [ws, hs] = sizes.front();
        lf::ViewRequest sreq;
        sreq.view = lf::VirtualView::from_camera(rig.cameras[j], ws, hs);
        // Metrics where the held-out image has the scene (lf/quality/quality.h).
        const cv::Rect srect = lf::camera_view_rect(rig.cameras[j], ws, hs);
        const cv::Mat sgt = lf::camera_view_image(rig.cameras[j], images[j], ws, hs)(srect);
        double best = -1, qbest = 0;
        for (int s = 0; s < steps; ++s) {
          const double q = q_max * s / (steps - 1);
          sreq.focal_plane = lf::plane_at_inverse_depth(rj, q);
          const double p =
              lf::psnr(render_frame(rj, ij, sreq, {"none"}).image(srect), sgt, hs / 40);
          sweep_mean[s] += p / n_loo;
          if (p > best) best = p, qbest = q;
        }
        best_q.push_back(qbest);
        for (const auto& [W, H] : sizes) {
          lf::ViewRequest req;
          req.view = lf::VirtualView::from_camera(rig.cameras[j], W, H);
          const cv::Rect valid = lf::camera_view_rect(rig.cameras[j], W, H);
          const cv::Mat gt = lf::camera_view_image(rig.cameras[j], images[j], W, H)(valid);
          const int border = H / 40;
          const auto t0 = Clock::now();
          req.focal_plane = lf::FocalPlane::infinity();
          const lf::FocalPlane auto_plane = af.run(req).plane;
          af_ms.push_back(ms_since(t0));
          if (W == W0) auto_q.push_back(auto_plane.n.dot(rj.plane().normal));
          const auto t1 = Clock::now();
          const lf::SurfaceEstimate est = surf.estimate(req);
          surface_ms.push_back(ms_since(t1));
          if (W == W0) surface_planes.push_back(est.planes_used);
          double p_auto = NAN, p_best = NAN;  // NAN: not among --focal
          for (const std::string& fs : focals) {
            req.surface = {};
            if (fs == "auto")
              req.focal_plane = auto_plane;
            else if (fs == "surface" || fs == "surface2") {
              lf::apply(est, req);
              if (fs == "surface") req.surface.second_of.clear();
            } else if (fs == "best")
              req.focal_plane = lf::plane_at_inverse_depth(rj, qbest);
            else
              req.focal_plane = cli::parse_focal(fs, rj).plane;
            for (const lf::Sampling sampling : samplings)
              for (const double ap : apertures)
                for (const Encoding& e : encodings) {
                  req.aperture_scale = ap > 0 ? ap : 1;
                  req.aperture = ap > 0    ? lf::Aperture::kTent
                                 : ap == 0 ? lf::Aperture::kFourCamera
                                           : lf::Aperture::kUlr;
                  req.ulr_cameras = ap > 0 ? 4 : static_cast<int>(-ap);
                  req.sampling = sampling;
                  const bool cubic = sampling == lf::Sampling::kBicubic;
                  char ap_label[48] = "";
                  if (ap == 0)
                    std::snprintf(ap_label, sizeof ap_label, ", four-camera");
                  else if (ap < 0)
                    std::snprintf(ap_label, sizeof ap_label, ", ULR k = %d", static_cast<int>(-ap));
                  else if (ap != 1)
                    std::snprintf(ap_label, sizeof ap_label, ", aperture %gx", ap);
                  const std::string key = std::to_string(W) + "x" + std::to_string(H) + " | " +
                                          e.name + " | " + fs + ap_label +
                                          (cubic ? ", bicubic" : "");
                  if (!stats.count(key)) order.push_back(key);
                  auto& st = stats[key];
                  std::vector<double> times;
                  FrameResult fr;
                  for (int rep = 0; rep < 3; ++rep) {
                    fr = render_frame(rj, ij, req, e);
                    times.push_back(fr.ms);
                  }
                  const double p = lf::psnr(fr.image(valid), gt, border);
                  st.psnr.push_back(p);
                  st.ssim.push_back(lf::ssim(fr.image(valid), gt, border));
                  st.ms.push_back(median(times));
                  st.px_ratio.push_back(static_cast<double>(fr.fragment_pixels) / (W * H));
                  st.bytes.push_back(static_cast<double>(fr.bytes));
                  const bool base = e.name == encodings.front().name && ap == 1 && !cubic;
                  if (base && fs == "auto") p_auto = p;
                  if (base && fs == "best") p_best = p;
                }
          }
          if (W == W0) {
            // The gap only where both auto and best were rendered.
            if (std::isfinite(p_best) && std::isfinite(p_auto)) gap_auto.push_back(p_best - p_auto);
            // Nearest-camera baseline through the auto plane.
            int nearest = 0;
            for (size_t i = 0; i < rj.cameras.size(); ++i)
              if (cv::norm(rj.cameras[i].center() - req.view.position) <
                  cv::norm(rj.cameras[nearest].center() - req.view.position))
                nearest = static_cast<int>(i);
            const lf::Rig one = rj.subset({nearest});
            req.focal_plane = auto_plane;
            req.surface = {};
            req.aperture_scale = 1;
            req.aperture = lf::Aperture::kTent;
            req.sampling = lf::Sampling::kBilinear;
            nearest_psnr.push_back(
                lf::psnr(render_frame(one, {ij[nearest]}, req, {"none"}).image(valid), gt, border));
          }
        }
        cli::progress("leave-one-out", k + 1, n_loo);
      }
      std::printf(
          "| output | encoding | focal plane | PSNR dB | SSIM | ms/frame (1 core) | "
          "fragment px / output px | bytes/frame |\n|---|---|---|---|---|---|---|---|\n");
      for (const auto& key : order) {
        const auto& st = stats[key];
        std::printf(
            "| %s | %.2f | %.4f | %.2f | %.2f | %s |\n", key.c_str(), mean(st.psnr), mean(st.ssim),
            median(st.ms), mean(st.px_ratio),
            mean(st.bytes) > 0 ? std::to_string(static_cast<long>(mean(st.bytes))).c_str() : "-");
      }
      if (!gap_auto.empty()) {
        std::printf(
            "\nAuto-focus vs the best single plane of a %d-plane exhaustive sweep (%dx%d, "
            "held-out views): gap mean %.3f dB, max %.3f dB; auto-focus %.1f ms per view "
            "(median)\n",
            steps, W0, H0, mean(gap_auto), *std::max_element(gap_auto.begin(), gap_auto.end()),
            median(af_ms));
        std::printf(
            "Focal surface: estimated in %.1f ms per view (median, from scratch, side by side "
            "with auto-focus above); %.1f distinct planes per view at %dx%d (mean)\n",
            median(surface_ms), mean(surface_planes), W0, H0);
        std::printf("Nearest camera alone (through the auto plane, %dx%d): PSNR %.2f dB\n", W0, H0,
                    mean(nearest_psnr));
      }
      ground_truth_check(rig, images, args.get("--input", "../shared/data/stanford-chess"));
      // Plot (a): PSNR vs time; (b): mean sweep curve with auto / best picks.
      double pmin = 1e9, pmax = -1e9, tmax = 0;
      for (const auto& key : order) {
        pmin = std::min(pmin, mean(stats[key].psnr));
        pmax = std::max(pmax, mean(stats[key].psnr));
        tmax = std::max(tmax, median(stats[key].ms));
      }
      Axes a = axes(canvas, {80, 50, 420, 380}, 0, tmax * 1.15, std::floor(pmin - 1),
                    std::ceil(pmax + 1), "Leave-one-out PSNR vs time per frame (1 core)",
                    "ms per frame", "PSNR dB");
      const cv::Scalar colours[] = {{200, 60, 0},  {0, 120, 220}, {0, 160, 0},
                                    {150, 0, 150}, {0, 0, 200},   {100, 100, 0}};
      for (size_t ci = 0; ci < order.size(); ++ci) {
        const auto& key = order[ci];
        const cv::Scalar& col = colours[ci % 6];
        const cv::Point p = a.at(median(stats[key].ms), mean(stats[key].psnr));
        if (ci < 6)
          cv::circle(canvas, p, 5, col, cv::FILLED);
        else
          cv::drawMarker(canvas, p, col, cv::MARKER_SQUARE, 9, 2);
        cv::putText(canvas, key,
                    {90 + 210 * static_cast<int>(ci / 6), 480 + 13 * static_cast<int>(ci % 6)},
                    cv::FONT_HERSHEY_SIMPLEX, 0.38, col);
      }
      double smin = 1e9, smax = -1e9;
      for (double v : sweep_mean) smin = std::min(smin, v), smax = std::max(smax, v);
      const double la = q_label(0), lb = q_label(q_max);
      Axes b = axes(canvas, {620, 50, 440, 380}, std::min(la, lb), std::max(la, lb),
                    std::floor(smin), std::ceil(smax + 0.5),
                    std::string("Mean PSNR over the focal sweep (") +
                        std::to_string(sizes.front().first) + "x" +
                        std::to_string(sizes.front().second) + ")",
                    q_name, "PSNR dB");
      for (int s = 1; s < steps; ++s)
        cv::line(canvas, b.at(q_label(q_max * (s - 1) / (steps - 1)), sweep_mean[s - 1]),
                 b.at(q_label(q_max * s / (steps - 1)), sweep_mean[s]), cv::Scalar(0, 0, 0), 2);
      for (double q : best_q)
        cv::drawMarker(canvas, b.at(q_label(q), smax + 0.2), cv::Scalar(0, 160, 0),
                       cv::MARKER_TRIANGLE_DOWN, 10, 2);
      for (double q : auto_q)
        cv::drawMarker(canvas, b.at(q_label(q), smax + 0.35), cv::Scalar(0, 0, 220),
                       cv::MARKER_CROSS, 10, 2);
      cv::putText(canvas, "green: best plane per held-out view; red: auto-focus", {620, 480},
                  cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar(0, 0, 0));
    }

    // ------------------------------------------------------------- bandwidth
    // Views along an orbit with a dolly through the camera plane.
    std::vector<lf::ViewRequest> path;
    {
      const auto keys = lf::orbit_path(rig, 0.5, 2.0 * spacing, 24);
      const auto views = lf::sample_path(rig, keys, 24, W0, H0, true);
      const lf::FocalPlane plane = rig.has_focal_param ? lf::plane_from_focal_param(rig, -0.2)
                                                       : lf::plane_at_inverse_depth(rig, q_max / 3);
      for (size_t k = 0; k < views.size(); ++k) {
        lf::ViewRequest r;
        r.sequence = k;
        r.view = views[k];
        r.focal_plane = plane;
        path.push_back(r);
      }
    }
    if (!args.has("--skip-bandwidth") && !rig.grid.empty()) {
      std::printf(
          "\n## Bandwidth per output frame (%dx%d, %zu views on an orbit with a +-%.3g %s "
          "dolly through the camera plane)\n\n",
          W0, H0, path.size(), 2.0 * spacing, rig.unit.c_str());
      std::printf(
          "| cameras | fragment px / output px | raw bytes/frame | JPEG q90 bytes/frame | "
          "vs 64 (px) |\n|---|---|---|---|---|\n");
      const int R = rig.grid.rows, C = rig.grid.cols;
      std::vector<std::pair<std::string, double>> ratios;
      double ref = 0;
      auto measure = [&](const lf::Rig& r, const std::vector<cv::Mat>& im, bool real) {
        double px = 0, raw = 0, jpg = 0;
        for (const auto& req : path) {
          px += render_frame(r, im, req, {"none"}).fragment_pixels;
          if (real) {
            raw += render_frame(r, im, req, parse_encoding("raw")).bytes;
            jpg += render_frame(r, im, req, parse_encoding("jpeg90")).bytes;
          }
        }
        const double n = path.size();
        return std::array<double, 3>{px / n / (double(W0) * H0), raw / n, jpg / n};
      };
      std::vector<std::array<double, 3>> rows;
      std::vector<std::string> names;
      for (int k : {2, 4, 8}) {
        if (k > std::min(R, C)) continue;
        const lf::Rig sub = lf::grid_spread(rig, k);
        std::vector<int> keep;
        for (const auto& c : sub.cameras) keep.push_back(rig.index_of(c.id));
        std::vector<cv::Mat> im;
        for (int i : keep) im.push_back(images[i]);
        rows.push_back(measure(sub, im, true));
        names.push_back(std::to_string(keep.size()));
        if (keep.size() == 64) ref = rows.back()[0];
      }
      {
        // Synthetic 16 x 16 rig spanning the same camera-plane extent.
        double ext = 0;
        for (const auto& p : rig.plane_positions())
          ext = std::max({ext, std::abs(p[0]), std::abs(p[1])});
        lf::Rig syn = lf::synthetic_grid_rig(16, 16, 2 * ext / 15, 160, 90, 40);
        const lf::CameraPlane& P = rig.plane();
        const cv::Matx33d Rw(P.u[0], P.u[1], P.u[2], P.v[0], P.v[1], P.v[2], P.normal[0],
                             P.normal[1], P.normal[2]);
        for (auto& c : syn.cameras) {
          const cv::Vec3d C0 = c.center();
          c.extrinsics = lf::Extrinsics::from_center(c.extrinsics.R * Rw,
                                                     P.origin + P.u * C0[0] + P.v * C0[1]);
        }
        syn.triangles.clear();
        syn.finalize();
        std::vector<cv::Mat> im(syn.cameras.size(),
                                cv::Mat(90, 160, CV_8UC4, cv::Scalar::all(128)));
        rows.push_back(measure(syn, im, false));
        names.push_back("256 (synthetic)");
      }
      for (size_t k = 0; k < rows.size(); ++k) {
        const bool real = rows[k][1] > 0;
        std::printf("| %s | %.3f | %s | %s | %+.1f %% |\n", names[k].c_str(), rows[k][0],
                    real ? std::to_string(static_cast<long>(rows[k][1])).c_str() : "-",
                    real ? std::to_string(static_cast<long>(rows[k][2])).c_str() : "-",
                    ref > 0 ? 100.0 * (rows[k][0] / ref - 1) : 0.0);
      }
    }

    // ----------------------------------------------------------------- speed
    if (!args.has("--skip-speed")) lfbench::speed_table(rig, images, path, W0, H0);
    // -------------------------------------------------------------- backends
    std::vector<lf::Backend> backends;
    {
      std::stringstream ss(args.get("--backend", "cpu"));
      std::string tok;
      while (std::getline(ss, tok, ',')) backends.push_back(cli::backend_from(tok, false));
    }
    if (backends.size() > 1 || (backends.size() == 1 && backends[0] != lf::Backend::kCpu))
      lfbench::backend_table(rig, images, backends, sizes,
                             path.empty() ? lf::FocalPlane{} : path[0].focal_plane);
    const std::string plot = args.get("--plot", "lf-bench.png");
    if (!args.has("--skip-quality")) {
      if (!cv::imwrite(plot, canvas)) throw std::runtime_error("cannot write " + plot);
      std::printf("\nplot: %s\n", plot.c_str());
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lf-bench: error: %s\n", e.what());
    return 1;
  }
}
