// Memory back to the system after a burst: glibc keeps the chunks a process
// freed mapped (its per-thread arenas, and a mmap threshold that rises to
// the largest buffer freed), so the memory of a viewer's 4K frames stays in
// the RSS after its stream ended. An element that freed a large amount at
// once (lfcompositor at the end of its stream) asks for a trim here.
#pragma once

namespace lfgst {

// malloc_trim(0) (glibc; nothing elsewhere), at most once a second in the
// process. Thread-safe.
void trim_heap();

}  // namespace lfgst
