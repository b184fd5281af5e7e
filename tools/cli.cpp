#include "cli.h"

#include <glib.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "lf/geometry/rig_ops.h"
#include "lf/io/datasets.h"
#include "lf/io/rig_file.h"

namespace cli {

Args::Args(int argc, char** argv, const std::vector<std::string>& with_value,
           const std::vector<std::string>& bare) {
  // GLib's GOption, as the GStreamer tools parse (--key value or
  // --key=value); the option names as the tool gives them ("--name").
  std::vector<gchar*> strings(with_value.size(), nullptr);
  std::vector<gboolean> flags(bare.size(), FALSE);
  std::vector<std::string> names;
  std::vector<GOptionEntry> entries;
  names.reserve(with_value.size() + bare.size());
  for (const std::string& k : with_value) names.push_back(k.rfind("--", 0) == 0 ? k.substr(2) : k);
  for (const std::string& k : bare) names.push_back(k.rfind("--", 0) == 0 ? k.substr(2) : k);
  for (size_t i = 0; i < with_value.size(); ++i)
    entries.push_back({names[i].c_str(), 0, 0, G_OPTION_ARG_STRING, &strings[i], nullptr, "V"});
  for (size_t i = 0; i < bare.size(); ++i)
    entries.push_back({names[with_value.size() + i].c_str(), 0, 0, G_OPTION_ARG_NONE, &flags[i],
                       nullptr, nullptr});
  entries.push_back({nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr});
  GOptionContext* ctx = g_option_context_new(nullptr);
  g_option_context_set_help_enabled(ctx, FALSE);  // help_requested() prints the tool's
  g_option_context_add_main_entries(ctx, entries.data(), nullptr);
  gchar** args = g_new0(gchar*, argc + 1);
  for (int i = 0; i < argc; ++i) args[i] = g_strdup(argv[i]);
  GError* err = nullptr;
  const gboolean ok = g_option_context_parse_strv(ctx, &args, &err);
  const std::string leftover = ok && args[0] && args[1] ? args[1] : "";
  g_strfreev(args);
  g_option_context_free(ctx);
  std::string why;
  if (!ok) {
    why = std::string(err->message) + " (see --help)";
    g_error_free(err);
  } else if (!leftover.empty()) {
    why = "unknown option '" + leftover + "' (see --help)";
  }
  for (size_t i = 0; i < with_value.size(); ++i) {
    if (strings[i]) values_[with_value[i]] = strings[i];
    g_free(strings[i]);
  }
  for (size_t i = 0; i < bare.size(); ++i)
    if (flags[i]) values_[bare[i]] = "1";
  if (!why.empty()) throw std::invalid_argument(why);
}

std::string Args::get(const std::string& k, const std::string& def) const {
  auto it = values_.find(k);
  return it == values_.end() ? def : it->second;
}

double Args::number(const std::string& k, double def) const {
  if (!has(k)) return def;
  return parse_numbers(get(k), k).at(0);
}

int Args::integer(const std::string& k, int def) const {
  if (!has(k)) return def;
  const double v = number(k, def);
  if (v != std::floor(v) || std::abs(v) > 1e9)
    throw std::invalid_argument("option " + k + " must be an integer");
  return static_cast<int>(v);
}

std::vector<double> Args::numbers(const std::string& k, size_t n_min, size_t n_max) const {
  auto v = parse_numbers(get(k), k);
  if (v.size() < n_min || v.size() > n_max)
    throw std::invalid_argument("option " + k + " takes " + std::to_string(n_min) +
                                (n_max != n_min ? ".." + std::to_string(n_max) : "") +
                                " comma-separated numbers");
  return v;
}

bool help_requested(int argc, char** argv, const char* help) {
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::fputs(help, stdout);
      return true;
    }
  return false;
}

lf::Rig select_cameras(lf::Rig rig, const Args& args, bool default_8x8) {
  if (args.has("--block")) args.numbers("--block", 4, 4);  // checks the count
  return select_cameras(
      std::move(rig), args.get("--block"), args.has("--spread") ? args.integer("--spread", 0) : 0,
      args.has("--input-scale") ? args.number("--input-scale", 1) : 1.0, default_8x8);
}

lf::Rig select_cameras(lf::Rig rig, const std::string& block, int spread, double input_scale,
                       bool default_8x8) {
  for (const auto& w : rig.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  if (!block.empty()) {
    const auto b = parse_numbers(block, "--block");
    if (b.size() != 4) throw std::invalid_argument("--block needs R0,C0,ROWS,COLS");
    rig = lf::grid_block(rig, int(b[0]), int(b[1]), int(b[2]), int(b[3]));
  } else if (default_8x8 && rig.grid.rows >= 8 && rig.grid.cols >= 8) {
    rig = lf::grid_block(rig, 0, 0, 8, 8);
  }
  if (spread != 0) rig = lf::grid_spread(rig, spread);
  if (input_scale != 1.0) rig = lf::scale_rig(rig, input_scale);
  return rig;
}

std::vector<double> parse_numbers(const std::string& s, const std::string& what) {
  return lf::parse_number_list(s, what);
}

void parse_size(const std::string& s, int& w, int& h) {
  const auto x = s.find('x');
  if (x == std::string::npos) throw std::invalid_argument("size '" + s + "' must be WIDTHxHEIGHT");
  w = static_cast<int>(parse_numbers(s.substr(0, x), "width")[0]);
  h = static_cast<int>(parse_numbers(s.substr(x + 1), "height")[0]);
  if (w < 2 || h < 2 || w > 16384 || h > 16384)
    throw std::invalid_argument("size '" + s + "' outside 2..16384");
}

void progress(const std::string& label, int done, int total) {
  static const bool tty = isatty(2);
  if (!tty && done != total && done % std::max(1, total / 4) != 0) return;
  const int width = 30, filled = total ? width * done / total : width;
  std::fprintf(stderr, "%s%s [%s%s] %d/%d%s", tty ? "\r" : "", label.c_str(),
               std::string(filled, '#').c_str(), std::string(width - filled, ' ').c_str(), done,
               total, (!tty || done == total) ? "\n" : "");
  std::fflush(stderr);
}

lf::Backend backend_from(const std::string& text, bool quiet) {
  lf::Backend asked;
  if (!lf::parse_backend(text, &asked))
    throw std::invalid_argument("--backend '" + text + "': use auto, cpu or gl");
  std::string why;
  const lf::Backend b = lf::resolve_backend(asked, &why);
  if (!quiet) {
    if (asked == lf::Backend::kAuto)
      std::fprintf(stderr, "%s\n", why.c_str());
    else if (b == lf::Backend::kGl)
      std::fprintf(stderr, "backend gl: %s\n", lf::gl_info().renderer.c_str());
  }
  return b;
}

FocalSpec parse_focal(const std::string& s, const lf::Rig& rig) {
  FocalSpec f;
  f.text = s;
  if (s == "auto" || s == "plane") return f;  // the paper's: one plane, auto-focused
  if (s == "surface") {
    f.kind = FocalSpec::kSurface;
    return f;
  }
  f.kind = FocalSpec::kPlane;
  f.plane = lf::parse_focal_plane(s, rig);
  return f;
}

lf::Sampling parse_sampling(const std::string& text) {
  if (text == "bilinear") return lf::Sampling::kBilinear;
  if (text == "bicubic") return lf::Sampling::kBicubic;
  throw std::invalid_argument("sampling '" + text + "': bilinear or bicubic");
}

}  // namespace cli
