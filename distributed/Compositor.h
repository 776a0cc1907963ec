// Sort-last compositing over MPI, GL-free: radix-k in visibility order over the participating ranks (a k per round,
// binary swap when every k is 2), then a gather to one root rank, either of the premultiplied float frame or of the
// finished 8-bit frame (each rank finishes its own final region over the scene's background). Pixels travel run-length
// encoded (PixelRuns.h): empty pixels never travel and are never blended. Every point-to-point transfer is
// non-blocking and polled against a deadline (Deadline.h), so a dead or stalled peer is reported by rank instead of
// hanging the frame.
#pragma once

#include <mpi.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "distributed/Deadline.h"
#include "distributed/PixelRuns.h"
#include "image/Image.h"
#include "render/core/PartialFrame.h"
#include "render/core/Scene.h"

namespace voxbrick::distributed {

/// The encoding named "half" or "float" (the --mpi-encoding values); throws std::invalid_argument for another name.
PixelEncoding parsePixelEncoding(const std::string& name);
/// "half" or "float".
const char* pixelEncodingName(PixelEncoding encoding);

/// What one compositing cost the calling rank.
struct CompositeStats {
  double ms = 0;               ///< from entry to return on this rank
  uint64_t bytesSent = 0;      ///< message bytes this rank sent (headers, runs and pixels)
  uint64_t bytesReceived = 0;  ///< message bytes this rank received
  int rounds = 0;              ///< exchanges this rank took part in (radix-k rounds, gather)
  /// The pixels this rank handled: its partial frame's within the footprint (read once), the active pixels of every
  /// piece it joined (received, and its own after the first round), and its final region's (finished or sent). What
  /// the cost model charges a cost per pixel for (bench/mpi_model.py).
  uint64_t pixelsHandled = 0;
};

struct CompositeOptions {
  PixelEncoding encoding = PixelEncoding::Half;
  double timeoutSeconds = 10;  ///< the most any one transfer may wait for its peer
  int tag = 7100;              ///< the first of the 4 message tags this compositing uses on the communicator
  /// The ranks of the communicator that take part, in part order: part i is drawn by ranks[i]. Empty: every rank,
  /// part i on rank i. The others do not call the compositor (a server goes on over the survivors of a lost rank).
  std::vector<int> ranks;
  int root = 0;  ///< the rank that receives the frame; one of the participating ranks
  /// Radix-k's k for each round, their product the number of participating ranks; empty: radixFactors(that number).
  std::vector<int> factors;
  Kernels kernels = Kernels::Best;  ///< the portable scalar kernels on request (tests); the same results
  /// The rectangle of this rank's partial frame that may hold anything (its part's projection on the screen,
  /// SortLastParts::footprint): the pixels outside it must be empty, and are taken as such, mostly without being
  /// read (DenseFrame says which are). None: the whole frame.
  std::optional<render::PixelRect> footprint;
};

/// The k of each round radix-k uses by default for `ranks` participating ranks: for up to 8 ranks one round (k =
/// ranks, measured fastest: bench/results/mpi/mpi.md), beyond it the prime factors joined into rounds of k <= 8
/// (64: 8x8). Empty for one rank. Throws std::invalid_argument for ranks < 1.
std::vector<int> radixFactors(int ranks);

/// Every ordered factorisation of `ranks` into factors >= 2 (radix-k's possible rounds; 2x3 and 3x2 both), none for
/// one rank. Throws std::invalid_argument for ranks < 1.
std::vector<std::vector<int>> radixFactorisations(int ranks);

/// Joins the participating ranks' premultiplied partial frames (all the same size) in visibility order:
/// `frontToBack[i]` is the part i-th nearest (an index into options.ranks; with every rank taking part, a rank), a
/// permutation of 0..parts-1, the same on every participating rank. The root returns the whole premultiplied frame
/// (compositeSerial of the parts in that order, within the encoding's rounding); the other ranks return an empty
/// image. Collective over the participating ranks: each must call it with the same order, size and options. Throws
/// PeerError naming the rank when a transfer fails or passes its deadline or a peer sends what was not due, and
/// std::invalid_argument for inconsistent arguments on this rank (a bad rank list, order, factors or root, a frame
/// whose pixels do not match its size, or this rank not among the participants).
image::ImageF composite(MPI_Comm comm, image::ImageF partial, const std::vector<int>& frontToBack,
                        const CompositeOptions& options = {}, CompositeStats* stats = nullptr);

/// As composite, but the root returns the finished 8-bit frame: each rank finishes its own final region through
/// `view` (SceneView::output over the background, then rounded as image::toImage8) and sends it as 8-bit RGBA, so
/// that the frame equals toImage8(render::finishPartial(composite(...), scene)) within the encoding's rounding (one
/// step of 1/255 at most where a value lies near a rounding boundary). The other ranks return an empty image.
image::Image8 compositeFinished(MPI_Comm comm, const image::ImageF& partial, const std::vector<int>& frontToBack,
                                const render::SceneView& view, const CompositeOptions& options = {},
                                CompositeStats* stats = nullptr);
/// The same into `frame`, whose storage is reused when it already has the frame's size (a server's next frame): the
/// root's frame is filled, the other ranks' left empty.
void compositeFinished(MPI_Comm comm, const image::ImageF& partial, const std::vector<int>& frontToBack,
                       const render::SceneView& view, image::Image8& frame, const CompositeOptions& options = {},
                       CompositeStats* stats = nullptr);

}  // namespace voxbrick::distributed
