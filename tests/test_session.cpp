// The session classes (lib/lf/session): the camera host's request queue
// and the compositor host's frame assembly, without a pipeline.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "lf/focus/focus.h"
#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/quality/synthetic.h"
#include "lf/render/quilt.h"
#include "lf/render/render.h"
#include "lf/session/camera_frames.h"
#include "lf/session/camera_host.h"
#include "lf/session/compositor_host.h"
#include "lf/session/frame_assembly.h"
#include "lf/session/request_queue.h"
#include "lf/session/viewer.h"
#include "lf/session/viewer_session.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"

using Verdict = lf::RequestWindow::Verdict;

namespace {
// A request of viewer `viewer` (sequence `seq`) for a 40-degree view from
// `eye` looking at `at`, focused on the plane z = 10 (the synthetic rigs'
// cameras look along +z from z = 0).
lf::ViewRequest view_request(uint32_t viewer, uint64_t seq, cv::Vec3d eye,
                             cv::Vec3d at = {0, 0, 10}, int width = 160, int height = 120) {
  lf::ViewRequest req;
  req.viewer_id = viewer, req.sequence = seq;
  req.view = lf::VirtualView::look_at(eye, at, {0, 1, 0}, 40, width, height);
  req.focal_plane = lf::FocalPlane::through({0, 0, 10}, {0, 0, 1});
  return req;
}
}  // namespace

// lf::RequestQueue (lib/lf/session/request_queue.h): each key keeps its requests
// within max_age of its newest (0: the newest alone), the keys are served in
// turn, and the capacity takes the oldest of the longest queue.
TEST(RequestQueue, NewestWinsPerKeyAndKeysTakeTurns) {
  lf::RequestQueue<int> q(64, 0);
  // Keys are viewer << 1 | probe: 2 and 4 are two viewers. Viewer 2 floods
  // 10 requests alone: only its newest waits. Viewer 4 sends 3 while viewer
  // 2's waits: not over its share, it keeps them (kHeld).
  std::vector<int> dropped;
  for (int i = 0; i < 10; ++i)
    for (int d : q.push(2, 1000 + i, 100 + i)) dropped.push_back(d);
  for (int i = 0; i < 4; ++i)
    for (int d : q.push(4, 1000 + i, 200 + i)) dropped.push_back(d);
  EXPECT_EQ(q.size(), 4u);
  EXPECT_EQ(dropped.size(), 10u);  // 100..108, and 200 (over kHeld)
  EXPECT_EQ(q.pop(), 109);         // equal tags: key order
  EXPECT_EQ(q.pop(), 201);
  EXPECT_EQ(q.pop(), 202);
  EXPECT_EQ(q.pop(), 203);
  EXPECT_TRUE(q.empty());
  // Over its share (viewer 4 was just served three times), the newest wins
  // again for it while viewer 2 waits; a viewer's own probe key (5) is not
  // another viewer.
  q.push(2, 2000, 110);
  q.push(4, 2000, 210);
  q.push(4, 2001, 211);
  EXPECT_EQ(q.size(), 2u);
  EXPECT_EQ(q.pop(), 110);
  EXPECT_EQ(q.pop(), 211);
  q.push(5, 3000, 500);
  q.push(4, 3000, 220);
  q.push(4, 3001, 221);
  EXPECT_EQ(q.size(), 2u);
  q.clear();
}

TEST(RequestQueue, AgeKeepsRecentRequestsInOrderAndTurnsAlternate) {
  lf::RequestQueue<int> q(64, 100);  // 100 ns of age
  for (int t : {0, 50, 100, 150, 250}) q.push(7, static_cast<uint64_t>(t), t);
  // 0 went at 150; at 250, 50 and 100 are over 100 ns behind it, 150 is not.
  EXPECT_EQ(q.size(), 2u);
  q.push(9, 300, 900);
  q.push(9, 310, 910);
  // Turns: key 7's oldest, key 9's oldest, key 7, key 9.
  EXPECT_EQ(q.pop(), 150);
  EXPECT_EQ(q.pop(), 900);
  EXPECT_EQ(q.pop(), 250);
  EXPECT_EQ(q.pop(), 910);
  EXPECT_TRUE(q.empty());
}

// Turns weighted by cost: a viewer of large views (cost 40, 3840x2160
// against 640x480 is about 27) waiting beside one of small views (cost 1)
// is served once for every 40 of the other's; an idle key saves no credit.
TEST(RequestQueue, TurnsWeightedByCost) {
  lf::RequestQueue<int> q(64, 1000000);
  std::vector<int> order;
  for (int round = 0; round < 60; ++round) {
    q.push(1, static_cast<uint64_t>(round), 100 + round, 40);  // large, always waiting
    q.push(2, static_cast<uint64_t>(round), 200 + round, 1);
    order.push_back(q.pop());
  }
  int large = 0;
  for (int v : order) large += v < 200;
  EXPECT_EQ(large, 2);  // the first turn, then once 40 small ones were served
  EXPECT_EQ(order.front(), 100);
  // Key 2 left; key 3 arrives fresh: no credit, no debt: it goes before key 1
  // (whose tag is ahead), and after one request each they alternate by tag.
  q.clear();
  q.push(1, 0, 1, 40);
  q.push(3, 0, 3, 40);
  EXPECT_EQ(q.pop(), 1);  // equal tags: key order
  q.push(1, 1, 11, 40);
  EXPECT_EQ(q.pop(), 3);
  EXPECT_EQ(q.pop(), 11);
}

TEST(RequestQueue, ACheapViewerKeepsItsRequestsWhileACostlyOneHoldsTheCameras) {
  lf::RequestQueue<int> q(64, 0);
  // Viewer 2 asks for 3840x2160 (27 times the pixels), viewer 4 for
  // 640x480. Viewer 2's request is served (it holds the cameras), then
  // viewer 4's; while the cameras are held, viewer 4 sends three more, one
  // a frame period (33 ms) apart. It has been served less than viewer 2
  // and viewer 2 was served within the last second, so it keeps all three
  // (before, only the newest: just served itself, it was past the virtual
  // time, and a 640x480 viewer beside a 4K flood lost 1 request in 10).
  q.push(2, 0, 100, 27);
  q.push(4, 0, 200, 1);
  EXPECT_EQ(q.pop(), 100);  // equal tags: key order
  EXPECT_EQ(q.pop(), 200);
  std::vector<int> dropped;
  for (uint64_t i = 1; i <= 3; ++i)
    for (int d : q.push(4, i * 33000000, 200 + static_cast<int>(i), 1)) dropped.push_back(d);
  EXPECT_TRUE(dropped.empty());
  EXPECT_EQ(q.size(), 3u);
  // Viewer 2, served more, keeps only its newest.
  q.push(2, 40000000, 110, 27);
  q.push(2, 41000000, 111, 27);
  EXPECT_EQ(q.size(), 4u);
  EXPECT_EQ(q.pop(), 201);
  EXPECT_EQ(q.pop(), 202);
  EXPECT_EQ(q.pop(), 203);
  EXPECT_EQ(q.pop(), 111);
  // Over a second after viewer 2's last turn, viewer 4 is alone: its newest wins.
  q.push(4, 2500000000, 210, 1);
  q.push(4, 2500000001, 211, 1);
  EXPECT_EQ(q.size(), 1u);
  EXPECT_EQ(q.pop(), 211);
}

TEST(RequestQueue, CapacityDropsFromTheLongestQueue) {
  lf::RequestQueue<int> q(4, 1000000);
  q.push(1, 0, 10);
  for (int i = 0; i < 5; ++i) q.push(2, static_cast<uint64_t>(i), 20 + i);
  EXPECT_EQ(q.size(), 4u);
  // Key 1's one request survives the flood of key 2.
  std::vector<int> out;
  while (!q.empty()) out.push_back(q.pop());
  EXPECT_EQ(out, (std::vector<int>{10, 22, 23, 24}));
  EXPECT_TRUE(q.clear().empty());
}

// lf::RequestWindow (RFC 3550 appendix A.1): inside the window is taken,
// behind it is late, and one packet far outside never moves it; two
// consecutive ones (or one request apart) do.
TEST(RequestWindow, NoSinglePacketMovesTheWindow) {
  lf::RequestWindow w;
  EXPECT_EQ(w.offer(1000), Verdict::kAccept);  // nothing emitted yet: anything
  w.emitted(1000);
  EXPECT_EQ(w.offer(1001), Verdict::kAccept);
  EXPECT_EQ(w.offer(1000 + lf::RequestWindow::kMaxDropout), Verdict::kAccept);
  EXPECT_EQ(w.offer(1000), Verdict::kLate);
  EXPECT_EQ(w.offer(1000 - lf::RequestWindow::kMaxMisorder), Verdict::kLate);
  EXPECT_EQ(w.late(), 2u);
  // A forged jump of +4000, then the real stream goes on: the window stays.
  EXPECT_EQ(w.offer(5000), Verdict::kProbation);
  EXPECT_EQ(w.candidate(), 5000);
  EXPECT_EQ(w.offer(1002), Verdict::kAccept);
  EXPECT_EQ(w.last_emitted(), 1000);
  // Forgeries each a different distance ahead never confirm one another.
  for (uint64_t jump : {4000u, 4100u, 4200u, 9000u, 200u})
    EXPECT_EQ(w.offer(1000 + jump), Verdict::kProbation) << jump;
  EXPECT_EQ(w.last_emitted(), 1000);
  // A restarted viewer: its second request confirms the first.
  EXPECT_EQ(w.offer(3), Verdict::kProbation);
  EXPECT_EQ(w.offer(5), Verdict::kFollow);  // one request lost in between
  EXPECT_EQ(w.last_emitted(), 4);
  EXPECT_EQ(w.candidate(), -1);
  EXPECT_EQ(w.offer(5), Verdict::kAccept);
  EXPECT_TRUE(w.inside(6));
  EXPECT_FALSE(w.inside(4));
  EXPECT_FALSE(lf::RequestWindow::inside(4, 4 + lf::RequestWindow::kMaxDropout + 1));
  EXPECT_TRUE(lf::RequestWindow::inside(-1, 123456));
  // Sequences near the top of the range do not overflow.
  w.reset();
  w.emitted(UINT64_MAX - 1);
  EXPECT_EQ(w.offer(UINT64_MAX), Verdict::kProbation);  // clamped to INT64_MAX: outside
  EXPECT_EQ(w.offer(0), Verdict::kProbation);
}

TEST(ViewerSelection, FirstViewerSeenAndTheStereoRightEye) {
  lf::ViewerSelection any;
  EXPECT_TRUE(any.accepts(7, false));
  EXPECT_TRUE(any.taken(7));
  EXPECT_FALSE(any.taken(7));
  EXPECT_EQ(any.viewer(), 7);
  EXPECT_FALSE(any.accepts(8, false));
  EXPECT_TRUE(any.accepts(8, true));
  EXPECT_FALSE(any.accepts(6, true));
  // Only foreign fragments for kForeignWarnUs: one warning, once.
  lf::ViewerSelection named(3);
  EXPECT_FALSE(named.foreign(0));
  EXPECT_FALSE(named.foreign(lf::ViewerSelection::kForeignWarnUs - 1));
  EXPECT_TRUE(named.foreign(lf::ViewerSelection::kForeignWarnUs));
  EXPECT_FALSE(named.foreign(lf::ViewerSelection::kForeignWarnUs * 2));
  EXPECT_EQ(named.foreign_count(), 4u);
  EXPECT_DOUBLE_EQ(named.foreign_seconds(lf::ViewerSelection::kForeignWarnUs), 2.0);
  EXPECT_NE(named.foreign_detail(lf::ViewerSelection::kForeignWarnUs, 9)
                .find("4 fragments in 2.0 s, all of other viewers (such as 9)"),
            std::string::npos);
  // One of ours restarts the count (no warning while ours come).
  lf::ViewerSelection b(3);
  b.foreign(0);
  b.taken(3);
  EXPECT_EQ(b.foreign_count(), 0u);
  EXPECT_FALSE(b.foreign(lf::ViewerSelection::kForeignWarnUs));
}

namespace {
// A piece that counts its live copies: discard() and pop_front() must
// release what they drop.
struct Counted {
  std::shared_ptr<int> token;
  int value = 0;
};
using Pending = lf::PendingRequests<uint64_t, Counted>;
std::vector<Counted> one(const std::shared_ptr<int>& token, int value) {
  std::vector<Counted> v;
  v.push_back({token, value});
  return v;
}
bool never(uint64_t) {
  return false;
}
}  // namespace

TEST(PendingRequests, CompleteInOrderDeadlinesPerRequestAndTheCap) {
  Pending p(3);
  auto token = std::make_shared<int>(0);
  // Request 2 is complete (2 cameras) before request 1 (1 of 2).
  EXPECT_EQ(p.add(1, 10, 1, one(token, 1), 500, 400, 33), Pending::Added::kAdded);
  EXPECT_EQ(p.add(2, 10, 1, one(token, 2), 600), Pending::Added::kAdded);
  EXPECT_EQ(p.add(2, 11, 1, one(token, 3)), Pending::Added::kAdded);
  bool complete = true;
  EXPECT_FALSE(p.front_ready(2, never, false, &complete));  // 1 waits, and holds 2 back
  EXPECT_FALSE(complete);
  EXPECT_EQ(p.earliest_running_time(), 500u);
  EXPECT_EQ(p.front().pts, 400u);
  EXPECT_EQ(p.front().duration, 33u);
  // Request 1's deadline: it leaves incomplete, then 2 complete.
  auto due_before_550 = [](uint64_t rt) { return rt < 550; };
  ASSERT_TRUE(p.front_ready(2, due_before_550, false, &complete));
  EXPECT_FALSE(complete);
  EXPECT_EQ(p.front_key(), 1u);
  p.pop_front();
  ASSERT_TRUE(p.front_ready(2, never, false, &complete));
  EXPECT_TRUE(complete);
  EXPECT_EQ(p.front().count, 2u);
  EXPECT_EQ(p.front().pieces.size(), 2u);
  p.pop_front();
  EXPECT_TRUE(p.empty());
  EXPECT_EQ(p.earliest_running_time(), lf::kNoTime);
  // More than 3 waiting: the oldest leaves, incomplete; at the end of
  // stream everything leaves.
  for (uint64_t s = 10; s < 13; ++s) p.add(s, 1, 1, one(token, 0));
  EXPECT_FALSE(p.front_ready(2, never, false, &complete));
  p.add(13, 1, 1, one(token, 0));
  EXPECT_TRUE(p.front_ready(2, never, false, &complete));
  EXPECT_TRUE(p.front_ready(1, never, false, &complete) && complete);
  p.pop_front();
  EXPECT_FALSE(p.front_ready(2, never, false, &complete));
  EXPECT_TRUE(p.front_ready(2, never, true, &complete));
  p.clear();
  EXPECT_EQ(token.use_count(), 1);  // every piece released
}

// Live shedding: the requests before the newest complete one go, whatever
// their state; none goes while no request is complete, nor a conflicted
// one's elders (it never completes).
TEST(PendingRequests, ShedStaleKeepsTheNewestCompleteAndWhatFollowsIt) {
  Pending p;
  auto token = std::make_shared<int>(0);
  p.add(1, 10, 2, one(token, 1));  // complete (2 of 2)
  p.add(2, 10, 1, one(token, 2));  // incomplete
  p.shed_stale(2);                 // 1 is the newest complete: nothing before it
  EXPECT_EQ(p.size(), 2u);
  EXPECT_EQ(p.shed(), 0u);
  p.add(3, 10, 2, one(token, 3));  // complete
  p.add(4, 10, 1, one(token, 4));  // incomplete, newer
  p.shed_stale(2);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p.front_key(), 3u);
  EXPECT_EQ(p.shed(), 2u);
  EXPECT_EQ(token.use_count(), 3);  // the shed requests' pieces are released
  p.pop_front();
  p.add(5, 10, 1, one(token, 5));
  p.add(5, 10, 1, one(token, 6));  // a second copy: conflicted, never complete
  p.discard(5, 10);
  p.shed_stale(1);  // 4 is complete at 1 camera; 5 is conflicted
  EXPECT_EQ(p.front_key(), 4u);
  EXPECT_EQ(p.shed(), 2u);
  p.clear();
  p.shed_stale(1);
  EXPECT_EQ(p.shed(), 2u);
}

TEST(PendingRequests, ASecondCopyOfASourceDropsBothAndTheRequestNeverCompletes) {
  Pending p;
  auto token = std::make_shared<int>(0);
  // A partial sum of 3 cameras and a camera of its own, for 4 in all.
  std::vector<Counted> pair = one(token, 1);
  pair.push_back({token, 2});  // a camera's two layers: two pieces, one source
  EXPECT_EQ(p.add(5, 100, 3, std::move(pair)), Pending::Added::kAdded);
  EXPECT_EQ(p.add(5, 200, 1, one(token, 3)), Pending::Added::kAdded);
  EXPECT_EQ(p.count_of(5), 4u);
  EXPECT_EQ(token.use_count(), 4);
  // A forged copy of source 100: refused, then both copies dropped.
  EXPECT_EQ(p.add(5, 100, 3, one(token, 9)), Pending::Added::kDuplicate);
  EXPECT_EQ(token.use_count(), 4);  // the refused pieces are released
  p.discard(5, 100);
  EXPECT_EQ(p.count_of(5), 1u);
  ASSERT_EQ(p.front().pieces.size(), 1u);
  EXPECT_EQ(p.front().pieces[0].value, 3);
  EXPECT_EQ(token.use_count(), 2);
  bool complete = true;
  EXPECT_FALSE(p.front_ready(1, never, false, &complete));  // conflicted: never complete
  EXPECT_TRUE(p.front().conflicted);
  // A third copy changes nothing; the deadline still sends what is left.
  EXPECT_EQ(p.add(5, 100, 3, one(token, 9)), Pending::Added::kDuplicate);
  p.discard(5, 100);
  EXPECT_EQ(p.count_of(5), 1u);
  EXPECT_TRUE(p.front_ready(
      1, [](uint64_t) { return true; }, false, &complete));
  EXPECT_FALSE(complete);
  p.discard(6, 1);  // an unknown request: nothing
  EXPECT_EQ(p.size(), 1u);
}

TEST(ProbeCollector, BoundedOpenProbesRememberedIdsAndExpiry) {
  struct Answers {
    int fragments = 0;
  };
  lf::ProbeCollector<Answers> c(2);
  auto a = c.open({11, 1, 100, {}});
  a->second.answers.fragments = 3;
  EXPECT_FALSE(c.full());
  c.open({12, 1, 50, {}});
  EXPECT_TRUE(c.full());
  EXPECT_EQ(c.oldest()->first, 12u);  // started first, whatever its id
  EXPECT_EQ(c.expired(160, 100), std::vector<uint32_t>{12});
  EXPECT_TRUE(c.expired(140, 100).empty());
  const auto p = c.take(c.find(11));
  EXPECT_EQ(p.answers.fragments, 3);
  EXPECT_TRUE(c.scored(11));
  EXPECT_EQ(c.find(11), c.end());
  EXPECT_EQ(c.size(), 1u);
  // The last kRemembered scored ids are remembered, no more.
  for (uint32_t id = 100; id < 100 + lf::ProbeCollector<Answers>::kRemembered; ++id)
    c.take(c.open({id, 1, 0, {}}));
  EXPECT_FALSE(c.scored(11));
  EXPECT_TRUE(c.scored(100));
  EXPECT_FALSE(c.scored(12));  // still open, not scored
}

// lf::FocusSchedule: a click is probed with the next tick and retried when
// unanswered; continuous focus probes every kContinuousEvery ticks at the
// last click; answers apply once, in order, the continuous ones smoothed.
TEST(FocusSchedule, ClicksRetriesContinuousProbesAndWhichAnswersApply) {
  lf::FocusSchedule f;
  constexpr uint64_t kRetry = 5;
  // Nothing to probe without a click or continuous focus.
  for (uint64_t k = 0; k < 12; ++k) EXPECT_FALSE(f.probe_for(k, kRetry, false, 640, 480)) << k;
  // Continuous, before any click: the view centre, every 5 ticks.
  auto c = f.probe_for(15, kRetry, true, 640, 480);
  ASSERT_TRUE(c);
  EXPECT_FALSE(c->click);
  EXPECT_DOUBLE_EQ(c->x, 319.5);
  EXPECT_DOUBLE_EQ(c->y, 239.5);
  EXPECT_FALSE(f.probe_for(16, kRetry, true, 640, 480));
  // Its answer: half the way from the plane in use (inverse depth 0.1).
  const auto a = f.answer(c->id, 0.5, 0.1);
  ASSERT_TRUE(a);
  EXPECT_DOUBLE_EQ(*a, 0.3);
  EXPECT_FALSE(f.answer(c->id, 0.5, 0.1));  // once
  // A click: probed with the next tick at the clicked point.
  f.click(10, 20);
  EXPECT_TRUE(f.click_waiting());
  const auto p1 = f.probe_for(17, kRetry, false, 640, 480);
  ASSERT_TRUE(p1 && p1->click);
  EXPECT_EQ(p1->id, c->id + 1);
  EXPECT_DOUBLE_EQ(p1->x, 10);
  EXPECT_DOUBLE_EQ(p1->y, 20);
  EXPECT_FALSE(f.click_waiting());
  // No answer: retried retry_ticks later, at most kClickRetries times.
  EXPECT_FALSE(f.probe_for(21, kRetry, false, 640, 480));
  int retries = 0;
  for (uint64_t k = 22; k < 100; ++k)
    if (auto r = f.probe_for(k, kRetry, false, 640, 480)) {
      EXPECT_TRUE(r->click);
      EXPECT_DOUBLE_EQ(r->x, 10);
      ++retries;
    }
  EXPECT_EQ(retries, lf::FocusSchedule::kClickRetries);
  // The first retry's late answer applies as it is; then the first probe's
  // (older) does not, nor does the same answer twice.
  EXPECT_EQ(f.answer(p1->id + 1, 0.25, 0.1), std::optional<double>(0.25));
  EXPECT_FALSE(f.answer(p1->id, 0.3, 0.1));
  EXPECT_FALSE(f.answer(p1->id + 1, 0.3, 0.1));
  // Continuous probes now go to the clicked point; answers to probes never
  // sent do not apply.
  const auto c2 = f.probe_for(100, kRetry, true, 640, 480);
  ASSERT_TRUE(c2 && !c2->click);
  EXPECT_DOUBLE_EQ(c2->x, 10);
  EXPECT_FALSE(f.answer(c2->id + 7, 0.3, 0.1));
  EXPECT_EQ(f.answer(c2->id, 0.3, 0.1), std::optional<double>(0.1 + 0.5 * (0.3 - 0.1)));
}

// lf::SurfaceSchedule: the first probe at once, then every interval ticks;
// answers newest-first once; a focus change takes the view off the
// surface; without answers probing stops once, live and not live.
TEST(SurfaceSchedule, CadenceAnswersRefocusAndGivingUp) {
  lf::SurfaceSchedule s;
  lf::FocalSurface fs;
  fs.tile = 16, fs.cols = 2, fs.rows = 1;
  fs.planes = {lf::FocalPlane::through({0, 0, 5}, {0, 0, 1})};
  fs.plane_of = {0, 0};
  auto t = s.tick(0, true, 0, "infinity", 10, false, 0);
  EXPECT_EQ(t.probe, 1u);
  EXPECT_EQ(s.tick(5, true, 0, "infinity", 10, false, 0).probe, 0u);
  EXPECT_EQ(s.tick(10, true, 0, "infinity", 10, false, 0).probe, 2u);
  // Not live: the last probe is waited for once.
  EXPECT_EQ(s.wait_for(), std::optional<uint32_t>(2));
  EXPECT_FALSE(s.wait_for());
  EXPECT_TRUE(s.awaiting());
  // Answers: probe 2, then the older 1 is refused, as is one never sent.
  EXPECT_FALSE(s.answer(3, fs));
  EXPECT_TRUE(s.answer(2, fs));
  EXPECT_FALSE(s.answer(1, fs));
  EXPECT_FALSE(s.awaiting());
  EXPECT_TRUE(s.ever_answered());
  EXPECT_EQ(s.surface().cols, 2);
  // The wheel (focal depth set): off the surface, and no probes.
  t = s.tick(11, true, 3.5, "infinity", 10, false, 0);
  EXPECT_TRUE(t.refocused);
  EXPECT_EQ(t.probe, 0u);
  EXPECT_TRUE(s.surface().empty());
  // Live, never answered: after 3 probes and 5 s, one give-up, then none.
  lf::SurfaceSchedule live;
  int64_t us = 1'000'000;
  for (uint64_t k = 0; k < 3; ++k)
    EXPECT_NE(live.tick(k * 10, true, 0, "p", 10, false, us).probe, 0u);
  EXPECT_FALSE(live.tick(30, true, 0, "p", 10, false, us + 4'000'000).gave_up);
  t = live.tick(40, true, 0, "p", 10, false, us + lf::SurfaceSchedule::kGiveUpAfterUs);
  EXPECT_TRUE(t.gave_up);
  EXPECT_EQ(t.probe, 0u);
  for (uint64_t k = 41; k < 200; ++k) {
    t = live.tick(k, true, 0, "p", 10, false, us + 10'000'000);
    EXPECT_FALSE(t.gave_up || t.probe) << k;
  }
  // Not live: the first wait failed gives up at once; setting focal-surface
  // off and on again starts afresh.
  lf::SurfaceSchedule once;
  EXPECT_EQ(once.tick(0, true, 0, "p", 10, false, 0).probe, 1u);
  EXPECT_TRUE(once.tick(1, true, 0, "p", 10, true, 0).gave_up);
  EXPECT_EQ(once.tick(2, false, 0, "p", 10, false, 0).probe, 0u);
  EXPECT_EQ(once.tick(3, true, 0, "p", 10, false, 0).probe, 2u);
}

TEST(Navigation, KeysDragAndWheel) {
  lf::EyeAndFocus v;
  EXPECT_TRUE(lf::key_moves_eye("Left", 2.0, &v));
  EXPECT_TRUE(lf::key_moves_eye("Down", 2.0, &v));
  EXPECT_TRUE(lf::key_moves_eye("KP_Add", 2.0, &v));
  EXPECT_EQ(v.eye, cv::Vec3d(-0.5, 0.5, 2.0));
  EXPECT_FALSE(lf::key_moves_eye("q", 2.0, &v));
  lf::drag_moves_eye(40, -80, 2.0, &v);  // against the drag, 1/40 step a pixel
  EXPECT_EQ(v.eye, cv::Vec3d(-2.5, 4.5, 2.0));
  // The wheel: 0.25 px of parallax per notch between cameras 2 apart at
  // fx = 500: inverse depth 0.25 / 1000 per notch; never behind infinity.
  lf::wheel_moves_focus(4, 500, 2.0, 0.0, 1e12, &v);
  EXPECT_NEAR(v.focal_depth, 1000.0, 1e-9);
  lf::wheel_moves_focus(-8, 500, 2.0, 0.001, 1e12, &v);
  EXPECT_EQ(v.focal_depth, 1e12);
  EXPECT_TRUE(lf::key_moves_eye("r", 2.0, &v));
  EXPECT_EQ(v.eye, cv::Vec3d(0, 0, 0));
  EXPECT_EQ(v.focal_depth, 0);
}

// lf::tick_requests (lib/lf/session/viewer.h): a tick's requests from the
// centre eye's: alone; a stereo pair `baseline` apart along the view's x axis
// (viewer ids v, v + 1); a quilt's one request, cols x rows eyes large, its
// baseline given, from a view cone, or the array's extent.
TEST(ViewerTick, AloneAStereoPairOrAQuilt) {
  const lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.5, 160, 120, 50);
  const lf::ViewRequest req = view_request(4, 9, {0.1, 0.2, -1}, {0.1, 0.2, 10}, 96, 72);
  const cv::Vec3d x(req.view.R(0, 0), req.view.R(0, 1), req.view.R(0, 2));
  EXPECT_EQ(lf::tick_requests(rig, req, {}).size(), 1u);

  lf::TickShape stereo;
  stereo.stereo_baseline = 0.3;
  const auto pair = lf::tick_requests(rig, req, stereo);
  ASSERT_EQ(pair.size(), 2u);
  EXPECT_EQ(pair[0].viewer_id, 4u);
  EXPECT_EQ(pair[1].viewer_id, 5u);
  EXPECT_LT(cv::norm(pair[0].view.position - (req.view.position - 0.15 * x)), 1e-12);
  EXPECT_LT(cv::norm(pair[1].view.position - (req.view.position + 0.15 * x)), 1e-12);
  EXPECT_EQ(pair[1].sequence, req.sequence);

  lf::TickShape quilt;
  quilt.quilt.views = 6, quilt.quilt.cols = 3, quilt.quilt.rows = 2;
  quilt.quilt_baseline = 0.7;
  auto q = lf::tick_requests(rig, req, quilt);
  ASSERT_EQ(q.size(), 1u);
  EXPECT_EQ(q[0].view.width, 288);
  EXPECT_EQ(q[0].view.height, 144);
  EXPECT_EQ(q[0].quilt.baseline, 0.7);
  quilt.quilt_baseline = 0, quilt.view_cone = 10;  // 2 D tan(5 deg), D = 11 along the axis
  q = lf::tick_requests(rig, req, quilt);
  EXPECT_NEAR(q[0].quilt.baseline, 2 * 11 * std::tan(5 * CV_PI / 180), 1e-9);
  quilt.view_cone = 0;  // the array's extent along x: 2 spacings of 0.5
  q = lf::tick_requests(rig, req, quilt);
  EXPECT_NEAR(q[0].quilt.baseline, 1.0, 1e-9);
}

// lf::ViewerSession (lib/lf/session/viewer_session.h): gestures move the eye
// and the focus (kept over the array), a click's focus probe and the surface
// probes go with the next tick, an answered surface is carried by the
// requests, a refocus takes the view off it, and what a tick cannot do is a
// notice, not an exception.
TEST(ViewerSession, GesturesProbesAndTheSurfaceInUse) {
  using Kind = lf::Gesture::Kind;
  auto rig = std::make_shared<const lf::Rig>(lf::synthetic_grid_rig(3, 3, 0.5, 160, 120, 50));
  lf::ViewerSettings s;
  s.width = 160, s.height = 120, s.focal_plane = "depth:10";
  lf::ViewerSession v(rig, 7, lf::build_viewer_views(s, *rig));
  lf::ViewerSettings now = s;  // the settings a tick reads live
  now.focal_surface = false;
  constexpr int64_t kPeriodUs = 33'333;
  lf::ViewerTick t = v.tick(3, now, kPeriodUs, 0);
  ASSERT_EQ(t.requests.size(), 1u);
  EXPECT_EQ(t.requests[0].viewer_id, 7u);
  EXPECT_EQ(t.requests[0].sequence, 3u);
  EXPECT_EQ(t.requests[0].view.width, 160);
  EXPECT_NEAR(lf::inverse_depth_of(*rig, t.requests[0].focal_plane), 0.1, 1e-12);
  EXPECT_TRUE(t.probes.empty());
  EXPECT_TRUE(t.notices.empty());

  // Drag 20 px right: the eye 20/40 of a spacing (0.5) left; far beyond
  // the array it stops at its edge (s = -0.5); release ends the drag.
  lf::Gesture g;
  g.kind = Kind::kPress, g.button = 1, g.x = 10, g.y = 10;
  EXPECT_FALSE(v.navigate(g, s, 1e12));
  g.kind = Kind::kMove, g.x = 30;
  auto moved = v.navigate(g, s, 1e12);
  ASSERT_TRUE(moved);
  EXPECT_NEAR(moved->eye[0], -0.25, 1e-12);
  EXPECT_NEAR(moved->eye[1], 0, 1e-12);
  g.x = 1000;
  moved = v.navigate(g, s, 1e12);
  ASSERT_TRUE(moved);
  EXPECT_NEAR(moved->eye[0], -0.5, 1e-3);  // (just inside the border)
  EXPECT_GE(moved->eye[0], -0.5);
  g.kind = Kind::kRelease;
  EXPECT_FALSE(v.navigate(g, s, 1e12));
  g.kind = Kind::kMove, g.x = 0;
  EXPECT_FALSE(v.navigate(g, s, 1e12));
  // A wheel notch up: nearer (inverse depth + 0.25 / (fx * spacing)).
  g.kind = Kind::kScroll, g.dy = 1;
  moved = v.navigate(g, s, 1e12);
  ASSERT_TRUE(moved);
  const double fx = rig->cameras[0].intrinsics.fx;
  EXPECT_NEAR(1.0 / moved->focal_depth, 0.1 + 0.25 / (fx * 0.5), 1e-12);
  // A key: a quarter spacing.
  g.kind = Kind::kKey, g.key = "Right";
  moved = v.navigate(g, s, 1e12);
  ASSERT_TRUE(moved);
  EXPECT_NEAR(moved->eye[0], 0.125, 1e-12);

  // A right click: the next tick carries its focus probe at that point.
  g.kind = Kind::kPress, g.button = 3, g.x = 40, g.y = 30;
  EXPECT_FALSE(v.navigate(g, s, 1e12));
  t = v.tick(4, now, kPeriodUs, 0);
  ASSERT_TRUE(t.focus_probe);
  EXPECT_TRUE(t.focus_probe->click);
  EXPECT_EQ(t.focus_probe->x, 40);
  ASSERT_EQ(t.probes.size(), 1u);
  EXPECT_TRUE(lf::is_focus_probe(t.probes[0][0].sequence));
  // Its answer (depth 4) applies once; the same again does not.
  EXPECT_NEAR(v.focus_answer(t.focus_probe->id, 0.25, 0, 1e12).value_or(-1), 4, 1e-12);
  EXPECT_FALSE(v.focus_answer(t.focus_probe->id, 0.25, 0, 1e12));

  // The focal surface: a probe with the first tick, none the next; an
  // answer is carried from then on; a refocus takes the view off it.
  now.focal_surface = true;
  t = v.tick(5, now, kPeriodUs, 0);
  ASSERT_EQ(t.probes.size(), 1u);
  EXPECT_TRUE(lf::is_surface_probe(t.probes[0][0].sequence));
  EXPECT_EQ(t.surface_planes, 0u);
  lf::FocalSurface surface;
  surface.tile = 16, surface.cols = 10, surface.rows = 8;
  surface.planes = {lf::plane_at_inverse_depth(*rig, 0.1), lf::plane_at_inverse_depth(*rig, 0.2)};
  surface.plane_of.assign(80, 0);
  surface.plane_of[5] = 1;
  ASSERT_TRUE(v.surface().answer(t.surface_probe, surface));
  t = v.tick(6, now, kPeriodUs, 0);
  EXPECT_TRUE(t.probes.empty());
  EXPECT_EQ(t.surface_planes, 2u);
  EXPECT_EQ(t.requests[0].surface.plane_of, surface.plane_of);
  now.focal_depth = 3;
  t = v.tick(7, now, kPeriodUs, 0);
  EXPECT_TRUE(t.refocused);
  EXPECT_EQ(t.surface_planes, 0u);
  EXPECT_TRUE(t.requests[0].surface.empty());

  // A stereo pair; f-number on a rig without a length unit is a notice.
  s.stereo_baseline = 0.2, s.f_number = 2;
  lf::Rig unitless = *rig;
  unitless.unit = "";
  lf::ViewerSession w(std::make_shared<const lf::Rig>(unitless), 2,
                      lf::build_viewer_views(s, unitless));
  now = s;
  now.focal_surface = false;
  t = w.tick(0, now, kPeriodUs, 0);
  ASSERT_EQ(t.requests.size(), 2u);
  EXPECT_EQ(t.requests[1].viewer_id, 3u);
  ASSERT_EQ(t.notices.size(), 1u);
  EXPECT_EQ(t.notices[0].kind, lf::ViewerNotice::Kind::kFNumberIgnored);
  // A bad setting is refused when the views are built.
  s.position = {1, 2};
  EXPECT_THROW(lf::build_viewer_views(s, *rig), std::invalid_argument);
}

// lf::CameraFrames (lib/lf/session/camera_frames.h): the newest frame, the
// frame of a request's capture time (waiting until it is known, at most the
// timeout when live), a probe's one frame (a live camera without the
// probe's instant sits it out), a camera not live held kAhead frames ahead
// of the requests, and the ends and flushing that release every wait.
TEST(CameraFrames, NewestCaptureTimeProbesHoldingAndEnds) {
  using Frames = lf::CameraFrames<std::shared_ptr<int>>;
  using namespace std::chrono;
  constexpr int64_t kMs = 1'000'000;  // ns
  const auto frame = [](int v) { return std::make_shared<int>(v); };
  const auto value = [](const Frames::Pick& p) { return p.frame ? *p.frame : -1; };
  {
    Frames f(2);
    f.set_camera(1, 33 * kMs);
    f.push(0, frame(0)), f.push(33 * kMs, frame(33));
    EXPECT_EQ(value(f.pick({}, seconds(5))), 33);
    f.set_keep(8);
    f.push(66 * kMs, frame(66));
    Frames::Want w;
    w.by_capture_time = true, w.time_ns = 40 * kMs;  // 33 is known to be the one: 66 came
    EXPECT_EQ(value(f.pick(w, seconds(5))), 33);
    // 100 ms: not known until a frame after 67 ms comes.
    w.time_ns = 100 * kMs;
    std::thread camera([&] {
      std::this_thread::sleep_for(milliseconds(20));
      f.push(100 * kMs, frame(100));
    });
    EXPECT_EQ(value(f.pick(w, seconds(5))), 100);
    camera.join();
    // Live, nothing newer comes: after the timeout, the newest before.
    w.time_ns = 200 * kMs;
    const auto t0 = steady_clock::now();
    EXPECT_EQ(value(f.pick(w, milliseconds(30))), 100);
    EXPECT_GE(steady_clock::now() - t0, milliseconds(29));
    // A probe at 300 ms: the camera has no frame of its tick, it sits out.
    Frames::Want probe;
    probe.time_ns = 300 * kMs, probe.probe = 7;
    EXPECT_FALSE(f.pick(probe, milliseconds(10)).frame);
    // Another probe at 300 ms: its frame, and every step gets the same one
    // after newer frames pushed it out of the ring.
    f.push(300 * kMs, frame(300));
    probe.probe = 8;
    EXPECT_EQ(value(f.pick(probe, seconds(5))), 300);
    for (int k = 1; k <= 9; ++k) f.push((300 + 33 * k) * kMs, frame(300 + 33 * k));
    EXPECT_EQ(value(f.pick(probe, seconds(5))), 300);
    EXPECT_EQ(value(f.pick({}, seconds(5))), 597);
  }
  {
    // Not live: held once kAhead frames ahead of the requests.
    Frames f(2);
    f.set_camera(0, 33 * kMs);
    std::atomic<int> pushed{0};
    std::atomic<bool> ended{false};
    std::thread camera([&] {
      for (int k = 0; k < 10; ++k) {
        const Frames::Pushed r = f.push(k, frame(k));
        ++pushed;
        if (r == Frames::Pushed::kEnd) {
          ended = true;
          return;
        }
      }
    });
    const auto reach = [&](int n) {
      const auto until = steady_clock::now() + seconds(10);
      while (pushed < n && steady_clock::now() < until)
        std::this_thread::sleep_for(milliseconds(1));
      std::this_thread::sleep_for(milliseconds(50));  // and no further
      return pushed.load();
    };
    EXPECT_EQ(reach(1), 1);  // the second push waits
    EXPECT_EQ(value(f.pick({}, seconds(5))), 1);
    EXPECT_EQ(reach(3), 3);  // a request took one: two more
    f.requests_ended();
    camera.join();
    EXPECT_TRUE(ended);
    EXPECT_EQ(pushed, 4);
  }
  {
    // Known not live but its format not yet (still starting): kStarting
    // timeouts, then no frame (a camera that never starts holds nothing).
    Frames f(2);
    f.set_live(0);
    const auto t0 = steady_clock::now();
    EXPECT_FALSE(f.pick({}, milliseconds(5)).frame);
    EXPECT_GE(steady_clock::now() - t0, milliseconds(5 * Frames::kStarting - 1));
  }
  {
    // Not live, no frame: a request waits without a deadline until flushing.
    Frames f(2);
    f.set_camera(0, 33 * kMs);
    Frames::Pick got;
    std::thread request([&] { got = f.pick({}, milliseconds(1)); });
    std::this_thread::sleep_for(milliseconds(50));
    f.set_flushing(true);
    request.join();
    EXPECT_TRUE(got.flushing);
    EXPECT_FALSE(got.frame);
    EXPECT_EQ(f.push(0, frame(0)), Frames::Pushed::kFlushing);
  }
}

// lf::FragmentIntake (lib/lf/session/compositor_host.h): a fragment's
// header is checked before anything is decoded: the viewer (the first seen
// when none is named), the rig's cameras, probes aside, the output size,
// and the request window, where one stray sequence is held on probation
// and a second one after it moves the window.
TEST(FragmentIntake, ViewerCameraSizeWindowAndProbes) {
  using V = lf::Intake::Verdict;
  auto rig = std::make_shared<const lf::Rig>(lf::synthetic_grid_rig(3, 3, 0.5, 160, 120, 50));
  lf::FragmentIntake intake(rig, -1);
  const auto take = [&](uint32_t viewer, uint64_t seq, int camera, int w = 96, int h = 72) {
    const std::vector<uint8_t> b =
        lf::empty_answer(view_request(viewer, seq, {0, 0, -1}, {0, 0, 10}, w, h), camera);
    lf::Intake in = intake.take(b.data(), b.size(), true, 96, 72, false, 0);
    if (in.verdict == V::kAccept) intake.viewer.taken(in.head.viewer_id);
    return in;
  };
  lf::Intake in = take(5, 1, rig->cameras[0].id);
  EXPECT_EQ(in.verdict, V::kAccept);
  ASSERT_EQ(in.parts.size(), 1u);
  EXPECT_EQ(in.parts[0].f.sequence, 1u);
  EXPECT_EQ(take(6, 1, rig->cameras[0].id).verdict, V::kForeign);  // viewer 5 was taken
  in = take(5, 2, 999);
  EXPECT_EQ(in.verdict, V::kUnknownCamera);
  EXPECT_NE(in.why.find("999"), std::string::npos);
  EXPECT_STREQ(in.summary(), "Dropping a fragment of an unknown camera");
  EXPECT_EQ(take(5, lf::focus_probe_sequence(3, 0), rig->cameras[1].id).verdict, V::kProbe);
  in = take(5, 2, rig->cameras[1].id, 64, 48);
  EXPECT_EQ(in.verdict, V::kWrongSize);
  EXPECT_NE(in.why.find("64x48"), std::string::npos);
  // Without a size: refused (a probe's answer is scored still, focus only).
  std::vector<uint8_t> b = lf::empty_answer(view_request(5, 3, {0, 0, -1}), rig->cameras[0].id);
  EXPECT_EQ(intake.take(b.data(), b.size(), true, 0, 0, false, 0).verdict, V::kNoSize);
  // The window: request 1 was accepted, 1000 is held on probation, 1001 moves it.
  intake.window.emitted(1);
  EXPECT_EQ(take(5, 1000, rig->cameras[0].id).verdict, V::kOutsideWindow);
  in = take(5, 1001, rig->cameras[0].id);
  EXPECT_EQ(in.verdict, V::kAccept);
  EXPECT_TRUE(in.followed);
  EXPECT_EQ(in.candidate, 1000);
  // Bytes that are no fragment, and a fragment cut short.
  const uint8_t junk[40] = {'L', 'F', 'F', 'R'};
  EXPECT_EQ(intake.take(junk, sizeof junk, true, 96, 72, false, 0).verdict, V::kMalformed);
  b = lf::empty_answer(view_request(5, 1002, {0, 0, -1}, {0, 0, 10}, 96, 72), rig->cameras[0].id);
  in = intake.take(b.data(), b.size() - 1, true, 96, 72, false, 0);
  EXPECT_EQ(in.verdict, V::kMalformed);
  EXPECT_FALSE(in.why.empty());
}

// lf::FrameBudget through lf::FragmentIntake: live, the requests composited
// are held to max_pixel_rate output pixels a second (a second's burst), each
// admitted or refused whole at its first fragment, so a refused request's
// other cameras are refused too and an admitted one's are never cut off;
// the bucket refills with time; no limit at 0.
TEST(FragmentIntake, PixelBudgetAdmitsOrRefusesWholeRequests) {
  using V = lf::Intake::Verdict;
  auto rig = std::make_shared<const lf::Rig>(lf::synthetic_grid_rig(3, 3, 0.5, 160, 120, 50));
  lf::FragmentIntake intake(rig, 5);
  const double pixels = 96.0 * 72;
  intake.max_pixel_rate = 10 * pixels;  // ten requests a second
  int64_t now = 1'000'000;
  const auto take = [&](uint64_t seq, int camera) {
    const std::vector<uint8_t> b =
        lf::empty_answer(view_request(5, seq, {0, 0, -1}, {0, 0, 10}, 96, 72), camera);
    return intake.take(b.data(), b.size(), true, 96, 72, false, now).verdict;
  };
  // 30 requests at once, each camera's fragment in turn: the first ten
  // whole, the other twenty refused whole.
  int admitted = 0, refused = 0;
  for (uint64_t seq = 1; seq <= 30; ++seq) {
    std::vector<V> v;
    for (const lf::Camera& c : rig->cameras) v.push_back(take(seq, c.id));
    const bool all_in = std::all_of(v.begin(), v.end(), [](V x) { return x == V::kAccept; });
    const bool all_out = std::all_of(v.begin(), v.end(), [](V x) { return x == V::kOverBudget; });
    ASSERT_TRUE(all_in || all_out) << "request " << seq << " split";
    admitted += all_in, refused += all_out;
  }
  EXPECT_EQ(admitted, 10);
  EXPECT_EQ(refused, 20);
  EXPECT_EQ(intake.budget.refused(), 20u);
  // The refused verdict names the limit.
  std::vector<uint8_t> b =
      lf::empty_answer(view_request(5, 31, {0, 0, -1}, {0, 0, 10}, 96, 72), rig->cameras[0].id);
  lf::Intake in = intake.take(b.data(), b.size(), true, 96, 72, false, now);
  EXPECT_EQ(in.verdict, V::kOverBudget);
  EXPECT_STREQ(in.summary(), "Dropping requests above max-pixel-rate");
  EXPECT_NE(in.why.find("request 31"), std::string::npos) << in.why;
  // Half a second later, five more requests pass.
  now += 500'000;
  admitted = 0;
  for (uint64_t seq = 32; seq <= 41; ++seq) admitted += take(seq, rig->cameras[0].id) == V::kAccept;
  EXPECT_EQ(admitted, 5);
  // No limit (0, and not live): every request.
  intake.max_pixel_rate = 0;
  for (uint64_t seq = 42; seq <= 60; ++seq) EXPECT_EQ(take(seq, rig->cameras[0].id), V::kAccept);
}

// lf::OutputRate: one report a window (a second), of the frames composited
// in it and of them the complete ones; the first frame opens the window.
TEST(OutputRate, OneReportASecondOfFramesAndCompleteOnes) {
  lf::OutputRate rate;
  std::vector<lf::OutputRate::Report> reports;
  // 25 frames a second for 3.0 s, every fifth incomplete.
  for (int i = 0; i <= 75; ++i)
    if (const auto r = rate.frame(5'000'000 + i * 40'000, i % 5 != 4)) reports.push_back(*r);
  ASSERT_EQ(reports.size(), 3u);
  for (const auto& r : reports) {
    EXPECT_DOUBLE_EQ(r.seconds, 1.0);
    EXPECT_EQ(r.frames, 25u);
    EXPECT_EQ(r.complete, 20u);
    EXPECT_DOUBLE_EQ(r.fps(), 25.0);
    EXPECT_DOUBLE_EQ(r.complete_fps(), 20.0);
  }
  // A gap: the window closes at the next frame, over its true length.
  const auto late = rate.frame(5'000'000 + 76 * 40'000 + 2'500'000, true);
  ASSERT_TRUE(late.has_value());
  EXPECT_NEAR(late->seconds, 2.54, 1e-9);
  EXPECT_EQ(late->frames, 1u);  // the frame at 3.0 s that opened it
  EXPECT_EQ(lf::OutputRate::Report{}.fps(), 0.0);
}

// lf::ArrivalDeadline: the 99th percentile of the fragments' arrival ages
// plus a fifth, in 5 ms steps, between the request period and the cap;
// rising at once, falling only under three quarters, at most once a second.
TEST(ArrivalDeadline, FollowsTheArrivalTimesWithinThePeriodAndTheCap) {
  constexpr int64_t ms = 1'000'000, s = 1000 * ms, period = 33 * ms, cap = 500 * ms;
  lf::ArrivalDeadline d;
  int64_t now = 10 * s;
  for (int i = 0; i < 63; ++i) d.arrived(5 * ms);
  EXPECT_FALSE(d.update(now, period, cap)) << "fewer than kMinSamples ages";
  d.arrived(-1);  // unknown: ignored
  EXPECT_FALSE(d.update(now, period, cap));
  d.arrived(5 * ms);
  // Fast cameras: never under one period (the paper's deadline).
  EXPECT_EQ(d.update(now, period, cap).value_or(-1), period);
  EXPECT_EQ(d.deadline(), period);
  // Slow cameras (1080p JPEG on 2 cores): ages 100..199 ms; p99 198 ms,
  // +1/5 = 237.6 ms, up to 240 ms. Not before a second has passed.
  for (int i = 0; i < 2048; ++i) d.arrived((100 + i % 100) * ms);
  EXPECT_FALSE(d.update(now + s / 2, period, cap));
  now += s;
  EXPECT_EQ(d.update(now, period, cap).value_or(-1), 240 * ms);
  // A few stragglers (under 1 %) do not move it; the same value is no change.
  for (int i = 0; i < 15; ++i) d.arrived(5 * s);
  now += s;
  EXPECT_FALSE(d.update(now, period, cap));
  // Slower than the cap: the cap.
  for (int i = 0; i < 2048; ++i) d.arrived(2 * s);
  now += s;
  EXPECT_EQ(d.update(now, period, cap).value_or(-1), cap);
  // Falling: not to 420 ms (over three quarters of 500), but to 180 ms.
  for (int i = 0; i < 2048; ++i) d.arrived(350 * ms);
  now += s;
  EXPECT_FALSE(d.update(now, period, cap));
  for (int i = 0; i < 2048; ++i) d.arrived(150 * ms);
  now += s;
  EXPECT_EQ(d.update(now, period, cap).value_or(-1), 180 * ms);
  // A cap under the period: the period.
  for (int i = 0; i < 2048; ++i) d.arrived(1 * ms);
  now += s;
  EXPECT_EQ(d.update(now, 100 * ms, 50 * ms).value_or(-1), 100 * ms);
}

// lf::CameraAnswer: a camera's answer on the wire equals its fragment
// rendered and serialized the long way (raw: the same pixels; JPEG: the
// same bytes), and a quilt's eyes land in their tiles, apart, as the
// compositor takes them (lf::parse_frame_answer).
TEST(CameraAnswer, RawJpegAndQuiltAnswersAreTheFragmentsOnTheWire) {
  const lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.5, 160, 120, 50);
  const int index = 4;
  const lf::Camera& cam = rig.cameras[index];
  const cv::Mat image = lf::render_textured_plane(cam, 10, 1.0);
  const lf::ViewRequest req = view_request(3, 77, {0.1, 0.1, -1});
  const auto renderer = lf::make_renderer(lf::Backend::kCpu);
  renderer->set_image(0, image, &image, 1);
  lf::Fragment base;
  base.viewer_id = req.viewer_id, base.sequence = req.sequence, base.capture_time_ns = 5;

  const lf::CameraAnswer one(rig, req, index);
  ASSERT_EQ(one.count(), 1u);
  ASSERT_FALSE(one.sees_nothing());
  EXPECT_FALSE(one.quilt());
  lf::Fragment want;
  want.viewer_id = req.viewer_id, want.sequence = req.sequence, want.capture_time_ns = 5;
  lf::render_fragment(one.plan(0), cam, image, want);
  EXPECT_EQ(one.pixel_count(), want.pixel_count());
  const std::vector<lf::Fragment> heads = one.headers(base, cam.id);
  std::vector<uint8_t> raw(lf::CameraAnswer::raw_size(heads));
  one.write_raw(heads, cam, *renderer, 0, raw.data(), raw.size());
  EXPECT_EQ(raw, lf::serialize_fragment(want, lf::Encoding::kRaw));
  EXPECT_THROW(one.write_raw(heads, cam, *renderer, 0, raw.data(), raw.size() - 1),
               std::invalid_argument);
  std::vector<uint8_t> scratch;
  EXPECT_EQ(one.encode_jpeg(base, cam, *renderer, 0, 90, scratch),
            lf::serialize_fragment(want, lf::Encoding::kJpeg, 90));

  // A quilt of 6 eyes in 3 x 2 tiles of 96 x 72.
  lf::ViewRequest q = req;
  q.view = lf::VirtualView::look_at({0.1, 0.1, -1}, {0, 0, 10}, {0, 1, 0}, 40, 96, 72);
  q.view.width = 288, q.view.height = 144;
  q.quilt.views = 6, q.quilt.cols = 3, q.quilt.rows = 2, q.quilt.baseline = 0.6;
  const lf::CameraAnswer eyes(rig, q, index);
  EXPECT_TRUE(eyes.quilt());
  ASSERT_GE(eyes.count(), 2u);
  const std::vector<lf::Fragment> eye_heads = eyes.headers(base, cam.id);
  std::vector<uint8_t> quilt(lf::CameraAnswer::raw_size(eye_heads));
  eyes.write_raw(eye_heads, cam, *renderer, 0, quilt.data(), quilt.size());
  const auto parts = lf::parse_frame_answer(quilt.data(), quilt.size(), 288 * 144);
  ASSERT_EQ(parts.size(), eyes.count());
  for (const auto& part : parts) {
    EXPECT_EQ(part.f.out_width, 288);
    EXPECT_EQ(part.f.out_height, 144);
    bool in_a_tile = false;
    for (int i = 0; i < 6; ++i)
      in_a_tile |= (part.f.rect & lf::quilt_tile(q.quilt, 288, 144, i)) == part.f.rect;
    EXPECT_TRUE(in_a_tile) << part.f.rect;
  }
  // A quilt whose eyes this camera cannot see: nothing to send.
  lf::ViewRequest away = q;
  away.view.position = cv::Vec3d(100, 100, -1);
  const lf::CameraAnswer none(rig, away, index);
  EXPECT_TRUE(none.quilt());
  EXPECT_TRUE(none.sees_nothing());
  EXPECT_EQ(none.count(), 0u);
}

// lf::FrameCompositor (lib/lf/session/compositor_host.h), the compositor
// host's frames: the cameras' fragments added and renormalised as
// lf::Compositor does; a drawing left to it gives the frame its fragment
// would; stereo puts the right viewer's pieces on the right; an incomplete
// request takes the last frame where no weight came; a bad piece is left
// out and named; composite_into() does the same in a caller's frame.
TEST(FrameCompositor, FragmentsDrawingsStereoAndTheLastFrame) {
  const lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.5, 160, 120, 50);
  const lf::ViewRequest req = view_request(3, 5, {0.4, 0.3, -1});
  std::vector<cv::Mat> images;
  std::vector<lf::ReceivedPiece> pieces, drawn;
  std::vector<lf::CameraAnswer> answers;
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    images.push_back(lf::render_textured_plane(rig.cameras[i], 10, 1.0));
    answers.emplace_back(rig, req, static_cast<int>(i));
  }
  lf::Compositor reference;
  reference.reset(160, 120);
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    if (answers[i].sees_nothing()) continue;
    lf::ReceivedPiece p;
    p.f.viewer_id = req.viewer_id, p.f.sequence = req.sequence;
    lf::render_fragment(answers[i].plan(0), rig.cameras[i], images[i], p.f);
    reference.add(p.f);
    pieces.push_back(p);
    lf::ReceivedPiece d;
    d.f.viewer_id = req.viewer_id, d.f.camera_id = rig.cameras[i].id;
    auto drawing = std::make_shared<lf::DeferredDrawing>();
    drawing->plan = answers[i].plan(0), drawing->camera = rig.cameras[i];
    drawing->slot = static_cast<int>(i), drawing->image = images[i];
    drawing->frame_key = &images[i];
    d.deferred = drawing;
    drawn.push_back(d);
  }
  ASSERT_GE(pieces.size(), 3u);
  cv::Mat want;
  reference.resolve(want);
  lf::FrameCompositor frames(lf::make_renderer(lf::Backend::kCpu));
  auto r = frames.composite(pieces, 160, 120, false, 3, true);
  EXPECT_EQ(cv::norm(*r.frame, want, cv::NORM_INF), 0);
  EXPECT_EQ(r.filled, 0u);
  EXPECT_TRUE(r.refused.empty());
  const cv::Mat complete = r.frame->clone();
  r = frames.composite(drawn, 160, 120, false, 3, true);
  EXPECT_EQ(cv::norm(*r.frame, want, cv::NORM_INF), 0) << "drawn here = drawn by the camera";

  // Stereo: the same pieces as viewer 4 on the right.
  std::vector<lf::ReceivedPiece> pair = pieces;
  for (lf::ReceivedPiece p : pieces) {
    p.f.viewer_id = 4;
    pair.push_back(p);
  }
  r = frames.composite(pair, 160, 120, true, 3, true);
  ASSERT_EQ(r.frame->size(), cv::Size(320, 120));
  EXPECT_EQ(cv::norm((*r.frame)(cv::Rect(0, 0, 160, 120)), want, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm((*r.frame)(cv::Rect(160, 0, 160, 120)), want, cv::NORM_INF), 0);

  // Incomplete after a mono frame: where only one camera's fragment came is
  // its picture, elsewhere the last frame's.
  frames.composite(pieces, 160, 120, false, 3, true);
  lf::ReceivedPiece bad = pieces[1];
  bad.f.out_width = 320;  // for another frame size: refused
  r = frames.composite({pieces[0], bad}, 160, 120, false, 3, false);
  EXPECT_GT(r.filled, 0u);
  ASSERT_EQ(r.refused.size(), 1u);
  EXPECT_EQ(r.refused[0].first, static_cast<int>(pieces[1].f.camera_id));
  const cv::Rect only = pieces[0].f.rect;
  for (int y = 0; y < 120; y += 7)
    for (int x = 0; x < 160; x += 7)
      if (!only.contains({x, y})) {
        EXPECT_EQ(r.frame->at<cv::Vec4b>(y, x), complete.at<cv::Vec4b>(y, x)) << x << "," << y;
      }

  // Straight into a caller's frame (an output buffer): the same picture
  // from fragments and drawings, the last frame given by the caller, a
  // frame of another shape refused.
  cv::Mat into(120, 160, CV_8UC4, cv::Scalar::all(77)), none;
  r = frames.composite_into(pieces, 160, 120, true, into, none);
  EXPECT_EQ(r.frame, &into);
  EXPECT_EQ(cv::norm(into, want, cv::NORM_INF), 0);
  const cv::Mat sent = into.clone();
  into.setTo(cv::Scalar::all(77));
  r = frames.composite_into(drawn, 160, 120, true, into, sent);
  EXPECT_EQ(cv::norm(into, want, cv::NORM_INF), 0);
  EXPECT_EQ(r.filled, 0u);
  r = frames.composite_into({pieces[0], bad}, 160, 120, false, into, sent);
  EXPECT_GT(r.filled, 0u);
  ASSERT_EQ(r.refused.size(), 1u);
  for (int y = 0; y < 120; y += 7)
    for (int x = 0; x < 160; x += 7)
      if (!only.contains({x, y})) {
        EXPECT_EQ(into.at<cv::Vec4b>(y, x), sent.at<cv::Vec4b>(y, x)) << x << "," << y;
      }
  r = frames.composite_into({pieces[0]}, 160, 120, false, into, none);
  EXPECT_EQ(r.filled, 0u) << "no last frame: nothing to fill from";
  cv::Mat wide(120, 320, CV_8UC4);
  EXPECT_THROW(frames.composite_into(pieces, 160, 120, true, wide, none), std::invalid_argument);
  EXPECT_THROW(frames.composite_into(pieces, 160, 120, true, into, wide), std::invalid_argument);
  EXPECT_THROW(frames.composite_into(pieces, 160, 120, true, into, wide(cv::Rect(0, 0, 160, 120))),
               std::invalid_argument)
      << "not continuous";
}

// lf::shared_geometry: the cameras answering one plane or surface request
// share one geometry (the first to ask makes it), which plans each camera
// as its own would; no key: each its own.
TEST(CameraAnswer, CamerasShareTheGeometryOfARequest) {
  const auto rig = std::make_shared<const lf::Rig>(lf::synthetic_grid_rig(3, 3, 0.5, 160, 120, 50));
  const lf::ViewRequest req = view_request(0, 0, {0.1, 0.1, -1});
  const std::string key = "request-bytes-1";
  const auto a = lf::shared_geometry(rig, req, 0, key);
  const auto b = lf::shared_geometry(rig, req, 5, key);
  EXPECT_EQ(a.get(), b.get());
  EXPECT_NE(lf::shared_geometry(rig, req, 5, "request-bytes-2").get(), a.get());
  EXPECT_NE(lf::shared_geometry(rig, req, 5, "").get(), a.get());
  EXPECT_NE(lf::shared_geometry(rig, req, 5, std::string(lf::kMaxSharedKeyBytes + 1, 'x')).get(),
            lf::shared_geometry(rig, req, 5, std::string(lf::kMaxSharedKeyBytes + 1, 'x')).get());
  // A focal surface with second planes (16-pixel tiles of the 160x120 view,
  // two planes, every third tile with both).
  lf::ViewRequest sreq = req;
  lf::FocalSurface& fs = sreq.surface;
  fs.tile = 16, fs.cols = 10, fs.rows = 8;
  fs.planes = {lf::FocalPlane::through({0, 0, 6}, {0, 0, 1}),
               lf::FocalPlane::through({0, 0, 12}, {0, 0, 1})};
  for (int t = 0; t < fs.cols * fs.rows; ++t) {
    fs.plane_of.push_back(static_cast<uint8_t>((t / 7) % 2));
    fs.second_of.push_back(t % 3 ? lf::FocalSurface::kNone : static_cast<uint8_t>(1 - (t / 7) % 2));
  }
  const auto s0 = lf::shared_geometry(rig, sreq, 0, "surface-bytes");
  const auto s5 = lf::shared_geometry(rig, sreq, 5, "surface-bytes");
  EXPECT_EQ(s0.get(), s5.get());
  EXPECT_GT(s5->regions(1).size(), 0u);
  const lf::ViewGeometry alone(*rig, sreq, 5);
  EXPECT_NE(alone.surface_layout(), s5->surface_layout());
  for (int l = 0; l < 2; ++l) {
    const lf::FragmentPlan a = lf::plan_fragment(alone, 5, l), b = lf::plan_fragment(*s5, 5, l);
    EXPECT_FALSE(a.empty());
    ASSERT_EQ(a.runs.size(), b.runs.size());
    for (size_t r = 0; r < a.runs.size(); ++r)
      EXPECT_TRUE(a.runs[r].y == b.runs[r].y && a.runs[r].x0 == b.runs[r].x0 &&
                  a.runs[r].x1 == b.runs[r].x1 &&
                  a.pieces[a.runs[r].piece].H == b.pieces[b.runs[r].piece].H);
  }
}

// lf::shared_keyed_requests: the cameras sent one request buffer share its
// parse (the first parses); other bytes parse anew; a malformed buffer
// throws every time (each camera parses it again); the last 16 buffers are kept.
TEST(CameraAnswer, CamerasShareTheParseOfARequestBuffer) {
  lf::ViewRequest req = view_request(0, 0, {0.1, 0.1, -1});
  req.sequence = 41;
  const std::vector<uint8_t> bytes = lf::serialize_request(req);
  const auto a = lf::shared_keyed_requests(bytes.data(), bytes.size());
  const std::vector<uint8_t> copy = bytes;  // the same bytes at another address
  const auto b = lf::shared_keyed_requests(copy.data(), copy.size());
  EXPECT_EQ(a.get(), b.get());
  ASSERT_EQ(a->size(), 1u);
  EXPECT_EQ((*a)[0].first.sequence, 41u);
  EXPECT_EQ((*a)[0].second, std::string(bytes.begin(), bytes.end()));
  req.sequence = 42;
  const std::vector<uint8_t> other = lf::serialize_request(req);
  const auto c = lf::shared_keyed_requests(other.data(), other.size());
  EXPECT_NE(c.get(), a.get());
  EXPECT_EQ((*c)[0].first.sequence, 42u);
  std::vector<uint8_t> bad = bytes;
  bad.resize(bad.size() / 2);
  EXPECT_THROW(lf::shared_keyed_requests(bad.data(), bad.size()), lf::WireError);
  EXPECT_THROW(lf::shared_keyed_requests(bad.data(), bad.size()), lf::WireError)
      << "a buffer that failed fails again";
  // Seventeen other buffers later the first is parsed again (the last 16 kept).
  for (uint64_t s = 100; s < 117; ++s) {
    req.sequence = s;
    const std::vector<uint8_t> b2 = lf::serialize_request(req);
    lf::shared_keyed_requests(b2.data(), b2.size());
  }
  const auto again = lf::shared_keyed_requests(bytes.data(), bytes.size());
  EXPECT_NE(again.get(), a.get());
  EXPECT_EQ((*again)[0].first.sequence, 41u);
}
