#include "lf/focus/probe_answers.h"

#include <algorithm>

namespace lf {

bool ProbeFragments::keep(int step, int steps, Fragment f) {
  if (step < 0 || step >= steps) return false;
  auto& answers = by_camera_[f.camera_id];
  for (const auto& a : answers)
    if (a.first == step) return false;
  sat_out_ += f.empty() && f.capture_time_ns < 0;
  answers.emplace_back(step, std::move(f));
  ++count_;
  return true;
}

int ProbeFragments::steps() const {
  size_t most = 0;
  for (const auto& [camera, answers] : by_camera_) most = std::max(most, answers.size());
  return static_cast<int>(most);
}

int ProbeFragments::complete_cameras() const {
  const size_t most = static_cast<size_t>(steps());
  int n = 0;
  for (const auto& [camera, answers] : by_camera_) n += answers.size() == most;
  return n;
}

int64_t ProbeFragments::capture_time_ns() const {
  int64_t t = -1;
  for_each_complete([&](int, const Fragment& f) { t = std::max(t, f.capture_time_ns); });
  return t;
}

}  // namespace lf
