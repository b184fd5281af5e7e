#include "lfguard.h"

namespace lfgst {

GQuark error_quark() {
  return g_quark_from_static_string("lightfield-error-quark");
}

}  // namespace lfgst
