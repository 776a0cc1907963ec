// Transfers polled against a deadline (Deadline.h).
#include "distributed/Deadline.h"

#include <sched.h>

#include <chrono>
#include <mutex>
#include <thread>

namespace voxbrick::distributed {
namespace {

using Clock = std::chrono::steady_clock;

// Requests abandoned after a failure, with their buffers: MPI may still complete them into those buffers.
struct Abandoned {
  MPI_Request request;
  std::shared_ptr<const void> keep;
};
std::mutex gAbandonedMutex;
std::vector<Abandoned>& abandoned() {
  static auto* list = new std::vector<Abandoned>();  // never destroyed: MPI may touch the buffers until exit
  return *list;
}

}  // namespace

void pauseBetweenPolls(int& idle) {
  if (idle < 1024) ++idle;
  if (idle < 64) {
    sched_yield();
  } else {
    std::this_thread::sleep_for(std::chrono::microseconds(idle < 1024 ? 20 : 200));
  }
}

std::string mpiErrorText(int code) {
  char text[MPI_MAX_ERROR_STRING];
  int length = 0;
  if (MPI_Error_string(code, text, &length) != MPI_SUCCESS) return "MPI error " + std::to_string(code);
  return std::string(text, size_t(length));
}

void abandonRequest(MPI_Request request, std::shared_ptr<const void> keep) {
  if (request == MPI_REQUEST_NULL) return;
  std::lock_guard lock(gAbandonedMutex);
  abandoned().push_back({request, std::move(keep)});
}

Transfers::~Transfers() {
  std::lock_guard lock(gAbandonedMutex);
  for (auto& pending : mPending) {
    if (pending.request != MPI_REQUEST_NULL) abandoned().push_back({pending.request, std::move(pending.keep)});
  }
}

void Transfers::send(int rank, int tag, const void* data, size_t bytes, std::shared_ptr<const void> keep,
                     const char* what) {
  Pending pending{MPI_REQUEST_NULL, rank, true, what, std::move(keep)};
  int code = MPI_Isend(data, int(bytes), MPI_BYTE, rank, tag, mComm, &pending.request);
  if (code != MPI_SUCCESS) {
    throw PeerError(
        rank, "sending " + std::string(what) + " to rank " + std::to_string(rank) + " failed: " + mpiErrorText(code));
  }
  mPending.push_back(std::move(pending));
}

void Transfers::receive(int rank, int tag, void* data, size_t bytes, std::shared_ptr<void> keep, const char* what) {
  Pending pending{MPI_REQUEST_NULL, rank, false, what, std::move(keep)};
  int code = MPI_Irecv(data, int(bytes), MPI_BYTE, rank, tag, mComm, &pending.request);
  if (code != MPI_SUCCESS) {
    throw PeerError(rank, "receiving " + std::string(what) + " from rank " + std::to_string(rank) +
                              " failed: " + mpiErrorText(code));
  }
  mPending.push_back(std::move(pending));
}

void Transfers::wait() {
  auto deadline = Clock::now() + std::chrono::duration<double>(mTimeout);
  size_t left = 0;
  for (auto& pending : mPending) left += pending.request != MPI_REQUEST_NULL;
  int idle = 0;
  while (left > 0) {
    bool progressed = false;
    for (auto& pending : mPending) {
      if (pending.request == MPI_REQUEST_NULL) continue;
      int done = 0;
      MPI_Status status;
      int code = MPI_Test(&pending.request, &done, &status);
      if (code != MPI_SUCCESS) {
        throw PeerError(pending.rank, std::string(pending.sending ? "sending " : "receiving ") + pending.what +
                                          (pending.sending ? " to rank " : " from rank ") +
                                          std::to_string(pending.rank) + " failed: " + mpiErrorText(code));
      }
      if (done) {
        pending.request = MPI_REQUEST_NULL;
        pending.keep.reset();
        --left;
        progressed = true;
      }
    }
    if (left == 0) break;
    if (progressed) {
      idle = 0;
    } else if (Clock::now() > deadline) {
      for (auto& pending : mPending) {
        if (pending.request == MPI_REQUEST_NULL) continue;
        throw PeerError(pending.rank, "rank " + std::to_string(pending.rank) + " did not answer within " +
                                          std::to_string(int(mTimeout * 1000)) + " ms (" +
                                          (pending.sending ? "sending " : "receiving ") + pending.what + ")");
      }
    } else {
      pauseBetweenPolls(idle);
    }
  }
  mPending.clear();
}

std::vector<bool> Transfers::waitEach() {
  const auto deadline = Clock::now() + std::chrono::duration<double>(mTimeout);
  std::vector<bool> done(mPending.size(), false);
  int idle = 0;
  while (true) {
    bool progressed = false, waiting = false;
    for (size_t i = 0; i < mPending.size(); ++i) {
      Pending& pending = mPending[i];
      if (pending.request == MPI_REQUEST_NULL) continue;
      int complete = 0;
      if (MPI_Test(&pending.request, &complete, MPI_STATUS_IGNORE) != MPI_SUCCESS) {
        abandonRequest(pending.request, std::move(pending.keep));  // failed: given up, its buffer kept
        pending.request = MPI_REQUEST_NULL;
        continue;
      }
      if (complete) {
        pending.request = MPI_REQUEST_NULL;
        pending.keep.reset();
        done[i] = progressed = true;
      } else {
        waiting = true;
      }
    }
    if (!waiting || Clock::now() > deadline) break;
    if (progressed) {
      idle = 0;
    } else {
      pauseBetweenPolls(idle);
    }
  }
  return done;  // the destructor abandons what is still pending
}

}  // namespace voxbrick::distributed
