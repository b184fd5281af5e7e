// lfcamerahost (gst/lfcamerahost.cpp): a camera host's bin, and the base of
// lfarray (gst/lfarray.cpp), which adds an lfcompositor after the fragments.
#pragma once

#include <gst/gst.h>

G_BEGIN_DECLS
#define LF_TYPE_CAMERA_HOST (lf_camera_host_get_type())
G_DECLARE_DERIVABLE_TYPE(LfCameraHost, lf_camera_host, LF, CAMERA_HOST, GstBin)
struct _LfCameraHostClass {
  GstBinClass parent_class;
  gboolean composite;  // lfarray: an lfcompositor after the fragments
};
G_END_DECLS

// For a subclass that composites (lfarray): installs its own properties
// (`whole_view`, the boolean whole-view, and the lfcompositor properties it
// sets on its compositor) on `oc`, with the camera host's property handlers.
void lf_camera_host_install_composite_properties(GObjectClass* oc, GParamSpec* whole_view);
// For such a subclass's instance init: replaces the fragment `src` pad by a
// ghost pad of the class's own `src` template.
void lf_camera_host_replace_src(LfCameraHost* self);
