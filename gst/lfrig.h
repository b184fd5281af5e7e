// Rigs in the elements: one cache per process, and the way every element
// addresses a camera of a rig (camera-id, or row and col of the grid).
#pragma once

#include <gst/gst.h>

#include <memory>
#include <string>

#include "lf/geometry/rig.h"
#include "lfprops.h"

namespace lfgst {

// Loads a rig file or dataset folder (lf::load_rig_or_dataset), shared by
// every element of the process that names the same file: the key is the
// canonical path (relative and absolute names of one file share an entry),
// and an entry is loaded again when the file's (or, for a dataset folder, any
// of its files') modification time or size changed. Throws std::exception
// (std::runtime_error, std::invalid_argument) naming the file and problem.
std::shared_ptr<const lf::Rig> load_rig_cached(const std::string& path);

// As load_rig_cached, for an element starting up: posts an element error
// (no rig given, or why it cannot be loaded) and returns null on failure.
std::shared_ptr<const lf::Rig> open_rig(GstElement* el, const std::string& path);

// How lfcamsrc and lffragment name their camera: camera-id >= 0, or else
// row and col of the rig's grid.
struct CameraAddress {
  gint camera_id = -1;
  gint row = -1;
  gint col = -1;
};

// Installs camera-id, row and col on an element whose settings S derive from
// CameraAddress.
template <class S>
void add_camera_properties(Properties<S>& props, GObjectClass* oc) {
  props.template add<gint>(
      oc, static_cast<gint S::*>(&CameraAddress::camera_id),
      g_param_spec_int("camera-id", "Camera id",
                       "Camera id in the rig (-1: the camera at row, col of the rig's grid)", -1,
                       G_MAXINT, -1, kReadWriteReady));
  props.template add<gint>(
      oc, static_cast<gint S::*>(&CameraAddress::row),
      g_param_spec_int("row", "Row", "Grid row of the camera, with col (-1: unset)", -1, 65535, -1,
                       kReadWriteReady));
  props.template add<gint>(
      oc, static_cast<gint S::*>(&CameraAddress::col),
      g_param_spec_int("col", "Column", "Grid column of the camera, with row (-1: unset)", -1,
                       65535, -1, kReadWriteReady));
}

// Index into rig.cameras of the addressed camera; posts an element error and
// returns -1 when there is none.
int camera_index(GstElement* el, const lf::Rig& rig, const CameraAddress& a);

}  // namespace lfgst
