// MPI session, broadcasts, gathers and the dataset check across ranks (Cluster.h).
#include "distributed/Cluster.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>
#include <stdexcept>

#include "common/Checksum.h"
#include "render/core/RenderErrors.h"
#include "render/engine/Datasets.h"

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

constexpr int kTagLength = 7200, kTagText = 7201, kTagRecord = 7202;

// Rank 0 sends `text` to every other rank (its length, then its bytes), waiting for all with the deadline, so that a
// rank that does not take it is named.
void sendToAll(MPI_Comm comm, const std::string& text, double timeoutSeconds) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  auto length = std::make_shared<uint64_t>(text.size());
  auto bytes = std::make_shared<std::string>(text);
  Transfers transfers(comm, timeoutSeconds);
  for (int r = 1; r < size; ++r) {
    transfers.send(r, kTagLength, length.get(), sizeof(uint64_t), length, "a command");
    transfers.send(r, kTagText, bytes->data(), bytes->size(), bytes, "a command");
  }
  transfers.wait();
}

// A rank other than 0 takes what sendToAll sent: the length (for ever when timeout < 0, polling `stop`), then the text.
std::optional<std::string> receiveFromRoot(MPI_Comm comm, double timeoutSeconds, const std::function<bool()>& stop) {
  auto length = std::make_shared<uint64_t>(0);
  {
    Transfers transfers(comm, timeoutSeconds < 0 ? 0.2 : timeoutSeconds);
    transfers.receive(0, kTagLength, length.get(), sizeof(uint64_t), length, "a command");
    while (true) {
      try {
        transfers.wait();
        break;
      } catch (const PeerError&) {
        if (timeoutSeconds >= 0) throw;
        if (stop && stop()) return std::nullopt;  // the pending receive is abandoned with its buffer
      }
    }
  }
  auto text = std::make_shared<std::string>(*length, '\0');
  Transfers transfers(comm, std::max(timeoutSeconds, 10.0));
  transfers.receive(0, kTagText, text->data(), text->size(), text, "a command");
  transfers.wait();
  return *text;
}

}  // namespace

std::string broadcastText(MPI_Comm comm, const std::string& text, double timeoutSeconds,
                          const std::function<bool()>& stop) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  if (rank == 0) {
    sendToAll(comm, text, std::max(timeoutSeconds, 0.0));
    return text;
  }
  return receiveFromRoot(comm, timeoutSeconds, stop).value_or(std::string());
}

double rateOrCheapest(double rate) { return rate > 0 ? rate : 1e-9; }

double agreedRate(MPI_Comm comm, double rate, double timeoutSeconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", rateOrCheapest(rate));  // 17 digits: the same double on every rank
  return rateOrCheapest(std::strtod(broadcastText(comm, text, timeoutSeconds).c_str(), nullptr));
}

std::vector<std::string> allGather(MPI_Comm comm, const std::string& record, double timeoutSeconds) {
  int size = 1, rank = 0;
  MPI_Comm_size(comm, &size);
  MPI_Comm_rank(comm, &rank);
  constexpr size_t kRecord = 1024;
  std::vector<std::string> out(static_cast<size_t>(size));
  if (rank != 0) {
    auto mine = std::make_shared<std::vector<char>>(kRecord, '\0');
    std::memcpy(mine->data(), record.data(), std::min(record.size(), kRecord - 1));
    Transfers transfers(comm, timeoutSeconds);
    transfers.send(0, kTagRecord, mine->data(), kRecord, mine, "an answer");
    transfers.wait();
    nlohmann::json all = nlohmann::json::parse(receiveFromRoot(comm, timeoutSeconds, {}).value_or("[]"));
    for (size_t r = 0; r < out.size() && r < all.size(); ++r) out[r] = all[r].get<std::string>();
    return out;
  }
  out[0] = record.substr(0, kRecord - 1);
  std::vector<std::shared_ptr<std::vector<char>>> records;
  Transfers transfers(comm, timeoutSeconds);
  for (int r = 1; r < size; ++r) {
    records.push_back(std::make_shared<std::vector<char>>(kRecord, '\0'));
    transfers.receive(r, kTagRecord, records.back()->data(), kRecord, records.back(), "an answer");
  }
  transfers.wait();
  for (int r = 1; r < size; ++r) out[size_t(r)] = std::string(records[size_t(r - 1)]->data());
  sendToAll(comm, nlohmann::json(out).dump(), timeoutSeconds);
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

void agreeOnDataset(MPI_Comm comm, const std::string& name, const std::string& record, double timeoutSeconds) {
  const auto records = allGather(comm, record, timeoutSeconds);
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
  agreeOnDataset(comm, name, record, timeoutSeconds);
  return dataset;
}

}  // namespace voxbrick::distributed
