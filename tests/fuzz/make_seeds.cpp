// Seed corpora for the fuzz harnesses, generated from valid messages:
// make_seeds DIR writes DIR/{fragment,request,rig,bal}/seed_*.
#include <filesystem>
#include <fstream>
#include <iostream>

#include "lf/focus/focus.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/rig_file.h"
#include "lf/quality/synthetic.h"
#include "lf/render/composite.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"

namespace fs = std::filesystem;

static void write(const fs::path& dir, int k, const std::string& bytes) {
  fs::create_directories(dir);
  std::ofstream(dir / ("seed_" + std::to_string(k)), std::ios::binary) << bytes;
}
static std::string str(const std::vector<uint8_t>& v) {
  return std::string(v.begin(), v.end());
}

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_seeds DIR\n";
    return 2;
  }
  const fs::path out = argv[1];
  const lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.05, 48, 36, 40.0, 1.0);
  const lf::SyntheticScene scene = lf::SyntheticScene::for_rig(rig);
  int k = 0;
  for (int v = 0; v < 4; ++v) {
    lf::ViewRequest req;
    req.sequence = v;
    req.view = lf::view_between_cameras(rig, rig.plane().origin + cv::Vec3d(0.01 * v, 0.004 * v, 0),
                                        32 + 16 * v, 24 + 12 * v);
    req.focal_plane = v == 0 ? lf::FocalPlane::infinity() : lf::plane_at_depth(rig, 0.5 + v);
    write(out / "request", v, str(lf::serialize_request(req)));
    // The same view with a focal surface of two planes in tiles of 8
    // (version 3).
    lf::ViewRequest surfaced = req;
    lf::FocalSurface& sf = surfaced.surface;
    sf.tile = 8;
    sf.cols = (req.view.width + 7) / 8, sf.rows = (req.view.height + 7) / 8;
    sf.planes = {lf::plane_at_depth(rig, 0.7), lf::plane_at_depth(rig, 3.0)};
    for (int t = 0; t < sf.cols * sf.rows; ++t) sf.plane_of.push_back((t / sf.cols + t) % 2);
    write(out / "request", 4 + v, str(lf::serialize_request(surfaced)));
    // A probe bundle: a surface probe's steps (lib/lf/wire/probe_bundle.h).
    write(out / "request", 8 + v,
          str(lf::serialize_probe_bundle(lf::surface_probe_requests(rig, req, 1 + v))));
    const lf::ViewGeometry g(rig, req);
    std::vector<lf::Fragment> block;  // cameras 0, 4, 8, ... summed (version 2)
    for (int i = 0; i < static_cast<int>(rig.cameras.size()); i += 4) {
      lf::Fragment f;
      f.sequence = v;
      f.camera_id = rig.cameras[i].id;
      lf::render_fragment(lf::plan_fragment(g, i), rig.cameras[i], scene.render(rig.cameras[i], 0),
                          f);
      write(out / "fragment", k++, str(lf::serialize_fragment(f, lf::Encoding::kRaw)));
      // Two steps of a focus probe in one buffer (a probe bundle's answer).
      lf::Fragment s0 = f, s1 = f;
      s0.sequence = lf::focus_probe_sequence(1 + v, 0);
      s1.sequence = lf::focus_probe_sequence(1 + v, 1);
      write(out / "fragment", k++,
            str(lf::serialize_fragment(s0, lf::Encoding::kRaw)) +
                str(lf::serialize_fragment(s1, lf::Encoding::kRaw)));
      if (!f.empty())
        write(out / "fragment", k++,
              str(lf::serialize_fragment(f, lf::Encoding::kJpeg, 50 + 10 * v)));
      block.push_back(f);
    }
    // A partial sum (lib/lf/render/composite.h sum_fragments), raw and JPEG.
    std::vector<lf::FragmentPixels> parts;
    for (const lf::Fragment& f : block) parts.push_back({&f, f.pixels.data()});
    const lf::Fragment sum = lf::sum_fragments(parts);
    write(out / "fragment", k++, str(lf::serialize_fragment(sum, lf::Encoding::kRaw)));
    if (!sum.empty())
      write(out / "fragment", k++, str(lf::serialize_fragment(sum, lf::Encoding::kJpeg, 90)));
  }
  write(out / "rig", 0, lf::rig_to_json(rig));
  write(out / "rig", 1, lf::rig_to_json(lf::synthetic_grid_rig(1, 4, 0.1, 32, 24)));
  write(out / "bal", 0,
        "2 2 3\n0 0 1.5 -2.5\n1 0 0.5 3.0\n1 1 -1.0 2.0\n"
        "0.01 0.02 0.03 0.1 0.2 0.3 500 -0.1 0.01\n"
        "0.0 0.0 0.0 0.0 0.0 0.0 480 0.0 0.0\n"
        "1 2 -5\n0.5 0.5 -6\n");
  std::cout << "seeds written to " << out << "\n";
  return 0;
}
