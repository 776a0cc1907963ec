// Sort-last compositing over MPI, GL-free: binary swap in visibility order (a fold first when the rank count is not a
// power of two), then a gather of the pieces to rank 0. Only each piece's active rectangle travels, as 16-bit
// floats (half) or 32-bit floats per channel. Every point-to-point transfer is non-blocking and polled against a
// deadline (Deadline.h), so a dead or stalled peer is reported by rank instead of hanging the frame.
#pragma once

#include <mpi.h>

#include <cstdint>
#include <string>
#include <vector>

#include "distributed/Deadline.h"
#include "image/Image.h"
#include "render/core/PartialFrame.h"

namespace voxbrick::distributed {

/// How pixels travel between ranks.
enum class PixelEncoding {
  Half,   ///< 16-bit IEEE half floats per channel (round to nearest even): half the bytes, error below 1/2048
  Float,  ///< 32-bit floats per channel, exact
};

/// The encoding named "half" or "float" (the --mpi-encoding values); throws std::invalid_argument for another name.
PixelEncoding parsePixelEncoding(const std::string& name);
/// "half" or "float".
const char* pixelEncodingName(PixelEncoding encoding);

/// What one compositing cost the calling rank.
struct CompositeStats {
  double ms = 0;               ///< from entry to return on this rank
  uint64_t bytesSent = 0;      ///< message bytes this rank sent (headers and pixels)
  uint64_t bytesReceived = 0;  ///< message bytes this rank received
  int rounds = 0;              ///< exchanges this rank took part in (fold, swap rounds, gather)
};

struct CompositeOptions {
  PixelEncoding encoding = PixelEncoding::Half;
  double timeoutSeconds = 10;  ///< the most any one transfer may wait for its peer
  int tag = 7100;              ///< the first of the 4 message tags this compositing uses on the communicator
};

/// Joins the premultiplied partial frames (all the same size) of the ranks named in `frontToBack`, in visibility
/// order: `frontToBack[i]` is the rank whose part is i-th nearest. It names rank 0 and each rank at most once (the
/// same list on every rank named); ranks of `comm` it does not name take no part (a rank lost: the survivors go on
/// without it). Rank 0 returns the whole premultiplied frame (compositeSerial of the parts in that order, within the
/// encoding's rounding); the other ranks return an empty image. `partial` is taken by value: move a frame in that is
/// not needed after. Collective over the ranks named: each must call it with the same order, size and options. Throws
/// PeerError naming the rank when a transfer fails or passes its deadline, and std::invalid_argument for
/// inconsistent arguments on this rank.
image::ImageF composite(MPI_Comm comm, image::ImageF partial, const std::vector<int>& frontToBack,
                        const CompositeOptions& options = {}, CompositeStats* stats = nullptr);

}  // namespace voxbrick::distributed
