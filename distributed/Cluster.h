// The MPI world of `voxbrick render --mpi` and `serve --mpi`: MPI started for threads that take turns
// (MPI_THREAD_SERIALIZED) with errors returned rather than fatal, and the collective steps every rank takes together
// with a deadline: broadcasting a command from rank 0, gathering one record per rank, and agreeing that every rank
// opened the same dataset (refused naming the rank where it is missing or different), and the interactive rate every
// rank draws a reduced frame with.
#pragma once

#include <mpi.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "brickstore/read/BrickStore.h"
#include "distributed/Deadline.h"
#include "render/core/Dataset.h"

namespace voxbrick::distributed {

/// MPI for the life of the object: MPI_Init_thread (SERIALIZED) on construction, MPI_Finalize on destruction (or
/// nothing if MPI was already started). MPI_COMM_WORLD returns errors instead of aborting the job.
class MpiSession {
 public:
  MpiSession();
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  int rank() const { return mRank; }
  int size() const { return mSize; }
  /// Leaves without MPI_Finalize (after a peer failed, finalizing could wait for it forever).
  void abandon() { mFinalize = false; }

 private:
  int mRank = 0, mSize = 1;
  bool mFinalize = false;
};

/// Sends `text` from rank 0 to every rank (its length, then its bytes, point to point so that a rank that does not
/// take it is named). Rank 0 passes the text; the others receive it. A rank other than 0 waits up to
/// `timeoutSeconds` (< 0: for ever, polling `stop` if given, which returns true to give up: then the result is
/// empty). Throws PeerError naming the rank when the deadline passes.
std::string broadcastText(MPI_Comm comm, const std::string& text, double timeoutSeconds,
                          const std::function<bool()>& stop = {});

/// The interactive rate (samples per ms) a reduced frame is chosen by: `rate` when one is known (> 0), else a rate so
/// low that the cheapest drawing is chosen, as one process does before it has measured one.
double rateOrCheapest(double rate);

/// Collective: rank 0's interactive `rate` (rateOrCheapest) on every rank, so that every rank draws the same reduced
/// frame; sent with broadcastText and its deadline (PeerError names a rank that does not take it).
double agreedRate(MPI_Comm comm, double rate, double timeoutSeconds);

/// Every rank's `record` (up to 1023 bytes, cut beyond) on every rank, index = rank: each sends it to rank 0, which
/// sends them all back, every transfer with the deadline (PeerError names the rank).
std::vector<std::string> allGather(MPI_Comm comm, const std::string& record, double timeoutSeconds);

/// What identifies a dataset's files on disk: the CRC-32 of its small description file (store.json, mesh.json) and
/// every file's size (render::datasetFiles). Throws std::runtime_error when a file is missing.
std::string datasetIdentity(const std::filesystem::path& path);

/// Collective: every rank's `record` for dataset `name` ("ok IDENTITY" or "error MESSAGE") compared. Throws
/// render::RenderInputError on every rank naming the first rank that failed ("dataset 'NAME' cannot be opened on
/// rank R: ...") or whose identity differs from rank 0's ("... differs on rank R ..."); PeerError as allGather.
void agreeOnDataset(MPI_Comm comm, const std::string& name, const std::string& record, double timeoutSeconds);

/// Opens a dataset on every rank (collective): each rank calls `open`, then the ranks compare what they opened by
/// datasetIdentity. Throws render::RenderInputError on every rank when the dataset failed to open on some rank
/// ("dataset 'NAME' cannot be opened on rank R: ...") or differs from rank 0's ("... differs on rank R ...").
std::shared_ptr<const render::Dataset> openOnEveryRank(
    MPI_Comm comm, const std::string& name, const std::filesystem::path& path,
    const std::function<std::shared_ptr<const render::Dataset>()>& open, double timeoutSeconds);

}  // namespace voxbrick::distributed
