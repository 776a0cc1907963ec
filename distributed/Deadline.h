// Point-to-point MPI transfers with a deadline: requests are started non-blocking and polled with MPI_Test until they
// complete or the deadline passes, so that a dead or stalled peer becomes an error naming its rank within a bounded
// time instead of a hang. Errors are returned by MPI (MPI_ERRORS_RETURN on the communicator), never fatal.
#pragma once

#include <mpi.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace voxbrick::distributed {

/// A transfer with another rank that failed or passed its deadline; rank() is the peer's rank on the communicator.
class PeerError : public std::runtime_error {
 public:
  PeerError(int rank, const std::string& message) : std::runtime_error(message), mRank(rank) {}
  int rank() const { return mRank; }

 private:
  int mRank;
};

/// A set of started transfers waited for together against one deadline. Buffers passed in must stay alive until
/// wait() returns; after a failure the requests still pending are abandoned with their buffers (kept alive by the
/// shared_ptr each call takes), since MPI may still write into them.
class Transfers {
 public:
  explicit Transfers(MPI_Comm comm, double timeoutSeconds) : mComm(comm), mTimeout(timeoutSeconds) {}
  ~Transfers();
  Transfers(const Transfers&) = delete;
  Transfers& operator=(const Transfers&) = delete;

  /// Starts sending `bytes` bytes at `data` to `rank` (MPI_Isend); `keep` holds the buffer (may be null).
  void send(int rank, int tag, const void* data, size_t bytes, std::shared_ptr<const void> keep, const char* what);
  /// Starts receiving up to `bytes` bytes into `data` from `rank` (MPI_Irecv).
  void receive(int rank, int tag, void* data, size_t bytes, std::shared_ptr<void> keep, const char* what);
  /// Polls every transfer until all complete; throws PeerError naming the first peer that failed or that had not
  /// completed when the deadline (timeoutSeconds from this call) passed.
  void wait();
  /// Polls every transfer until each has completed or failed, or the deadline passed; returns, in the order they
  /// were started, which completed (the others are abandoned with their buffers). Never throws for a peer.
  std::vector<bool> waitEach();

 private:
  struct Pending {
    MPI_Request request = MPI_REQUEST_NULL;
    int rank = -1;
    bool sending = false;
    const char* what = "";
    std::shared_ptr<const void> keep;
  };
  MPI_Comm mComm;
  double mTimeout;
  std::vector<Pending> mPending;
};

/// Waits a little between two polls of a transfer: a few yields first (a reply usually comes within microseconds),
/// then short sleeps, so that an oversubscribed machine's other ranks get the core. `idle` counts the polls since the
/// last progress (the caller sets it to 0 on progress).
void pauseBetweenPolls(int& idle);

/// Gives up a started request that may still complete: it and the buffer `keep` holds are kept until the process
/// ends (MPI may still write into the buffer).
void abandonRequest(MPI_Request request, std::shared_ptr<const void> keep);

/// Describes an MPI error code (MPI_Error_string).
std::string mpiErrorText(int code);

}  // namespace voxbrick::distributed
