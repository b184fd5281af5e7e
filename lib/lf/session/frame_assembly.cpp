#include "lf/session/frame_assembly.h"

#include <cstdio>

namespace lf {

RequestWindow::Verdict RequestWindow::offer(uint64_t seq) {
  if (last_ < 0) return Verdict::kAccept;
  const auto last = static_cast<uint64_t>(last_);
  if (seq > last && seq - last <= kMaxDropout) return Verdict::kAccept;
  if (seq <= last && last - seq <= kMaxMisorder) {
    ++late_;
    return Verdict::kLate;
  }
  const int64_t cand = probation_;
  if (cand >= 0 &&
      (seq == static_cast<uint64_t>(cand) + 1 || seq == static_cast<uint64_t>(cand) + 2)) {
    last_ = static_cast<int64_t>(std::min<uint64_t>(seq - 1, INT64_MAX));
    probation_ = -1;
    return Verdict::kFollow;
  }
  probation_ = static_cast<int64_t>(std::min<uint64_t>(seq, INT64_MAX));
  return Verdict::kProbation;
}

void RequestWindow::emitted(uint64_t seq) {
  last_ = static_cast<int64_t>(std::min<uint64_t>(seq, INT64_MAX));
}

bool ViewerSelection::taken(uint32_t id) {
  foreign_count_ = 0, foreign_since_us_ = -1;
  if (viewer_ >= 0) return false;
  viewer_ = id;
  return true;
}

bool ViewerSelection::foreign(int64_t now_us) {
  if (foreign_count_++ == 0) foreign_since_us_ = now_us;
  if (warned_ || now_us - foreign_since_us_ < kForeignWarnUs) return false;
  warned_ = true;
  return true;
}

std::string ViewerSelection::foreign_detail(int64_t now_us, uint32_t other) const {
  char line[256];
  std::snprintf(line, sizeof line,
                "%llu fragments in %.1f s, all of other viewers (such as %u): check viewer-id "
                "(lfviewrequest viewer-id, or -1 here to take the first viewer seen)",
                static_cast<unsigned long long>(foreign_count_), foreign_seconds(now_us), other);
  return line;
}

}  // namespace lf
