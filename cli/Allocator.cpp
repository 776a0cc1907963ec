// The allocator's policy for the commands that make frames, and for prep.
#include <malloc.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <string>

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

namespace {

constexpr const char* kHugeTunable = "glibc.malloc.hugetlb";

/// The kernel's transparent huge page mode: "always", "madvise", "never", or "" where it does not say.
std::string transparentHugePageMode() {
  std::ifstream file("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string modes;
  std::getline(file, modes);
  const size_t open = modes.find('['), close = modes.find(']');
  return open == std::string::npos || close == std::string::npos || close < open ? ""
                                                                                 : modes.substr(open + 1, close - open - 1);
}

std::string environmentOr(const char* name, const std::string& otherwise) {
  const char* value = std::getenv(name);
  return value ? value : otherwise;
}

/// VOXBRICK_MALLOC_HUGE_PAGES=0: the operator says no.
bool hugePagesRefused() { return environmentOr("VOXBRICK_MALLOC_HUGE_PAGES", "") == "0"; }

}  // namespace

void askHugePagesForMalloc(char** argv) {
  // libvpx allocates a stream's encoder in blocks of up to 50 MB and clears them: from glibc's mmap (blocks above 32
  // MB always are, whatever keepFreedMemoryForFrames says), each 4 KiB page is faulted in as it is cleared, about
  // 6 us a page on a virtual machine here. Making a VP9 encoder for 1024x1024 took 134 ms, one for 1920x1080 267 ms
  // (VP8: 185 ms), every time a stream started; on huge pages 6, 16 (and 9) ms after the process's first
  // (bench/results/video/stream-start.md). Only an environment variable read as the process starts asks glibc for
  // them, hence the second run.
  if (hugePagesRefused()) return;
  const char* before = std::getenv("GLIBC_TUNABLES");
  const std::string tunables = before ? before : "";
  if (tunables.find(kHugeTunable) != std::string::npos) return;
  if (transparentHugePageMode() != "madvise") return;  // always: granted unasked; never: not at all
  const std::string asked = (tunables.empty() ? "" : tunables + ":") + kHugeTunable + "=1";
  if (setenv("GLIBC_TUNABLES", asked.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // Not run again: go on as it was.
  if (before)
    setenv("GLIBC_TUNABLES", before, 1);
  else
    unsetenv("GLIBC_TUNABLES");
}

std::string hugePagesForMallocNote() {
  const std::string mode = transparentHugePageMode();
  const std::string tunables = environmentOr("GLIBC_TUNABLES", "");
  if (tunables.find(kHugeTunable) != std::string::npos)
    return "malloc: GLIBC_TUNABLES=" + tunables + "; the kernel's transparent huge pages: " +
           (mode.empty() ? "not said" : mode);
  if (mode == "madvise" && hugePagesRefused())
    return "malloc: no huge pages asked (VOXBRICK_MALLOC_HUGE_PAGES=0): a video stream's start faults its pages in";
  return "malloc: the kernel's transparent huge pages: " + (mode.empty() ? std::string("not said") : mode);
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
