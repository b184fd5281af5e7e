// core: links the light field core alone (liblightfield-1.0, no GStreamer;
// README "Embedding"): a synthetic 4x4 camera array, the dynamic test scene
// seen by each camera at t = 0, and one virtual view between the cameras,
// focused on the scene's disc, rendered by the paper's algorithm (plan +
// render + composite). Writes the view to OUT.png and prints its size and
// how much of it the fragments covered.
//
// usage: core OUT.png
// build: c++ -std=c++17 core.cpp $(pkg-config --cflags --libs lightfield-1.0) -o core
#include <lf/focus/focus.h>
#include <lf/geometry/view_builder.h>
#include <lf/quality/synthetic.h>
#include <lf/render/render_view.h>

#include <cstdio>
#include <opencv2/imgcodecs.hpp>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s OUT.png\n", argv[0]);
    return 2;
  }
  // 4x4 cameras 5 cm apart, 160x120 pixels, 40 degrees vertical field of view.
  const lf::Rig rig = lf::synthetic_grid_rig(4, 4, 0.05, 160, 120, 40.0);
  const lf::SyntheticScene scene = lf::SyntheticScene::for_rig(rig);
  std::vector<cv::Mat> images;
  for (const lf::Camera& cam : rig.cameras) images.push_back(scene.render(cam, 0.0));
  lf::ViewRequest req;
  // Between the cameras, a quarter spacing right and down of the centre.
  req.view = lf::view_between_cameras(
      rig, rig.plane().origin + lf::camera_plane_offset(rig, 0.0125, 0.0125, 0), 320, 240);
  req.focal_plane = lf::plane_at_depth(rig, scene.near_depth);
  const cv::Mat out = lf::render_view(rig, images, req);
  std::vector<cv::Mat> ch;
  cv::split(out, ch);
  std::printf("view %dx%d, %d of %d pixels covered\n", out.cols, out.rows, cv::countNonZero(ch[3]),
              out.cols * out.rows);
  return cv::imwrite(argv[1], out) ? 0 : 1;
}
