// MPI session, broadcasts, gathers and the dataset check across ranks (Cluster.h).
#include "distributed/Cluster.h"

#include <cstring>
#include <exception>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "common/Checksum.h"
#include "render/core/RenderErrors.h"
#include "render/datasets/Datasets.h"

namespace voxbrick::distributed {

MpiSession::MpiSession() {
  int started = 0;
  MPI_Initialized(&started);
  if (!started) {
    int provided = 0;
    if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS) {
      throw std::runtime_error("MPI could not be started");
    }
    if (provided < MPI_THREAD_SERIALIZED) {
      throw std::runtime_error("this MPI library does not allow MPI calls from a thread other than the main one");
    }
    mFinalize = true;
  }
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  MPI_Comm_rank(MPI_COMM_WORLD, &mRank);
  MPI_Comm_size(MPI_COMM_WORLD, &mSize);
}

MpiSession::~MpiSession() {
  // Leaving on an error: another rank may never reach MPI_Finalize, so this one does not wait for it there.
  if (mFinalize && std::uncaught_exceptions() == 0) MPI_Finalize();
}

namespace {

// Polls a started collective; without a deadline (timeout < 0) until `stop` says to give up.
bool waitCollective(MPI_Request& request, double timeoutSeconds, const std::function<bool()>& stop,
                    const char* what) {
  if (timeoutSeconds >= 0) {
    if (!testUntil(request, timeoutSeconds, 0, what)) {
      throw PeerError(-1, std::string(what) + ": some rank did not answer within " +
                              std::to_string(int(timeoutSeconds * 1000)) + " ms");
    }
    return true;
  }
  while (!testUntil(request, 0.1, 0, what)) {
    if (stop && stop()) return false;
  }
  return true;
}

}  // namespace

std::string broadcastText(MPI_Comm comm, const std::string& text, double timeoutSeconds,
                          const std::function<bool()>& stop) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  // On the heap: when the wait is given up, the request is abandoned and MPI may still write into it (leaked then).
  auto* lengthSlot = new uint64_t(rank == 0 ? text.size() : 0);
  MPI_Request request;
  MPI_Ibcast(lengthSlot, 1, MPI_UINT64_T, 0, comm, &request);
  if (!waitCollective(request, rank == 0 ? std::max(timeoutSeconds, 0.0) : timeoutSeconds, stop, "a command")) {
    return {};
  }
  const uint64_t length = *lengthSlot;
  delete lengthSlot;
  std::string out = rank == 0 ? text : std::string(length, '\0');
  MPI_Ibcast(out.data(), int(length), MPI_CHAR, 0, comm, &request);
  waitCollective(request, std::max(timeoutSeconds, 10.0), {}, "a command's text");
  return out;
}

std::vector<std::string> allGather(MPI_Comm comm, const std::string& record, double timeoutSeconds) {
  constexpr size_t kRecord = 1024;
  int size = 1;
  MPI_Comm_size(comm, &size);
  auto mine = std::make_shared<std::vector<char>>(kRecord, '\0');
  std::memcpy(mine->data(), record.data(), std::min(record.size(), kRecord - 1));
  auto all = std::make_shared<std::vector<char>>(kRecord * size_t(size), '\0');
  MPI_Request request;
  MPI_Iallgather(mine->data(), int(kRecord), MPI_CHAR, all->data(), int(kRecord), MPI_CHAR, comm, &request);
  waitCollective(request, timeoutSeconds, {}, "gathering every rank's answer");
  std::vector<std::string> out;
  for (int r = 0; r < size; ++r) out.emplace_back(all->data() + size_t(r) * kRecord);
  return out;
}

std::string datasetIdentity(const std::filesystem::path& path) {
  std::ostringstream identity;
  for (const auto& file : render::datasetFiles(path)) {
    std::error_code error;
    auto bytes = std::filesystem::file_size(file, error);
    if (error) throw std::runtime_error("'" + file.string() + "' is missing");
    identity << file.filename().string() << ":" << bytes;
    if (file.extension() == ".json") {
      std::ifstream in(file, std::ios::binary);
      std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      identity << ":crc " << std::hex << common::crc32Of(text.data(), text.size()) << std::dec;
    }
    identity << " ";
  }
  return identity.str();
}

std::shared_ptr<const render::Dataset> openOnEveryRank(
    MPI_Comm comm, const std::string& name, const std::filesystem::path& path,
    const std::function<std::shared_ptr<const render::Dataset>()>& open, double timeoutSeconds) {
  std::shared_ptr<const render::Dataset> dataset;
  std::string record;
  try {
    dataset = open();
    record = "ok " + datasetIdentity(path);
  } catch (const std::exception& error) {
    record = std::string("error ") + error.what();
  }
  auto records = allGather(comm, record, timeoutSeconds);
  for (size_t r = 0; r < records.size(); ++r) {
    if (records[r].rfind("error ", 0) == 0) {
      throw render::RenderInputError("dataset '" + name + "' cannot be opened on rank " + std::to_string(r) + ": " +
                                     records[r].substr(6));
    }
  }
  for (size_t r = 1; r < records.size(); ++r) {
    if (records[r] != records[0]) {
      throw render::RenderInputError("dataset '" + name + "' differs on rank " + std::to_string(r) + " from rank 0 (" +
                                     records[r].substr(3) + "against " + records[0].substr(3) + ")");
    }
  }
  return dataset;
}

}  // namespace voxbrick::distributed
