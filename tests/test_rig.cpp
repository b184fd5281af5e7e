// Rigs: importers for every shared dataset, triangulation, rig file I/O,
// the cache of decoded stills.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "helpers.h"
#include "lf/geometry/rig_ops.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/datasets.h"
#include "lf/io/image_io.h"
#include "lf/io/rig_file.h"
#include "lf/io/still_cache.h"
#include "lf/quality/synthetic.h"

namespace {

using testing_lf::data_path;

double hull_area(const lf::Rig& rig) {
  double a = 0;
  for (const auto& t : rig.triangles) {
    const auto& p = rig.plane_positions();
    const cv::Vec2d A = p[rig.index_of(t[0])], B = p[rig.index_of(t[1])], C = p[rig.index_of(t[2])];
    const double s = (B[0] - A[0]) * (C[1] - A[1]) - (B[1] - A[1]) * (C[0] - A[0]);
    EXPECT_GT(s, 0) << "triangles must be counter-clockwise on the camera plane";
    a += 0.5 * s;
  }
  return a;
}

TEST(Rig, StanfordChess) {
  LF_NEEDS_DATA("stanford-chess");
  const lf::Rig rig = lf::import_dataset(data_path("stanford-chess"));
  ASSERT_EQ(rig.cameras.size(), 81u);
  EXPECT_EQ(rig.grid.rows, 9);
  EXPECT_EQ(rig.grid.cols, 9);
  EXPECT_EQ(rig.dimension(), 2);
  EXPECT_EQ(rig.triangles.size(), 128u);
  const lf::Camera& c = rig.cameras[rig.grid.at(0, 0)];
  EXPECT_EQ(c.name, "r00c00");
  EXPECT_EQ(c.width, 1400);
  EXPECT_EQ(c.height, 800);
  EXPECT_NEAR(c.center()[0], -3355.331299, 1e-9);  // X from the file name
  EXPECT_NEAR(c.center()[1], -780.134705, 1e-9);   // Y
  // Rectified slab: identical orientation, principal points shifting with X.
  const lf::Camera& d = rig.cameras[rig.grid.at(0, 8)];
  EXPECT_NEAR(d.intrinsics.cx - c.intrinsics.cx, 0.5 * (d.center()[0] - c.center()[0]), 1e-9);
  EXPECT_TRUE(rig.has_focal_param);
  // Image shift between two cameras for focal parameter a equals a * dX.
  const double a = -0.2, z = rig.focal_param_f_px / (rig.focal_param_infinity - a);
  const cv::Vec3d X(-3320, -810, z);
  const double shift = (*d.project(X))[0] - (*c.project(X))[0];
  EXPECT_NEAR(shift, a * (d.center()[0] - c.center()[0]), 1e-6);
}

TEST(Rig, HciCotton) {
  LF_NEEDS_DATA("hci-cotton");
  const lf::Rig rig = lf::import_dataset(data_path("hci-cotton"));
  ASSERT_EQ(rig.cameras.size(), 81u);
  const lf::Camera& centre = rig.cameras[40];
  EXPECT_EQ(centre.name, "input_Cam040");
  EXPECT_NEAR(centre.intrinsics.fx, 100.0 / 35.0 * 512, 1e-9);
  EXPECT_NEAR(centre.intrinsics.cx, 255.5, 1e-12);
  EXPECT_LT(cv::norm(centre.center()), 1e-12);
  EXPECT_NEAR(rig.typical_spacing(), 0.025, 1e-12);
  // A point at the focus distance has zero disparity; disparity d between
  // neighbours is f b (1/z - 1/z0) and points move left in the next column.
  const cv::Vec3d P(0.05, -0.03, 2.0);
  const double u40 = (*centre.project(P))[0], u41 = (*rig.cameras[41].project(P))[0];
  const double d = 1462.857142857 * 0.025 * (1 / 2.0 - 1 / 4.25);
  EXPECT_NEAR(u40 - u41, d, 1e-6);
  const cv::Vec3d Q(0.05, -0.03, 4.25);
  EXPECT_NEAR((*centre.project(Q))[0], (*rig.cameras[41].project(Q))[0], 1e-9);
}

TEST(Rig, BlenderShop) {
  LF_NEEDS_DATA("blender-shop-9x9");
  const lf::Rig rig = lf::import_dataset(data_path("blender-shop-9x9"));
  ASSERT_EQ(rig.cameras.size(), 81u);
  EXPECT_NEAR(rig.cameras[0].intrinsics.fx, 800.0, 1e-9);
  // Row 0 is the top (largest j), column 0 the leftmost (largest i).
  const lf::Camera& tl = rig.cameras[rig.grid.at(0, 0)];
  const lf::Camera& br = rig.cameras[rig.grid.at(8, 8)];
  EXPECT_LT(tl.center()[0], br.center()[0]);  // left of
  EXPECT_LT(tl.center()[1], br.center()[1]);  // above (y down)
  EXPECT_NEAR(br.center()[0] - tl.center()[0], 2 * 0.369230769, 1e-9);
}

TEST(Rig, MiddleburyRingIsUnstructured) {
  LF_NEEDS_DATA("middlebury-temple");
  const lf::Rig rig = lf::import_dataset(data_path("middlebury-temple"));
  // templeSR0011 repeats templeSR0001's viewpoint: dropped with a warning.
  ASSERT_EQ(rig.cameras.size(), 15u);
  ASSERT_EQ(rig.warnings.size(), 1u);
  EXPECT_NE(rig.warnings[0].find("templeSR0011"), std::string::npos);
  EXPECT_TRUE(rig.grid.empty());
  EXPECT_EQ(rig.dimension(), 2);
  EXPECT_GE(rig.triangles.size(), 10u);
  EXPECT_NEAR(rig.cameras[0].intrinsics.fx, 1520.4, 1e-9);
  hull_area(rig);
}

TEST(Rig, GridTriangulationAndHoles) {
  const lf::Rig rig = lf::synthetic_grid_rig(8, 8, 1.0, 64, 48);
  EXPECT_EQ(rig.triangles.size(), 98u);
  EXPECT_NEAR(hull_area(rig), 49.0, 1e-9);
  // Interior camera removed: its hole is re-triangulated (area unchanged).
  const lf::Rig holed = rig.without({rig.grid.at(3, 4)});
  EXPECT_EQ(holed.cameras.size(), 63u);
  EXPECT_NEAR(hull_area(holed), 49.0, 1e-9);
  EXPECT_EQ(holed.triangles.size(), 96u);
  // A corner removed: the convex hull loses half a cell.
  EXPECT_NEAR(hull_area(rig.without({rig.grid.at(0, 0)})), 48.5, 1e-9);
  // Blocks keep the grid.
  const lf::Rig block = lf::grid_block(rig, 2, 2, 3, 4);
  EXPECT_EQ(block.grid.rows, 3);
  EXPECT_EQ(block.grid.cols, 4);
  EXPECT_EQ(block.cameras.size(), 12u);
}

// A real rig's border cameras are not collinear: the convex hull of the
// cameras reaches beyond every triangle, and an eye there saw black (lf-web:
// a long drag to the left on the Chess 4x4 block). The eye is kept on the
// triangles.
TEST(Rig, EyeClampedToTheTrianglesNotTheHull) {
  lf::Rig rig = lf::synthetic_grid_rig(3, 3, 1.0, 64, 48);
  const int mid_left = rig.index_of(rig.grid.at(1, 0)), centre = rig.index_of(rig.grid.at(1, 1));
  lf::Camera& cam = rig.cameras[mid_left];
  const cv::Vec3d c0 = cam.center();
  cam.extrinsics =
      lf::Extrinsics::from_center(cam.extrinsics.R, c0 + 0.3 * (rig.cameras[centre].center() - c0));
  rig.triangles.clear();
  rig.finalize();
  const lf::CameraPlane& P = rig.plane();
  const cv::Vec2d moved = rig.plane_positions()[mid_left], hull_edge = P.to_plane(c0);
  // Half way between the hull's edge and the moved camera: inside the hull,
  // on no triangle.
  const cv::Vec2d q = 0.5 * (moved + hull_edge);
  const cv::Vec2d c = lf::clamp_to_array(rig, q);
  EXPECT_GT(cv::norm(c - q), 0.1);           // moved...
  EXPECT_LT(cv::norm(c - q), 0.15 + 1e-3);   // ...to the nearest triangle (0.15 away)
  EXPECT_EQ(lf::clamp_to_array(rig, c), c);  // which it now lies on
  // On a triangle: unchanged; far off the array: onto its border.
  const cv::Vec2d inside = 0.5 * (moved + rig.plane_positions()[centre]);
  EXPECT_EQ(lf::clamp_to_array(rig, inside), inside);
  const cv::Vec2d far = lf::clamp_to_array(rig, hull_edge + 10.0 * (hull_edge - moved));
  EXPECT_EQ(lf::clamp_to_array(rig, far), far);
}

TEST(Rig, FoldedGridIsRejected) {
  lf::Rig rig = lf::synthetic_grid_rig(3, 3, 1.0, 64, 48);
  // Swap two cameras' positions so that the grid topology contradicts them.
  std::swap(rig.cameras[0].extrinsics, rig.cameras[4].extrinsics);
  rig.triangles.clear();
  EXPECT_THROW(rig.finalize(), std::invalid_argument);
}

TEST(Rig, FileRoundTrip) {
  lf::Rig rig = lf::synthetic_grid_rig(3, 4, 0.1, 320, 240, 45, 2.0, 5);
  rig.cameras[3].intrinsics.k1 = -0.2;
  rig.cameras[3].image = "/nonexistent/cam3.png";
  rig.cameras[3].colour = {1.1, 0.02, 0, -3, 0, 0.9, 0.01, 2, 0, 0, 1.05, 0};
  rig.grid.cells[5] = -1;  // an empty grid position
  rig.cameras.erase(rig.cameras.begin() + 11);
  rig.grid.cells[11] = -1;
  rig.triangles.clear();
  rig.finalize();
  const auto path = std::filesystem::temp_directory_path() / "lf_rig_roundtrip.json";
  lf::save_rig(rig, path.string());
  const lf::Rig back = lf::load_rig(path.string());
  ASSERT_EQ(back.cameras.size(), rig.cameras.size());
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    EXPECT_EQ(back.cameras[i].id, rig.cameras[i].id);
    EXPECT_EQ(back.cameras[i].intrinsics.k1, rig.cameras[i].intrinsics.k1);
    EXPECT_LT(cv::norm(back.cameras[i].extrinsics.R - rig.cameras[i].extrinsics.R), 1e-15);
    EXPECT_EQ(back.cameras[i].extrinsics.t, rig.cameras[i].extrinsics.t);
  }
  EXPECT_EQ(back.cameras[3].image, "/nonexistent/cam3.png");
  EXPECT_EQ(back.cameras[3].colour, rig.cameras[3].colour);
  EXPECT_FALSE(back.cameras[2].has_colour_correction());
  EXPECT_EQ(back.triangles, rig.triangles);
  EXPECT_EQ(back.grid.cells, rig.grid.cells);
  std::filesystem::remove(path);
}

// lf-rig --synthetic --images: a synthetic rig written as a dataset reloads
// with every camera's image, pixel for pixel the scene's analytic render
// (PNG is lossless), and the disc stands out of the background (the images
// differ between cameras: parallax, not one picture copied).
TEST(Rig, SyntheticImagesMakeARigADataset) {
  const auto dir = std::filesystem::temp_directory_path() / "lf_rig_synthetic_images";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.05, 160, 120);
  const lf::Rig written = lf::write_synthetic_images(rig, dir.string());
  lf::save_rig(written, (dir / "rig.json").string());
  const lf::Rig back = lf::load_rig_or_dataset((dir / "rig.json").string());
  ASSERT_EQ(back.cameras.size(), 9u);
  const std::vector<cv::Mat> images = lf::load_images(back);
  const lf::SyntheticScene scene = lf::SyntheticScene::for_rig(rig);
  for (size_t i = 0; i < images.size(); ++i) {
    ASSERT_EQ(images[i].size(), cv::Size(160, 120));
    EXPECT_EQ(cv::norm(images[i], scene.render(rig.cameras[i], 0.0, false), cv::NORM_INF), 0)
        << "camera " << i;
  }
  EXPECT_GT(cv::norm(images[0], images[8], cv::NORM_L1) / (160 * 120 * 3), 5.0);
  EXPECT_THROW(lf::write_synthetic_images(rig, (dir / "missing").string()), std::runtime_error);
  std::filesystem::remove_all(dir);
}

TEST(Rig, BadRigFilesGiveClearErrors) {
  const std::string good = lf::rig_to_json(lf::synthetic_grid_rig(2, 2, 0.1, 64, 48));
  auto expect_error = [](const std::string& text, const std::string& word) {
    try {
      lf::rig_from_json(text, "test.json");
      ADD_FAILURE() << "accepted: " << word;
    } catch (const std::runtime_error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("test.json"), std::string::npos) << msg;
      EXPECT_NE(msg.find(word), std::string::npos) << msg;
    }
  };
  auto replace = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    const auto at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return s.replace(at, from.size(), to);
  };
  expect_error("{not json", "not valid JSON");
  expect_error("[]", "not a JSON object");
  expect_error(replace("\"lightfield-gst-rig\"", "\"other\""), "format");
  expect_error(replace("\"version\": 1", "\"version\": 99"), "unsupported version");
  expect_error(replace("\"fx\":", "\"fx_\":"), "'fx'");
  expect_error(replace("\"width\": 64", "\"width\": 0"), "image size");
  expect_error(replace("\"fx\": ", "\"fx\": -"), "focal");
  expect_error(replace("\"id\": 1,", "\"id\": 0,"), "unknown camera id 1");
  lf::Rig dup = lf::synthetic_grid_rig(2, 2, 0.1, 64, 48);
  dup.cameras[1].id = 0;
  EXPECT_THROW(dup.finalize(), std::invalid_argument);
  // A rig whose R is not a rotation (serialized without finalize()).
  lf::Rig skew = lf::synthetic_grid_rig(2, 2, 0.1, 64, 48);
  skew.cameras[2].extrinsics.R(0, 1) = 0.3;
  expect_error(lf::rig_to_json(skew), "not a rotation");
  EXPECT_THROW(lf::load_rig("/nonexistent/rig.json"), std::runtime_error);
  EXPECT_THROW(lf::import_dataset("/nonexistent"), std::runtime_error);
  // Finite is not enough: implausible numbers are refused by name.
  expect_error(replace("\"fx\": ", "\"fx\": 1e308, \"fx_was\": "), "focal length");
  expect_error(replace("\"cx\": ", "\"cx\": 1e9, \"cx_was\": "), "principal point");
  expect_error(replace("\"k1\": ", "\"k1\": 1e6, \"k1_was\": "), "distortion");
  lf::Rig far = lf::synthetic_grid_rig(2, 2, 0.1, 64, 48);
  far.cameras[3].extrinsics.t[0] = 1e12;
  expect_error(lf::rig_to_json(far), "translation");
}

// Bounds checked before anything is built: the camera count (a rig declaring
// 10^6 cameras once took 3.2 GB before it was refused) and the text's size.
TEST(Rig, HugeRigFilesAreRefusedBeforeTheyAreBuilt) {
  nlohmann::json j =
      nlohmann::json::parse(lf::rig_to_json(lf::synthetic_grid_rig(1, 2, 0.1, 64, 48)));
  j.erase("grid");
  j.erase("triangles");
  const nlohmann::json cam = j["cameras"][0];
  j["cameras"] = nlohmann::json::array();
  for (int i = 0; i < 16385; ++i) j["cameras"].push_back(cam);
  const std::string many = j.dump();  // compact: under the size bound
  ASSERT_LT(many.size(), 16u << 20);
  try {
    lf::rig_from_json(many, "many.json");
    ADD_FAILURE() << "a rig of 16385 cameras was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("16385 cameras (at most 16384)"), std::string::npos)
        << e.what();
  }
  const std::string big(17u << 20, ' ');
  try {
    lf::rig_from_json(big, "big.json");
    ADD_FAILURE() << "17 MiB of text were parsed";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not parsed"), std::string::npos) << e.what();
  }
}

// The still cache (lf/io/still_cache.h): a miss decodes and stores, a hit gives
// the same pixels without decoding; a changed source, a damaged cache file,
// another size miss; the directory stays within its byte budget; a cache
// that cannot be written never fails a read.
class StillCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = std::filesystem::temp_directory_path() /
            ("lf-test-still-cache-" + std::to_string(::getpid()));
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_);
    cache_.dir = (root_ / "cache").string();
    image_ = (root_ / "camera.png").string();
    write_source("first contents");
  }
  void TearDown() override { std::filesystem::remove_all(root_); }
  void write_source(const std::string& bytes) { std::ofstream(image_, std::ios::binary) << bytes; }
  // A still whose pixels depend on `seed`, counting the decodes.
  cv::Mat get(int w, int h, int seed, lf::StillSource* from, std::string* note = nullptr) {
    return lf::cached_still(
        cache_, image_, w, h, CV_8UC4,
        [&] {
          ++decodes_;
          cv::Mat m(h, w, CV_8UC4);
          cv::RNG rng(static_cast<uint64_t>(seed));
          rng.fill(m, cv::RNG::UNIFORM, 0, 256);
          return m;
        },
        from, note);
  }
  std::vector<std::filesystem::path> files(const std::string& ext) const {
    std::vector<std::filesystem::path> out;
    for (const auto& e : std::filesystem::directory_iterator(cache_.dir))
      if (e.path().extension() == ext) out.push_back(e.path());
    return out;
  }
  std::filesystem::path root_;
  lf::StillCache cache_;
  std::string image_;
  int decodes_ = 0;
};

TEST_F(StillCacheTest, MissDecodesAndStoresHitReadsTheSamePixels) {
  lf::StillSource from;
  std::string note = "x";
  const cv::Mat a = get(70, 40, 10, &from, &note);
  EXPECT_EQ(from, lf::StillSource::kDecoded);
  EXPECT_EQ(note, "");
  ASSERT_EQ(files(".still").size(), 1u);
  EXPECT_EQ(
      std::filesystem::file_size(files(".still")[0]),
      56 + std::filesystem::absolute(image_).lexically_normal().string().size() + 70 * 40 * 4);
  const cv::Mat b = get(70, 40, 99, &from);  // a decode would give other pixels
  EXPECT_EQ(from, lf::StillSource::kCache);
  EXPECT_EQ(decodes_, 1);
  ASSERT_EQ(b.size(), a.size());
  ASSERT_EQ(b.type(), CV_8UC4);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0);
  EXPECT_TRUE(files(".tmp").empty());
}

TEST_F(StillCacheTest, ChangedSourceOtherSizeAndDamageMiss) {
  lf::StillSource from;
  get(70, 40, 10, &from);
  // Another size of the same image: a second entry.
  get(35, 20, 10, &from);
  EXPECT_EQ(from, lf::StillSource::kDecoded);
  EXPECT_EQ(files(".still").size(), 2u);
  // The source rewritten (another size, another time): decoded again.
  const auto before = files(".still");
  write_source("second, longer contents");
  const cv::Mat fresh = get(70, 40, 50, &from);
  EXPECT_EQ(from, lf::StillSource::kDecoded);
  EXPECT_EQ(decodes_, 3);
  // One pixel byte of the stored file flipped: the CRC misses, the file is
  // replaced by a good one.
  std::filesystem::path newest;
  for (const auto& f : files(".still"))
    if (std::find(before.begin(), before.end(), f) == before.end()) newest = f;
  ASSERT_FALSE(newest.empty());
  {
    std::fstream f(newest, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(-7, std::ios::end);
    char c = 0;
    f.read(&c, 1);
    f.seekp(-7, std::ios::end);
    c = static_cast<char>(c ^ 0x5a);
    f.write(&c, 1);
  }
  const cv::Mat again = get(70, 40, 50, &from);
  EXPECT_EQ(from, lf::StillSource::kDecoded);
  EXPECT_EQ(cv::norm(fresh, again, cv::NORM_INF), 0);
  get(70, 40, 77, &from);
  EXPECT_EQ(from, lf::StillSource::kCache);
  // Truncated: a miss too.
  std::filesystem::resize_file(newest, std::filesystem::file_size(newest) - 1);
  get(70, 40, 50, &from);
  EXPECT_EQ(from, lf::StillSource::kDecoded);
  EXPECT_EQ(decodes_, 5);
}

TEST_F(StillCacheTest, StaysWithinItsBudgetLeastRecentlyUsedFirst) {
  // Three images of one size; room for two. File times have a coarse clock
  // (a few ms): the steps are 20 ms apart.
  std::vector<std::string> images;
  for (const char* name : {"a.png", "b.png", "c.png"}) {
    images.push_back((root_ / name).string());
    std::ofstream(images.back(), std::ios::binary) << name;
  }
  const std::uintmax_t one = 56 + images[0].size() + 50 * 50 * 4;
  cache_.max_bytes = 2 * one + one / 2;
  auto use = [&](int k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    image_ = images[k];
    lf::StillSource from;
    get(50, 50, k, &from);
    return from;
  };
  EXPECT_EQ(use(0), lf::StillSource::kDecoded);
  EXPECT_EQ(use(1), lf::StillSource::kDecoded);
  EXPECT_EQ(use(0), lf::StillSource::kCache);    // a is used again: b is the oldest
  EXPECT_EQ(use(2), lf::StillSource::kDecoded);  // over budget: b goes
  std::uintmax_t total = 0;
  for (const auto& f : files(".still")) total += std::filesystem::file_size(f);
  EXPECT_LE(total, cache_.max_bytes);
  EXPECT_EQ(files(".still").size(), 2u);
  EXPECT_EQ(use(0), lf::StillSource::kCache);
  EXPECT_EQ(use(2), lf::StillSource::kCache);
  EXPECT_EQ(use(1), lf::StillSource::kDecoded);
  EXPECT_EQ(decodes_, 4);
}

TEST_F(StillCacheTest, ACacheThatCannotBeWrittenNeverFailsARead) {
  cache_.dir = (root_ / "camera.png" / "cache").string();  // under a regular file
  lf::StillSource from;
  std::string note;
  const cv::Mat m = get(30, 20, 5, &from, &note);
  EXPECT_EQ(from, lf::StillSource::kDecoded);
  EXPECT_EQ(m.size(), cv::Size(30, 20));
  EXPECT_NE(note.find("cannot create"), std::string::npos) << note;
  // No cache at all: decoded every time.
  cache_.dir.clear();
  get(30, 20, 5, &from);
  get(30, 20, 5, &from);
  EXPECT_EQ(decodes_, 3);
  // A missing source is decode()'s to report.
  std::filesystem::remove(image_);
  cache_.dir = (root_ / "cache").string();
  EXPECT_THROW(lf::cached_still(
                   cache_, image_, 30, 20, CV_8UC4,
                   []() -> cv::Mat { throw std::runtime_error("image camera.png: unreadable"); }),
               std::runtime_error);
  // decode() of the wrong size is a programming error.
  write_source("x");
  EXPECT_THROW(lf::cached_still(cache_, image_, 30, 20, CV_8UC4,
                                [] { return cv::Mat(20, 31, CV_8UC4, cv::Scalar::all(0)); }),
               std::logic_error);
}

// lf::read_image (libpng, TurboJPEG) gives cv::imread(IMREAD_COLOR)'s pixels:
// the datasets' PNG and JPEG images, and PNGs of other kinds that OpenCV
// writes (grey, 16-bit colour and grey, alpha) and a grey JPEG.
TEST(ImageIo, SamePixelsAsOpenCv) {
  std::vector<std::string> files;
  for (const char* d : {"stanford-chess", "blender-shop-9x9", "hci-cotton", "middlebury-dino"}) {
    if (!testing_lf::have_data(d)) continue;
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(data_path(d))) {
      const std::string ext = e.path().extension().string();
      if (ext == ".png" || ext == ".jpg") names.push_back(e.path().string());
    }
    std::sort(names.begin(), names.end());
    for (size_t i = 0; i < names.size() && i < 3; ++i) files.push_back(names[i]);
  }
  const auto dir =
      std::filesystem::temp_directory_path() / ("lf-test-image-io-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  cv::Mat colour(37, 53, CV_8UC3);
  cv::randu(colour, cv::Scalar::all(0), cv::Scalar::all(256));
  cv::Mat grey, alpha, deep, deep_grey;
  cv::cvtColor(colour, grey, cv::COLOR_BGR2GRAY);
  cv::cvtColor(colour, alpha, cv::COLOR_BGR2BGRA);
  cv::randu(alpha.reshape(1).colRange(0, 1), 0, 256);  // not all opaque
  colour.convertTo(deep, CV_16UC3, 257.3);
  grey.convertTo(deep_grey, CV_16UC1, 255.7);
  const std::vector<std::pair<std::string, cv::Mat>> made = {
      {"grey.png", grey},           {"alpha.png", alpha}, {"deep.png", deep},
      {"deep-grey.png", deep_grey}, {"grey.jpg", grey},   {"colour.jpg", colour}};
  for (const auto& [name, m] : made) {
    const std::string f = (dir / name).string();
    ASSERT_TRUE(cv::imwrite(f, m)) << f;
    files.push_back(f);
  }
  for (const auto& f : files) {
    const cv::Mat ours = lf::read_image(f), theirs = cv::imread(f, cv::IMREAD_COLOR);
    ASSERT_FALSE(theirs.empty()) << f;
    ASSERT_EQ(ours.type(), CV_8UC3) << f;
    ASSERT_EQ(ours.size(), theirs.size()) << f;
    EXPECT_EQ(cv::norm(ours, theirs, cv::NORM_INF), 0) << f;
    EXPECT_EQ(lf::read_image_size(f), theirs.size()) << f;
  }
  EXPECT_GE(files.size(), made.size() + (testing_lf::have_data("stanford-chess") ? 3u : 0u));
  std::filesystem::remove_all(dir);
}

// Missing, foreign and damaged files: std::runtime_error naming the file.
TEST(ImageIo, BadFilesGiveClearErrors) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("lf-test-image-io-bad-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  cv::Mat m(40, 60, CV_8UC3);
  cv::randu(m, cv::Scalar::all(0), cv::Scalar::all(256));
  std::vector<uchar> png, jpg;
  cv::imencode(".png", m, png);
  cv::imencode(".jpg", m, jpg);
  auto write = [&](const std::string& name, const std::vector<uchar>& bytes) {
    const std::string f = (dir / name).string();
    std::ofstream(f, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()),
               static_cast<std::streamsize>(bytes.size()));
    return f;
  };
  auto fails = [](const std::string& f, const std::string& why) {
    try {
      lf::read_image(f);
      ADD_FAILURE() << f << " was read";
    } catch (const std::runtime_error& e) {
      const std::string w = e.what();
      EXPECT_NE(w.find(f), std::string::npos) << w;
      EXPECT_NE(w.find(why), std::string::npos) << w;
    }
  };
  fails((dir / "none.png").string(), "missing or unreadable");
  fails(write("text.png", {'h', 'e', 'l', 'l', 'o', '\n'}), "neither PNG nor JPEG");
  fails(write("cut.png", std::vector<uchar>(png.begin(), png.begin() + png.size() / 2)),
        "damaged PNG");
  std::vector<uchar> flipped = png;
  flipped[png.size() / 2] ^= 0x55;  // inside the image data: its CRC fails
  fails(write("flipped.png", flipped), "damaged PNG");
  fails(write("header.jpg", std::vector<uchar>(jpg.begin(), jpg.begin() + 20)), "damaged JPEG");
  EXPECT_THROW(lf::read_image_size((dir / "none.png").string()), std::runtime_error);
  // A JPEG cut short is an error, not a picture grey below the cut (libjpeg
  // only warns, and cv::imread returns that picture); so is one whose
  // entropy-coded data is garbage.
  fails(write("cut.jpg", std::vector<uchar>(jpg.begin(), jpg.end() - 200)),
        "truncated or corrupt JPEG");
  std::vector<uchar> garbled = jpg;
  for (size_t i = garbled.size() / 2; i < garbled.size() - 2; ++i) garbled[i] = 0xff;
  fails(write("garbled.jpg", garbled), "JPEG");
  // The intact files read.
  EXPECT_EQ(lf::read_image(write("ok.jpg", jpg)).size(), m.size());
  EXPECT_TRUE(lf::is_still_image((dir / "ok.jpg").string()));
  EXPECT_FALSE(lf::is_still_image((dir / "text.png").string()));
  EXPECT_FALSE(lf::is_still_image((dir / "none.png").string()));
  std::filesystem::remove_all(dir);
}

// A still fits a camera only by one uniform resize (a scaled rig), never by
// stretching: another shape names the file.
// lf::StillSequence (lfcamsrc mode=file with stills): frames in order, a
// damaged one an error naming it or with skip_bad_frames skipped, the end
// or (loop) the first frame again, a missing first frame, and a sequence
// of which no frame decodes.
TEST(ImageIo, StillSequenceFramesSkipsLoopsAndEnds) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("lf-test-still-sequence-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  for (int k = 0; k < 3; ++k) {
    cv::Mat m(40, 60, CV_8UC3, cv::Scalar(10 * k, 20, 30));
    cv::imwrite((dir / ("f" + std::to_string(k) + ".png")).string(), m);
  }
  std::ofstream((dir / "f1.png").string(), std::ios::binary | std::ios::trunc) << "not a png";
  const std::string pattern = (dir / "f%d.png").string();
  using What = lf::StillSequence::Next::What;
  cv::Mat rgba;
  lf::StillSequence strict(pattern, 60, 40, false, false);
  auto n = strict.next(&rgba);
  ASSERT_EQ(n.what, What::kFrame) << n.error;
  EXPECT_EQ(rgba.type(), CV_8UC4);
  EXPECT_EQ(rgba.at<cv::Vec4b>(0, 0), cv::Vec4b(30, 20, 0, 255));  // BGR (0, 20, 30) as RGBA
  n = strict.next(&rgba);
  EXPECT_EQ(n.what, What::kUndecodable);
  EXPECT_NE(n.error.find("f1.png (frame 1)"), std::string::npos) << n.error;

  lf::StillSequence skipping(pattern, 30, 20, true, true);  // half size: one uniform resize
  EXPECT_EQ(skipping.next(&rgba).what, What::kFrame);
  n = skipping.next(&rgba);
  ASSERT_EQ(n.what, What::kFrame);
  ASSERT_EQ(n.skipped.size(), 1u);
  EXPECT_NE(n.skipped[0].find("frame 1"), std::string::npos);
  EXPECT_EQ(rgba.size(), cv::Size(30, 20));
  EXPECT_EQ(rgba.at<cv::Vec4b>(0, 0)[2], 20);  // frame 2
  n = skipping.next(&rgba);                    // the end, looped: frame 0 again
  EXPECT_EQ(n.what, What::kFrame);
  EXPECT_EQ(rgba.at<cv::Vec4b>(0, 0)[2], 0);

  lf::StillSequence once(pattern, 60, 40, false, true);
  for (int k = 0; k < 2; ++k) EXPECT_EQ(once.next(&rgba).what, What::kFrame);
  EXPECT_EQ(once.next(&rgba).what, What::kEnd);

  lf::StillSequence still((dir / "f0.png").string(), 60, 40, true, false);
  EXPECT_EQ(still.next(&rgba).what, What::kFrame);
  EXPECT_EQ(still.next(&rgba).what, What::kSame);
  EXPECT_EQ(lf::StillSequence((dir / "g%d.png").string(), 60, 40, true, true).next(&rgba).what,
            What::kMissing);
  std::ofstream((dir / "f0.png").string(), std::ios::binary | std::ios::trunc) << "bad";
  std::ofstream((dir / "f2.png").string(), std::ios::binary | std::ios::trunc) << "bad";
  n = lf::StillSequence(pattern, 60, 40, true, true).next(&rgba);
  EXPECT_EQ(n.what, What::kUndecodable);
  EXPECT_NE(n.error.find("no frame of the sequence decodes"), std::string::npos) << n.error;
  std::filesystem::remove_all(dir);
}

TEST(ImageIo, StillOfAnotherSizeIsRefused) {
  EXPECT_NO_THROW(lf::check_image_fits("a.png", cv::Size(1400, 800), 1400, 800));
  EXPECT_NO_THROW(lf::check_image_fits("a.png", cv::Size(1400, 800), 700, 400));
  EXPECT_NO_THROW(lf::check_image_fits("a.png", cv::Size(1401, 801), 467, 267));  // scale 1/3
  try {
    lf::check_image_fits("b.jpg", cv::Size(640, 480), 1400, 800);
    ADD_FAILURE() << "a 640x480 still fitted a 1400x800 camera";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("b.jpg"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("640x480"), std::string::npos) << e.what();
  }
}

}  // namespace
