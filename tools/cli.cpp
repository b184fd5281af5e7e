#include "cli.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace cli {

Args::Args(int argc, char** argv, const std::vector<std::string>& with_value,
           const std::vector<std::string>& bare) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (std::find(bare.begin(), bare.end(), a) != bare.end()) {
      values_[a] = "1";
    } else if (std::find(with_value.begin(), with_value.end(), a) != with_value.end()) {
      if (i + 1 >= argc) throw std::invalid_argument("option " + a + " needs a value");
      values_[a] = argv[++i];
    } else {
      throw std::invalid_argument("unknown option '" + a + "' (see --help)");
    }
  }
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

std::vector<double> parse_numbers(const std::string& s, const std::string& what) {
  std::vector<double> out;
  std::stringstream ss(s);
  std::string tok;
  while (std::getline(ss, tok, ',')) {
    size_t used = 0;
    double v;
    try {
      v = std::stod(tok, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != tok.size() || !std::isfinite(v))
      throw std::invalid_argument(what + ": '" + tok + "' is not a number");
    out.push_back(v);
  }
  if (out.empty()) throw std::invalid_argument(what + ": no value");
  return out;
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

FocalSpec parse_focal(const std::string& s, const lf::Rig& rig) {
  FocalSpec f;
  f.text = s;
  if (s == "auto") return f;
  f.kind = FocalSpec::kPlane;
  f.plane = lf::parse_focal_plane(s, rig);
  return f;
}

}  // namespace cli
