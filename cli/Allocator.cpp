// The allocator's policy for the commands that make frames, and for prep.
#include <malloc.h>

#include "cli/Commands.h"

namespace voxbrick::cli {

void keepFreedMemoryForFrames() {
  // glibc returns a freed block above M_MMAP_THRESHOLD (128 KB, adapted up to the largest freed mmapped block) to
  // the system at once, and trims a heap's free top beyond M_TRIM_THRESHOLD (2x that); the next frame's read-back,
  // image and decompressed bricks then fault their pages in afresh: 13 ms for 4 MB on a virtual machine here, 28 ms
  // of a 165 ms 512x512 frame. Blocks up to 32 MB come from the heap instead, and up to 64 MB of free top is kept.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 64 << 20);
}

void growHeapInLargeSteps() {
  // prep allocates its OpenVDB grid a 2 KB leaf at a time from every thread. In a thread's own arena glibc grows
  // the heap by the page it needs, one mprotect call each, and the page faults that follow; one arena grown 64 MB at
  // a time took a tenth less of the kernel's CPU on a 512^3 prep (perf, cpu-clock samples). The leaves are made in
  // parallel_for tasks of many leaves each, so the arena's lock is not fought over.
  mallopt(M_ARENA_MAX, 1);
  mallopt(M_TOP_PAD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
}

}  // namespace voxbrick::cli
