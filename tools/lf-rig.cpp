// lf-rig: writes a rig file (JSON) from a dataset folder or rig file, with an
// optional grid block and image scale; lists camera ids for scripts.
#include <cstdio>
#include <iostream>

#include "cli.h"
#include "lf/datasets.h"

int main(int argc, char** argv) {
  const char* help = R"(lf-rig: make a rig file for the elements and tools.

usage: lf-rig --input PATH [--block R0,C0,ROWS,COLS] [--input-scale S] [--out RIG.json] [--ids]
  --input PATH     dataset folder or rig file
  --block ...      keep only this block of the grid
  --input-scale S  cameras' images resized by S (intrinsics scaled)
  --out FILE       write the rig file (image paths relative to it)
  --ids            print the camera ids, one per line (for scripts)
)";
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::cout << help;
      return 0;
    }
  try {
    cli::Args args(argc, argv, {"--input", "--block", "--input-scale", "--out"}, {"--ids"});
    if (!args.has("--input")) throw std::invalid_argument("--input is required (see --help)");
    lf::Rig rig = lf::load_rig_or_dataset(args.get("--input"));
    for (const auto& w : rig.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    if (args.has("--block")) {
      const auto b = args.numbers("--block", 4, 4);
      rig = lf::grid_block(rig, int(b[0]), int(b[1]), int(b[2]), int(b[3]));
    }
    if (args.has("--input-scale")) rig = lf::scale_rig(rig, args.number("--input-scale", 1));
    if (args.has("--out")) lf::save_rig(rig, args.get("--out"));
    if (args.has("--ids"))
      for (const auto& c : rig.cameras) std::printf("%d\n", c.id);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lf-rig: error: %s\n", e.what());
    return 1;
  }
}
