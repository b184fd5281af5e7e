// Bin properties forwarded to children (lfcamerahost, lfarray): a copy of a
// child element's property on the bin, set on every child of that kind
// when the bin builds them.
#pragma once

#include <gst/gst.h>

namespace lfgst {

// A bin property that is set on each child of one kind.
struct Forward {
  GType (*child)();
  const char* name;
};

// Installs copies of the children's properties [begin, end) on `oc`, with
// ids from `id` on: same name, type, range, default and text, readable,
// writable and changeable in NULL or READY on the bin; the text says so
// where the child itself takes changes while playing.
void install_forwards(GObjectClass* oc, guint id, const Forward* begin, const Forward* end);

}  // namespace lfgst
