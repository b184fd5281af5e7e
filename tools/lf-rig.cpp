// lf-rig: writes a rig file (JSON) from a dataset folder or rig file, with an
// optional grid block and image scale; lists camera ids for scripts.
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "cli.h"
#include "lf/geometry/rig_ops.h"
#include "lf/io/datasets.h"
#include "lf/io/rig_file.h"
#include "lf/quality/synthetic.h"

int main(int argc, char** argv) {
  const char* help = R"(lf-rig: make a rig file for the elements and tools.

usage: lf-rig (--input PATH | --synthetic RxC) [options] [--out RIG.json] [--ids]
  --input PATH     dataset folder or rig file
  --synthetic RxC  a synthetic grid rig (no images; for lfcamsrc mode=synthetic)
  --spacing S      synthetic: camera spacing, rig units (default 0.05)
  --size WxH       synthetic: image size (default 320x240)
  --vfov DEG       synthetic: vertical field of view (default 40)
  --images         synthetic, with --out: also render each camera's view of the synthetic
                   scene (lf::SyntheticScene at t = 0) to a PNG beside the rig file, so
                   the rig works as a dataset (e.g. 16x16 = 256 cameras for lf-gst-bench)
  --block ...      keep only this block of the grid
  --spread K       then keep a K x K sub-grid spread evenly over it (first, last included)
  --input-scale S  cameras' images resized by S (intrinsics scaled)
  --out FILE       write the rig file (image paths relative to it)
  --ids            print the camera ids, one per line (for scripts)
  --hosts N        print each camera's host (0..N-1), one per line in rig order: the grid
                   cut into N contiguous blocks, for partial sums (pipelines/net-host.sh)
)";
  if (cli::help_requested(argc, argv, help)) return 0;
  try {
    cli::Args args(argc, argv,
                   {"--input", "--synthetic", "--spacing", "--size", "--vfov", "--block",
                    "--spread", "--input-scale", "--out", "--hosts"},
                   {"--ids", "--images"});
    lf::Rig rig;
    if (args.has("--synthetic")) {
      int rows, cols, w = 320, h = 240;
      cli::parse_size(args.get("--synthetic"), cols, rows);
      if (args.has("--size")) cli::parse_size(args.get("--size"), w, h);
      rig = lf::synthetic_grid_rig(rows, cols, args.number("--spacing", 0.05), w, h,
                                   args.number("--vfov", 40));
    } else if (args.has("--input")) {
      rig = lf::load_rig_or_dataset(args.get("--input"));
    } else {
      throw std::invalid_argument("--input or --synthetic is required (see --help)");
    }
    rig = cli::select_cameras(rig, args);
    if (args.has("--images")) {
      if (!args.has("--synthetic") || !args.has("--out"))
        throw std::invalid_argument("--images needs --synthetic and --out");
      const std::string dir = std::filesystem::absolute(args.get("--out")).parent_path().string();
      rig = lf::write_synthetic_images(std::move(rig), dir);
      std::fprintf(stderr, "lf-rig: %zu images written to %s\n", rig.cameras.size(), dir.c_str());
    }
    if (args.has("--out")) lf::save_rig(rig, args.get("--out"));
    if (args.has("--ids"))
      for (const auto& c : rig.cameras) std::printf("%d\n", c.id);
    if (args.has("--hosts"))
      for (int h : lf::host_blocks(rig, static_cast<int>(args.number("--hosts", 1))))
        std::printf("%d\n", h);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lf-rig: error: %s\n", e.what());
    return 1;
  }
}
