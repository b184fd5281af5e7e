// Memory back to the system after a burst: glibc keeps the chunks a process
// freed mapped (its per-thread arenas, and a mmap threshold that rises to
// the largest buffer freed), so the memory of a viewer's 4K frames stays in
// the RSS after its stream ended. An element that freed a large amount at
// once (lfcompositor at the end of its stream) asks for a trim here.
#pragma once

#include <gst/gst.h>

namespace lfgst {

// Buffers of at least this many bytes are mapped on their own (new_buffer).
constexpr gsize kOwnMappingBytes = 1 << 20;

// A new writable buffer of `size` bytes: at kOwnMappingBytes or more, in
// an anonymous mapping of its own (mmap, in whole kOwnMappingBytes), which
// goes back to the system 1 s after the buffer is freed unless a buffer of
// its size takes it again (at most 256 MiB kept; release_buffers() and
// trim_heap() unmap them at once); smaller ones as gst_buffer_new_allocate().
// Large fragments (a 3840x2160 view's are up to 33 MB) otherwise come from
// glibc's arenas once its mmap threshold has risen to their size, and a
// burst of them stayed in the RSS after the burst, freed but fragmented
// (docs/reliability.md). Null when the mapping fails. Thread-safe.
GstBuffer* new_buffer(gsize size);
// Unmaps the mappings new_buffer() keeps for reuse.
void release_buffers();

// release_buffers() and malloc_trim(0) (glibc; nothing elsewhere), at most
// once a second in the process. Thread-safe.
void trim_heap();

}  // namespace lfgst
