#include "lf/session/camera_host.h"

#include <deque>
#include <future>
#include <mutex>
#include <optional>
#include <string_view>
#include <utility>

#include "lf/render/quilt.h"
#include "lf/render/render.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"

namespace lf {

namespace {

// What the cameras of one process share per request: the first camera to
// plan (or parse) a request makes it and the others wait for it and take
// it. Keyed by the rig and the request's bytes (requests up to
// kMaxSharedKeyBytes bytes; larger ones, with big focal surfaces, are
// planned alone); the last kShared requests are kept.
constexpr size_t kShared = 16;
template <typename T>
class SharedPerRequest {
 public:
  // The value for (rig, key), made by `make` in the first caller; null
  // where that failed (it rethrows; a waiting caller then makes its own,
  // and fails alike with the reason).
  template <typename Make>
  std::shared_ptr<const T> get(const std::shared_ptr<const Rig>& rig, std::string_view key,
                               Make make) {
    std::shared_future<std::shared_ptr<const T>> value;
    // Only the maker's (a promise made and dropped unset costs two
    // allocations and an exception object, camera after camera).
    std::optional<std::promise<std::shared_ptr<const T>>> mine;
    {
      std::lock_guard<std::mutex> lock(m_);
      for (const Entry& e : entries_)
        if (e.rig == rig && e.key == key) value = e.value;
      if (!value.valid()) {
        value = mine.emplace().get_future().share();
        entries_.push_back({rig, std::string(key), value});
        if (entries_.size() > kShared) entries_.pop_front();
      }
    }
    if (!mine) return value.get();
    try {
      std::shared_ptr<const T> v = make();
      mine->set_value(v);
      return v;
    } catch (...) {
      mine->set_value(nullptr);
      throw;
    }
  }

 private:
  struct Entry {
    std::shared_ptr<const Rig> rig;
    std::string key;
    std::shared_future<std::shared_ptr<const T>> value;
  };
  std::mutex m_;
  std::deque<Entry> entries_;
};

}  // namespace

std::shared_ptr<const ViewGeometry> shared_geometry(const std::shared_ptr<const Rig>& rig,
                                                    const ViewRequest& req, int index,
                                                    const std::string& key) {
  const bool ulr = req.aperture == Aperture::kUlr || req.aperture == Aperture::kFourCamera;
  if (key.empty() || key.size() > kMaxSharedKeyBytes)
    return std::make_shared<const ViewGeometry>(*rig, req, index);
  if (ulr) {
    static SharedPerRequest<UlrField> fields;
    std::shared_ptr<const ViewGeometry> own;
    const auto field = fields.get(rig, key, [&] {
      own = std::make_shared<const ViewGeometry>(*rig, req, index);
      return own->ulr_field();
    });
    return own ? own : std::make_shared<const ViewGeometry>(*rig, req, index, field);
  }
  static SharedPerRequest<ViewGeometry> whole;
  const auto g =
      whole.get(rig, key, [&] { return std::make_shared<const ViewGeometry>(*rig, req); });
  return g ? g : std::make_shared<const ViewGeometry>(*rig, req, index);
}

CameraAnswer::CameraAnswer(const Rig& rig, const ViewRequest& req, int index,
                           std::shared_ptr<const ViewGeometry> geometry)
    : quilt_(!req.quilt.empty()), width_(req.view.width), height_(req.view.height) {
  if (!req.quilt.empty()) {
    for (int i = 0; i < req.quilt.views; ++i) {
      FragmentPlan plan = plan_fragment(ViewGeometry(rig, quilt_eye(req, i), index), index);
      if (plan.empty()) continue;
      plans_.push_back(std::move(plan));
      tile_of_.push_back(quilt_tile(req.quilt, req.view.width, req.view.height, i).tl());
    }
    return;
  }
  if (!geometry) geometry = std::make_shared<const ViewGeometry>(rig, req, index);
  if (req.surface.two_planes()) {
    auto both = plan_fragment_layers(*geometry, index);
    plans_.push_back(std::move(both[0]));
    if (!both[1].empty()) plans_.push_back(std::move(both[1]));  // else nothing to add
  } else {
    plans_.push_back(plan_fragment(*geometry, index));
  }
}

size_t CameraAnswer::pixel_count() const {
  size_t n = 0;
  for (const FragmentPlan& p : plans_) n += p.pixel_count();
  return n;
}

Fragment CameraAnswer::header(size_t k, const Fragment& base, int camera_id) const {
  Fragment head;
  head.viewer_id = base.viewer_id, head.sequence = base.sequence;
  head.capture_time_ns = base.capture_time_ns;
  describe_fragment(plans_.at(k), head);
  head.camera_id = static_cast<uint32_t>(camera_id);
  if (!quilt_) return head;
  // A quilt's eye: moved into its tile of the quilt frame.
  const cv::Point t = tile_of_[k];
  head.out_width = width_, head.out_height = height_;
  head.rect.x += t.x, head.rect.y += t.y;
  for (auto& span : head.spans)  // [begin, end) in output x
    span = {static_cast<uint16_t>(span[0] + t.x), static_cast<uint16_t>(span[1] + t.x)};
  return head;
}

std::vector<Fragment> CameraAnswer::headers(const Fragment& base, int camera_id) const {
  std::vector<Fragment> heads;
  heads.reserve(plans_.size());
  for (size_t k = 0; k < plans_.size(); ++k) heads.push_back(header(k, base, camera_id));
  return heads;
}

size_t CameraAnswer::raw_size(const std::vector<Fragment>& heads) {
  size_t size = 0;
  for (const Fragment& head : heads) size += raw_fragment_size(head);
  return size;
}

void CameraAnswer::write_raw(const std::vector<Fragment>& heads, const Camera& camera,
                             Renderer& renderer, int slot, uint8_t* out, size_t size) const {
  if (heads.size() != plans_.size())
    throw std::invalid_argument("CameraAnswer::write_raw: one header per plan (headers())");
  for (size_t k = 0; k < plans_.size(); ++k) {
    const size_t n = raw_fragment_size(heads[k]);
    if (n > size) throw std::invalid_argument("CameraAnswer::write_raw: the buffer is too small");
    renderer.draw(plans_[k], camera, slot, write_raw_fragment(heads[k], out, n));
    seal_fragment(out, n);
    out += n, size -= n;
  }
  if (size != 0) throw std::invalid_argument("CameraAnswer::write_raw: the buffer is too large");
}

std::vector<uint8_t> CameraAnswer::encode_jpeg(const Fragment& base, const Camera& camera,
                                               Renderer& renderer, int slot, int quality,
                                               std::vector<uint8_t>& scratch) const {
  std::vector<uint8_t> bytes;
  for (size_t k = 0; k < plans_.size(); ++k) {
    const FragmentPlan& plan = plans_[k];
    const Fragment head = header(k, base, camera.id);
    // Drawn straight into the rectangle the encoder takes.
    const size_t row_bytes = 4 * static_cast<size_t>(plan.rect.width);
    if (scratch.size() < row_bytes * plan.rect.height) scratch.resize(row_bytes * plan.rect.height);
    renderer.draw_rect(plan, camera, slot, scratch.data(), row_bytes);
    const std::vector<uint8_t> one = serialize_jpeg_fragment(head, scratch.data(), quality);
    bytes.insert(bytes.end(), one.begin(), one.end());
  }
  return bytes;
}

std::shared_ptr<const KeyedRequests> shared_keyed_requests(const uint8_t* data, size_t size) {
  auto parse = [&] {
    return std::make_shared<const KeyedRequests>(parse_keyed_requests(data, size));
  };
  if (size > kMaxSharedKeyBytes) return parse();
  static SharedPerRequest<KeyedRequests> parsed;
  // A buffer that does not parse is kept as null: each camera parses it
  // again, and throws with the reason.
  const auto r =
      parsed.get(nullptr, std::string_view(reinterpret_cast<const char*>(data), size), parse);
  return r ? r : parse();
}

std::vector<std::pair<ViewRequest, std::string>> parse_keyed_requests(const uint8_t* data,
                                                                      size_t size) {
  std::vector<size_t> sizes;
  std::vector<ViewRequest> reqs = parse_requests(data, size, &sizes);
  std::vector<std::pair<ViewRequest, std::string>> out;
  size_t at = 0;
  for (size_t k = 0; k < reqs.size(); at += sizes[k++]) {
    out.emplace_back(std::move(reqs[k]), std::string());
    if (sizes[k] <= kMaxSharedKeyBytes)
      out.back().second.assign(reinterpret_cast<const char*>(data + at), sizes[k]);
  }
  return out;
}

std::vector<uint8_t> empty_answer(const ViewRequest& req, int camera_id, int64_t capture_time_ns) {
  Fragment f;
  f.viewer_id = req.viewer_id, f.sequence = req.sequence;
  f.camera_id = static_cast<uint32_t>(camera_id);
  f.capture_time_ns = capture_time_ns;
  f.out_width = req.view.width, f.out_height = req.view.height;
  return serialize_fragment(f, Encoding::kEmpty, 90);
}

}  // namespace lf
