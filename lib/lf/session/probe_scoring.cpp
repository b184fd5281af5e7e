#include "lf/session/probe_scoring.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <optional>
#include <system_error>
#include <utility>

#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"

namespace lf {
namespace {

// An outcome of `probe` (a ProbeCollector's) with what every kind has.
template <class Probe>
ProbeOutcome outcome_of(ProbeOutcome::Kind kind, const Probe& probe) {
  ProbeOutcome o;
  o.kind = kind;
  o.viewer = probe.viewer, o.probe = probe.id;
  o.fragments = probe.answers.fragments();
  o.sat_out = probe.answers.sat_out();
  o.cameras = probe.answers.complete_cameras();
  o.capture_time_ns = probe.answers.capture_time_ns();
  return o;
}

}  // namespace

void ProbeScoring::absorb(const uint8_t* data, size_t size, int width, int height,
                          const SurfaceOptions& surface, int64_t now_us) {
  for (const FragmentSpan& s : split_probe_answer(data, size)) {
    if (is_focus_probe(s.head.sequence))
      absorb_focus(data + s.offset, s.size, s.head.sequence, now_us);
    else if (is_surface_probe(s.head.sequence))
      absorb_surface(data + s.offset, s.size, s.head.sequence, s.head.viewer_id, width, height,
                     surface, now_us);
  }
}

void ProbeScoring::absorb_focus(const uint8_t* data, size_t size, uint64_t sequence,
                                int64_t now_us) {
  const uint32_t id = focus_probe_id(sequence);
  auto it = focus_.find(id);
  if (it == focus_.end() && focus_.scored(id)) return;  // late: scored already
  Fragment f = parse_fragment(data, size, nullptr, size_t{kFocusProbeSide} * kFocusProbeSide);
  if (it == focus_.end()) {
    if (focus_.full()) finish_focus(focus_.oldest());
    it = focus_.open({id, f.viewer_id, now_us, {}});
  }
  auto& answers = it->second.answers;
  if (!answers.add(focus_probe_step(sequence), std::move(f))) return;
  const size_t cameras = rig_ ? rig_->cameras.size() : 0;
  if (cameras > 0 && answers.fragments() >= cameras * kFocusProbeSteps) finish_focus(it);
}

void ProbeScoring::absorb_surface(const uint8_t* data, size_t size, uint64_t sequence,
                                  uint32_t viewer, int width, int height, const SurfaceOptions& opt,
                                  int64_t now_us) {
  const uint32_t id = surface_probe_id(sequence);
  auto it = surface_.find(id);
  if (it == surface_.end() && surface_.scored(id)) return;
  if (it == surface_.end()) {
    SurfaceProbeAnswers answers(width, height, opt);  // throws on a bad size
    if (surface_.full()) finish_surface(surface_.oldest());
    it = surface_.open({id, viewer, now_us, std::move(answers)});
  }
  auto& answers = it->second.answers;
  Fragment f = parse_fragment(data, size, nullptr,
                              static_cast<size_t>(answers.probe_width()) * answers.probe_height());
  if (!answers.add(surface_probe_step(sequence), std::move(f))) return;
  const size_t cameras = rig_ ? rig_->cameras.size() : 0;
  if (cameras > 0 && answers.fragments() >= cameras * SurfaceOptions{}.planes) finish_surface(it);
}

void ProbeScoring::expire(int64_t now_us, int64_t deadline_us) {
  for (uint32_t id : focus_.expired(now_us, deadline_us)) finish_focus(focus_.find(id));
  for (uint32_t id : surface_.expired(now_us, deadline_us)) finish_surface(surface_.find(id));
}

std::vector<ProbeOutcome> ProbeScoring::take() {
  collect(false);
  return std::exchange(outcomes_, {});
}

void ProbeScoring::finish_focus(FocusProbes::Iter it) {
  const auto probe = focus_.take(it);
  ProbeOutcome o = outcome_of(ProbeOutcome::Kind::kFocus, probe);
  try {
    if (!rig_)
      o.why = "no rig to score it with";
    else if (probe.answers.best(*rig_, &o.inverse_depth))
      o.result = ProbeOutcome::Result::kAnswer;
    else
      o.why = "too few pixels seen by two cameras";
  } catch (const std::exception& e) {
    o.why = e.what();
  }
  outcomes_.push_back(std::move(o));
}

ProbeScoring::~ProbeScoring() {
  for (Running& r : running_)
    if (r.estimated.valid()) r.estimated.wait();  // at most kMaxSurfaceProbes estimates
}

ProbeScoring::Estimated ProbeScoring::estimate_surface(const SurfaceProbes::Probe& probe,
                                                       const SurfacePrior* prior,
                                                       bool every_core) const {
  Estimated r;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    if (rig_) r.e = probe.answers.estimate(*rig_, &r.ok, prior, every_core);
  } catch (const std::exception& ex) {
    r.why = ex.what(), r.threw = true, r.ok = false;
  }
  r.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

void ProbeScoring::finish_surface(SurfaceProbes::Iter it) {
  auto probe = std::make_shared<SurfaceProbes::Probe>(surface_.take(it));
  auto prior_of = [&]() -> const SurfacePrior* {
    const auto prior = priors_.find(probe->viewer);
    return prior == priors_.end() ? nullptr : &prior->second;
  };
  if (background_) {
    // On a thread of its own, with a copy of the viewer's prior; concluded
    // by take() once it is done. That thread alone: beside the compositor's
    // loops, which would otherwise run on one thread while it lasts
    // (SurfaceProbeAnswers::estimate).
    std::optional<SurfacePrior> copy;
    if (const SurfacePrior* prior = prior_of()) copy = *prior;
    try {
      Running r;
      r.probe = probe;
      r.estimated = std::async(std::launch::async, [this, probe, copy] {
        return estimate_surface(*probe, copy ? &*copy : nullptr, false);
      });
      running_.push_back(std::move(r));
      return;
    } catch (const std::system_error&) {  // no thread to be had: at once, after those running
      collect(true);
    }
  }
  conclude_surface(*probe, estimate_surface(*probe, prior_of()));
}

void ProbeScoring::collect(bool block) {
  while (!running_.empty()) {
    Running& r = running_.front();
    if (!block && r.estimated.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
      return;
    Estimated e = r.estimated.get();
    const std::shared_ptr<SurfaceProbes::Probe> probe = r.probe;
    running_.pop_front();
    conclude_surface(*probe, std::move(e));
  }
}

void ProbeScoring::wait() {
  collect(true);
}

void ProbeScoring::conclude_surface(const SurfaceProbes::Probe& probe, Estimated est) {
  ProbeOutcome o = outcome_of(ProbeOutcome::Kind::kSurface, probe);
  SurfaceEstimate& e = est.e;
  const bool ok = est.ok, threw = est.threw;
  if (threw) o.why = est.why;
  o.estimate_ms = est.ms;
  const auto prior = priors_.find(probe.viewer);
  if (!ok) {
    // Every camera sat the probe out (its instant was not among their
    // frames: a live pipeline starting, or a host overloaded): nothing was
    // measured and the next probe measures. Only twice in a row is it worth
    // a warning (the viewer keeps its plane meanwhile).
    // A probe scored before every camera answered every step (a busy host),
    // or that some cameras sat out (a live host starting: the cameras that
    // see the view may be among them), is the same: the next probe
    // measures again.
    const size_t expected = rig_ ? rig_->cameras.size() * SurfaceOptions{}.planes : 0;
    const bool unmeasured = probe.answers.pixels() == 0 || probe.answers.fragments() < expected ||
                            probe.answers.sat_out() > 0;
    if (!threw && rig_ && unmeasured && unmeasured_in_a_row_++ == 0)
      o.result = probe.answers.pixels() == 0 ? ProbeOutcome::Result::kSatOut
                                             : ProbeOutcome::Result::kIncomplete;
    else if (!threw)
      o.why = rig_ ? "fewer than 3 planes answered by every complete camera, or no pixel seen "
                     "by most of the aperture"
                   : "no rig to estimate it with";
    outcomes_.push_back(std::move(o));
    return;
  }
  unmeasured_in_a_row_ = 0;
  if (priors_.size() >= kMaxPriors && prior == priors_.end()) priors_.clear();
  const SurfaceOptions opt;
  priors_[probe.viewer] = prior_of(e, (probe.answers.width() + opt.tile - 1) / opt.tile,
                                   (probe.answers.height() + opt.tile - 1) / opt.tile);
  o.result = ProbeOutcome::Result::kAnswer;
  o.surface = std::move(e.surface);
  if (o.surface.empty()) {  // one plane everywhere
    const int w = probe.answers.width(), h = probe.answers.height();
    o.surface.tile = opt.tile;
    o.surface.cols = (w + opt.tile - 1) / opt.tile;
    o.surface.rows = (h + opt.tile - 1) / opt.tile;
    o.surface.planes = {e.single};
    o.surface.plane_of.assign(static_cast<size_t>(o.surface.cols) * o.surface.rows, 0);
  }
  o.planes_used = e.planes_used;
  o.textured = static_cast<size_t>(std::count(e.textured.begin(), e.textured.end(), true));
  o.tiles = e.textured.size();
  outcomes_.push_back(std::move(o));
}

std::string ProbeOutcome::describe() const {
  char line[256];
  const bool focus = kind == Kind::kFocus;
  if (result == Result::kSatOut)
    std::snprintf(line, sizeof line, "surface probe %u: every camera sat it out (%d cameras)",
                  probe, cameras);
  else if (result == Result::kIncomplete)
    std::snprintf(line, sizeof line,
                  "surface probe %u: scored before every camera answered, or with cameras that "
                  "sat it out (%zu fragments, %zu sat out, from %d complete cameras); the next "
                  "probe measures again",
                  probe, fragments, sat_out, cameras);
  else if (result == Result::kFailed && focus)
    std::snprintf(line, sizeof line, "probe %u: %s (%zu fragments)", probe, why.c_str(), fragments);
  else if (result == Result::kFailed)
    std::snprintf(line, sizeof line,
                  "surface probe %u: %s (%zu fragments, %zu sat out, from %d cameras)", probe,
                  why.c_str(), fragments, sat_out, cameras);
  else if (focus)
    std::snprintf(line, sizeof line,
                  "focus probe %u: inverse depth %g from %d cameras (%zu fragments)", probe,
                  inverse_depth, cameras, fragments);
  else
    std::snprintf(line, sizeof line,
                  "surface probe %u: %d planes (%zu of %zu tiles textured) from %d cameras (%zu "
                  "fragments), estimated in %.1f ms",
                  probe, planes_used, textured, tiles, cameras, fragments, estimate_ms);
  return line;
}

const char* ProbeOutcome::summary() const {
  return kind == Kind::kFocus ? "Cannot focus at the clicked point"
                              : "Cannot estimate the focal surface";
}

}  // namespace lf
