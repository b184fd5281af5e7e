// Helpers shared by the command-line tools (argument parsing, progress
// output, focal-plane specifications, camera paths).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "lf/focus/focus.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/parse.h"
#include "lf/io/path_file.h"
#include "lf/quality/quality.h"
#include "lf/render/composite.h"
#include "lf/render/gl_render.h"
#include "lf/render/render.h"
#include "lf/render/render_view.h"

namespace cli {

// --key value (or --key=value) / --flag parsing, by GLib's GOption as the
// GOption tools parse theirs. Unknown options and stray arguments are an
// error (std::invalid_argument).
class Args {
 public:
  Args(int argc, char** argv, const std::vector<std::string>& flags_with_value,
       const std::vector<std::string>& bare_flags);
  bool has(const std::string& k) const { return values_.count(k) > 0; }
  std::string get(const std::string& k, const std::string& def = "") const;
  double number(const std::string& k, double def) const;
  int integer(const std::string& k, int def) const;
  std::vector<double> numbers(const std::string& k, size_t n_min, size_t n_max) const;

 private:
  std::map<std::string, std::string> values_;
};

// True (after printing `help` on stdout) when the arguments ask for help.
bool help_requested(int argc, char** argv, const char* help);

// Applies --block (or, when absent and `default_8x8` is set and the grid is
// large enough, the 8x8 block at 0,0) and --input-scale to a rig, and prints
// the rig's import warnings on stderr.
lf::Rig select_cameras(lf::Rig rig, const Args& args, bool default_8x8 = false);
// The same from values (tools that parse with GOption): `block` "R0,C0,ROWS,COLS"
// or empty, `spread` 0 for none, `input_scale` 1 for none.
lf::Rig select_cameras(lf::Rig rig, const std::string& block, int spread, double input_scale,
                       bool default_8x8);

std::vector<double> parse_numbers(const std::string& s, const std::string& what);
void parse_size(const std::string& s, int& w, int& h);

// Prints "label [#####    ] k/n" on stderr (a single updating line on a
// terminal, a few lines otherwise).
void progress(const std::string& label, int done, int total);

// Focal-plane specification: "surface", "auto" (or "plane": the paper's one
// auto-focused plane), "infinity", "depth:Z", "param:A"
// (light-slab focal parameter), "plane:nx,ny,nz,d".
struct FocalSpec {
  enum Kind { kAuto, kPlane, kSurface } kind = kAuto;
  lf::FocalPlane plane;
  std::string text;
};
FocalSpec parse_focal(const std::string& s, const lf::Rig& rig);

// --backend auto|cpu|gl resolved (lf/render/gl_render.h resolve_backend): prints
// which renderer runs and why on stderr unless `quiet`; throws
// std::invalid_argument for another word and std::runtime_error when gl is
// asked for and unavailable.
lf::Backend backend_from(const std::string& text, bool quiet);

// --sampling bilinear|bicubic (lf/geometry/view.h Sampling); throws
// std::invalid_argument for another word.
lf::Sampling parse_sampling(const std::string& text);

}  // namespace cli
