// lf-render: offline light field rendering of one view or a camera path.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "cli.h"
#include "lf/focus/focal_surface.h"
#include "lf/geometry/rig_ops.h"
#include "lf/io/datasets.h"
#include "lf/io/rig_file.h"
#include "lf/render/colour.h"

namespace {

const char* kHelp =
    R"(lf-render: render virtual views of a light field (finite-viewpoints renderer of
Yang et al. 2002: per-camera fragments through a focal plane, tent aperture over
the camera triangulation, additive compositing with renormalisation).

usage: lf-render --input PATH [view] [options] --out FILE

input
  --input PATH          dataset folder (Stanford out_*.png, HCI parameters.cfg,
                        Blender 'Original Camera_*', Middlebury *_par.txt) or a
                        rig file (.json, see --save-rig)
  --block R0,C0,ROWS,COLS  only the cameras of this block of the grid
  --input-scale S       resize camera images by S first (default 1; 0.5 halves)
  --save-rig FILE       write the rig file (JSON) and continue

view (one of; default: --orbit 0.6)
  --at X,Y[,Z]          one view at this position in rig units (the dataset's own
                        units: Stanford X,Y from the file names, HCI/Blender
                        metres); orientation and intrinsics follow the cameras
                        (interpolated between the surrounding ones)
  --eye X,Y,Z --look-at X,Y,Z [--vfov DEG]   one view with a full pose
  --path FILE           keyframed camera path (JSON, docs/rendering.md)
  --orbit R             circular path on the camera plane, radius R x half the
                        array's extent
  --dolly D             with --orbit: also move +-D rig units along the plane normal
  --frames N            frames of a path (default 60)

rendering
  --size WxH            output size in pixels (default 640x480)
  --focal SPEC          surface (default): a focal surface from the images, one
                        plane per 16-pixel tile (lib/lf/focus/focal_surface.h; a flat
                        scene keeps one plane); plane (or auto): the paper's one
                        focal plane per view, chosen from the images by
                        photo-consistency; or a fixed plane: infinity, depth:Z
                        (rig units from the camera plane), param:A (light-slab
                        focal parameter: Stanford's pixels of shift per position
                        unit), plane:nx,ny,nz,d
  --one-plane-per-tile  with --focal surface: no second planes. By default tiles
                        next to a depth edge or with a thin structure inside get a
                        second plane, chosen per pixel (lib/lf/render/composite.h
                        LayerCompositor; CPU backend); --second-planes is accepted
                        and changes nothing
  --refocus-every N     on a path: re-run auto-focus every N frames (default 15),
                        or estimate the focal surface every N frames (default 1)
  --aperture D          synthetic aperture diameter on the camera plane, rig units
                        (default 0: the paper's tent, 2 camera spacings wide, the
                        smallest); wider blends more cameras: what is off the focal
                        plane blurs instead of doubling (lib/lf/geometry/view.h Aperture)
  --f-number N          the aperture as a full-frame-equivalent f-number (N = F / D,
                        F = 36 mm x fx / width; needs the rig's unit mm, cm or m)
  --ulr K               Unstructured Lumigraph weights over the K cameras nearest each
                        ray in angle (2..16; lib/lf/geometry/view.h), for rigs without a grid
  --four-camera         bilinear weights over the grid cell around each ray: a view at a
                        cell's centre blends four cameras where the tent blends two
                        (lib/lf/geometry/view.h kFourCamera; about 1.3x the fragments)
  --sampling S          bilinear (default, the paper's) or bicubic (Keys, a = -0.5:
                        sharper edges, twice the warping time; on held-out views
                        bilinear scores higher: docs/rendering.md)
  --threads N           render cameras in parallel (default: all cores)
  --backend B           auto (default: GL on a hardware GPU, else CPU), cpu, or gl
                        (EGL/GLES 3, lib/lf/render/gl_render.h: fragments drawn and blended
                        on the GPU, images uploaded once; Mesa's llvmpipe without one)

output
  --out FILE            .png: one image (a path writes FILE with _0000, _0001, ...)
                        .avi (Motion JPEG) or .mp4 (MPEG-4 part 2): a video
  --fps F               video frame rate (default 30)
  --quiet               no progress output
)";

}  // namespace

int main(int argc, char** argv) {
  if (cli::help_requested(argc, argv, kHelp)) return 0;
  try {
    cli::Args args(
        argc, argv,
        {"--input",    "--block",   "--input-scale",   "--save-rig", "--at",       "--eye",
         "--look-at",  "--vfov",    "--path",          "--orbit",    "--dolly",    "--frames",
         "--size",     "--focal",   "--refocus-every", "--aperture", "--f-number", "--ulr",
         "--sampling", "--threads", "--backend",       "--out",      "--fps"},
        {"--quiet", "--second-planes", "--one-plane-per-tile", "--four-camera"});
    if (!args.has("--input")) throw std::invalid_argument("--input is required (see --help)");
    if (!args.has("--out")) throw std::invalid_argument("--out is required (see --help)");
    const bool quiet = args.has("--quiet");
    lf::Rig rig = cli::select_cameras(lf::load_rig_or_dataset(args.get("--input")), args);
    if (args.has("--save-rig")) lf::save_rig(rig, args.get("--save-rig"));
    int W = 640, H = 480;
    if (args.has("--size")) cli::parse_size(args.get("--size"), W, H);
    const int threads = args.integer("--threads", cv::getNumberOfCPUs());
    if (!quiet)
      std::fprintf(stderr, "rig '%s': %zu cameras (%s), loading images\n", rig.name.c_str(),
                   rig.cameras.size(),
                   rig.grid.empty() ? "unstructured"
                                    : (std::to_string(rig.grid.rows) + "x" +
                                       std::to_string(rig.grid.cols) + " grid")
                                          .c_str());
    auto images = lf::load_images(rig, [&](int k, int n) {
      if (!quiet) cli::progress("images", k, n);
    });

    // Colour correction from the rig (lib/lf/render/colour.h; identity by default).
    lf::colour_correct_images(rig, images, lf::ChannelOrder::kBGRA);

    // The renderer; GL gets the images once, as a live camera's frame is.
    std::unique_ptr<lf::GlRenderer> gl;
    if (cli::backend_from(args.get("--backend", "auto"), quiet) == lf::Backend::kGl) {
      gl = std::make_unique<lf::GlRenderer>();
      for (size_t i = 0; i < images.size(); ++i) gl->set_image(static_cast<int>(i), images[i]);
    }

    // Views (lib/lf/geometry/view_builder.h, as lfviewrequest builds them).
    lf::ViewSettings vs;
    vs.width = W;
    vs.height = H;
    if (args.has("--at")) {
      const auto p = args.numbers("--at", 2, 3);
      vs.position =
          p.size() == 3 ? cv::Vec3d(p[0], p[1], p[2]) : lf::point_on_camera_plane(rig, p[0], p[1]);
    } else if (args.has("--eye")) {
      if (!args.has("--look-at")) throw std::invalid_argument("--eye needs --look-at");
      vs.position = lf::parse_point(args.get("--eye"), "--eye");
      vs.look_at = lf::parse_point(args.get("--look-at"), "--look-at");
      vs.vfov_deg = args.number("--vfov", 50);
    } else {
      vs.path_frames = args.integer("--frames", 60);
      if (vs.path_frames < 1 || vs.path_frames > 100000)
        throw std::invalid_argument("--frames out of range");
      if (args.has("--path")) {
        vs.path_file = args.get("--path");
      } else {
        vs.orbit = args.number("--orbit", 0.6);
        vs.dolly = args.number("--dolly", 0);
      }
    }
    const std::vector<lf::VirtualView> views = lf::build_views(rig, vs).views;

    const cli::FocalSpec focal = cli::parse_focal(args.get("--focal", "surface"), rig);
    std::unique_ptr<lf::AutofocusContext> af;
    std::unique_ptr<lf::FocalSurfaceEstimator> surface;
    if (focal.kind == cli::FocalSpec::kAuto)
      af = std::make_unique<lf::AutofocusContext>(rig, images);
    if (focal.kind == cli::FocalSpec::kSurface) {
      lf::SurfaceOptions opt;
      opt.second_planes = !args.has("--one-plane-per-tile");
      surface = std::make_unique<lf::FocalSurfaceEstimator>(rig, images, opt);
    } else if (args.has("--second-planes") || args.has("--one-plane-per-tile")) {
      throw std::invalid_argument("--second-planes and --one-plane-per-tile need --focal surface");
    }
    if (args.has("--second-planes") && args.has("--one-plane-per-tile"))
      throw std::invalid_argument("--second-planes and --one-plane-per-tile contradict each other");
    const int refocus = std::max(1, args.integer("--refocus-every", surface ? 1 : 15));

    const std::string out = args.get("--out");
    const std::string ext = std::filesystem::path(out).extension().string();
    cv::VideoWriter video;
    if (ext == ".avi" || ext == ".mp4") {
      const int fourcc = ext == ".avi" ? cv::VideoWriter::fourcc('M', 'J', 'P', 'G')
                                       : cv::VideoWriter::fourcc('m', 'p', '4', 'v');
      if (!video.open(out, cv::CAP_FFMPEG, fourcc, args.number("--fps", 30), cv::Size(W, H)))
        throw std::runtime_error("cannot open video " + out + " for writing");
    } else if (ext != ".png") {
      throw std::invalid_argument("--out must end in .png, .avi or .mp4");
    }

    lf::FocalPlane plane = focal.plane;
    lf::SurfaceEstimate estimate;
    double total_ms = 0, estimate_ms = 0, planes = 0, two_plane_tiles = 0;
    int estimates = 0;
    size_t frag_px = 0;
    for (size_t f = 0; f < views.size(); ++f) {
      lf::ViewRequest req;
      req.sequence = f;
      req.view = views[f];
      if (af && f % refocus == 0) {
        req.focal_plane = lf::FocalPlane::infinity();
        const auto r = af->run(req);
        plane = r.plane;
        if (!quiet && views.size() == 1) {
          std::fprintf(stderr, "auto-focus: inverse depth %.6g /%s", r.inverse_depth,
                       rig.unit.c_str());
          if (rig.has_focal_param)
            std::fprintf(stderr, " (focal parameter %.4f)",
                         lf::focal_param_from_inverse_depth(rig, r.inverse_depth));
          std::fprintf(stderr, "\n");
        }
      }
      req.focal_plane = plane;
      if (args.has("--f-number")) {
        const double mm = lf::millimetres_per_unit(rig.unit);
        if (mm <= 0)
          throw std::invalid_argument("--f-number needs the rig's unit to be mm, cm or m (it is '" +
                                      rig.unit + "'): give --aperture in rig units");
        req.aperture_scale = lf::aperture_scale_for(
            lf::diameter_for_f_number(args.number("--f-number", 0), req.view.focal_px(),
                                      req.view.width, mm),
            rig.typical_spacing());
      } else {
        req.aperture_scale =
            lf::aperture_scale_for(args.number("--aperture", 0), rig.typical_spacing());
      }
      req.sampling = cli::parse_sampling(args.get("--sampling", "bilinear"));
      if (args.has("--four-camera")) {
        if (args.has("--ulr") || req.aperture_scale != 1)
          throw std::invalid_argument("--four-camera takes no --ulr, --aperture or --f-number");
        req.aperture = lf::Aperture::kFourCamera;
      }
      if (args.has("--ulr")) {
        req.aperture = lf::Aperture::kUlr;
        req.aperture_scale = 1;
        req.ulr_cameras = args.integer("--ulr", 4);
      }
      if (!quiet && f == 0 && req.aperture_scale > 1) {
        const double d = lf::aperture_diameter(req.aperture_scale, rig.typical_spacing());
        std::fprintf(stderr, "aperture: %.4g %s across (%.2f x the tent's)", d, rig.unit.c_str(),
                     req.aperture_scale);
        if (const double mm = lf::millimetres_per_unit(rig.unit); mm > 0)
          std::fprintf(stderr, ", f/%.3g full-frame equivalent",
                       lf::full_frame_f_number(d * mm, req.view.focal_px(), req.view.width));
        std::fprintf(stderr, "\n");
      }
      if (surface) {
        if (f % refocus == 0) {
          const auto e0 = std::chrono::steady_clock::now();
          estimate = surface->estimate(req);
          estimate_ms +=
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - e0)
                  .count();
          planes += estimate.planes_used;
          two_plane_tiles += estimate.two_plane_tiles;
          ++estimates;
        }
        lf::apply(estimate, req);
      }
      lf::RenderStats st;
      const auto t0 = std::chrono::steady_clock::now();
      const cv::Mat img = gl ? gl->render_view(rig, req, &st, threads)
                             : lf::render_view(rig, images, req, &st, threads);
      total_ms +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      frag_px += st.fragment_pixels;
      cv::Mat bgr;
      cv::cvtColor(img, bgr, cv::COLOR_BGRA2BGR);
      if (video.isOpened()) {
        video.write(bgr);
      } else {
        std::string name = out;
        if (views.size() > 1) {
          char suffix[32];
          std::snprintf(suffix, sizeof suffix, "_%04zu", f);
          name = (std::filesystem::path(out).parent_path() /
                  (std::filesystem::path(out).stem().string() + suffix + ".png"))
                     .string();
        }
        if (!cv::imwrite(name, bgr)) throw std::runtime_error("cannot write " + name);
      }
      if (!quiet) cli::progress("render", static_cast<int>(f + 1), static_cast<int>(views.size()));
    }
    if (!quiet && estimates > 0)
      std::fprintf(stderr,
                   "focal surface: %.1f distinct planes per estimate over %dx%d tiles of %d px "
                   "(%.1f with a second plane), %.0f ms per estimate (%d)\n",
                   planes / estimates, (W + surface->options().tile - 1) / surface->options().tile,
                   (H + surface->options().tile - 1) / surface->options().tile,
                   surface->options().tile, two_plane_tiles / estimates, estimate_ms / estimates,
                   estimates);
    if (!quiet)
      std::fprintf(stderr,
                   "%zu frame(s) %dx%d from %zu cameras: %.1f ms/frame render, fragment pixels "
                   "%.2fx the output; wrote %s\n",
                   views.size(), W, H, rig.cameras.size(), total_ms / views.size(),
                   static_cast<double>(frag_px) / views.size() / (double(W) * H), out.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lf-render: error: %s\n", e.what());
    return 1;
  }
}
