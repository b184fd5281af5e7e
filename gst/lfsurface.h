// The lf-surface event: lfcompositor's answer to a surface probe
// (lib/lf/focus/surface_probe.h), sent upstream to lfviewrequest, which puts the
// surface into its requests. A GstStructure named "lf-surface" with
//   viewer-id (uint), probe-id (uint), capture-time (int64, ns of running
//   time of the frames measured, -1 unknown), tile, cols, rows (int: the
//   lf::FocalSurface grid), planes (GBytes: 4 doubles per plane, n.x, n.y,
//   n.z, d, world frame, n.X + d = 0; plane 0 the single plane), plane-of
//   (GBytes: one plane index per tile, row-major), planes-used (int), and
//   with second planes second-of (GBytes: one plane index per tile, 255 for
//   none; lf::FocalSurface::second_of).
// One place writes and reads the layout: the compositor, the view request
// and the tests.
#pragma once

#include <gst/gst.h>

#include <vector>

#include "lf/geometry/view.h"

namespace lfgst {

constexpr gsize kSurfacePlaneBytes = 4 * sizeof(double);

inline GstStructure* surface_structure(guint viewer, guint probe, gint64 capture_ns,
                                       const lf::FocalSurface& fs, int planes_used) {
  std::vector<double> planes;
  for (const lf::FocalPlane& pl : fs.planes)
    planes.insert(planes.end(), {pl.n[0], pl.n[1], pl.n[2], pl.d});
  GBytes* pb = g_bytes_new(planes.data(), planes.size() * sizeof(double));
  GBytes* ob = g_bytes_new(fs.plane_of.data(), fs.plane_of.size());
  GstStructure* s = gst_structure_new(
      "lf-surface", "viewer-id", G_TYPE_UINT, viewer, "probe-id", G_TYPE_UINT, probe,
      "capture-time", G_TYPE_INT64, capture_ns, "tile", G_TYPE_INT, fs.tile, "cols", G_TYPE_INT,
      fs.cols, "rows", G_TYPE_INT, fs.rows, "planes", G_TYPE_BYTES, pb, "plane-of", G_TYPE_BYTES,
      ob, "planes-used", G_TYPE_INT, planes_used, nullptr);
  g_bytes_unref(pb);
  g_bytes_unref(ob);
  if (fs.two_planes()) {
    GBytes* sb = g_bytes_new(fs.second_of.data(), fs.second_of.size());
    gst_structure_set(s, "second-of", G_TYPE_BYTES, sb, nullptr);
    g_bytes_unref(sb);
  }
  return s;
}

// Reads an lf-surface structure's probe id and surface; false when a field
// is missing, of another type or out of its bounds (tile 4..1024, cols and
// rows 1..16384, 1..64 planes, one plane index per tile, and per tile a
// second-plane index when second-of is there). Only sizes are
// checked: whoever uses the surface checks it against its view
// (lf::validate).
inline bool read_surface_structure(const GstStructure* s, guint* probe, lf::FocalSurface* fs) {
  const GValue* pv = gst_structure_get_value(s, "planes");
  const GValue* ov = gst_structure_get_value(s, "plane-of");
  GBytes* planes =
      pv && G_VALUE_HOLDS(pv, G_TYPE_BYTES) ? static_cast<GBytes*>(g_value_get_boxed(pv)) : nullptr;
  GBytes* plane_of =
      ov && G_VALUE_HOLDS(ov, G_TYPE_BYTES) ? static_cast<GBytes*>(g_value_get_boxed(ov)) : nullptr;
  gint tile = 0, cols = 0, rows = 0;
  if (!gst_structure_get_uint(s, "probe-id", probe) || !gst_structure_get_int(s, "tile", &tile) ||
      !gst_structure_get_int(s, "cols", &cols) || !gst_structure_get_int(s, "rows", &rows) ||
      !planes || !plane_of || tile < lf::FocalSurface::kMinTile ||
      tile > lf::FocalSurface::kMaxTile || cols < 1 || rows < 1 || cols > 16384 || rows > 16384)
    return false;
  gsize np = 0, no = 0;
  const auto* d = static_cast<const double*>(g_bytes_get_data(planes, &np));
  const auto* o = static_cast<const uint8_t*>(g_bytes_get_data(plane_of, &no));
  if (np % kSurfacePlaneBytes != 0 || np < kSurfacePlaneBytes ||
      np > lf::FocalSurface::kMaxPlanes * kSurfacePlaneBytes ||
      no != static_cast<gsize>(cols) * static_cast<gsize>(rows))
    return false;
  fs->tile = tile, fs->cols = cols, fs->rows = rows;
  fs->planes.clear();
  for (gsize i = 0; i < np / kSurfacePlaneBytes; ++i) {
    lf::FocalPlane pl;
    pl.n = cv::Vec3d(d[4 * i], d[4 * i + 1], d[4 * i + 2]);
    pl.d = d[4 * i + 3];
    fs->planes.push_back(pl);
  }
  fs->plane_of.assign(o, o + no);
  fs->second_of.clear();
  if (const GValue* sv = gst_structure_get_value(s, "second-of")) {
    if (!G_VALUE_HOLDS(sv, G_TYPE_BYTES)) return false;
    gsize ns = 0;
    const auto* so = static_cast<const uint8_t*>(
        g_bytes_get_data(static_cast<GBytes*>(g_value_get_boxed(sv)), &ns));
    if (ns != no) return false;
    fs->second_of.assign(so, so + ns);
  }
  return true;
}

}  // namespace lfgst
