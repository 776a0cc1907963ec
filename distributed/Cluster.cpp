// MPI session, broadcasts, gathers and the dataset check across ranks (Cluster.h).
#include "distributed/Cluster.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <exception>
#include <fstream>
#include <optional>
#include <sstream>
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

RankGroup RankGroup::all(MPI_Comm comm) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  RankGroup group;
  group.comm = comm;
  for (int r = 0; r < size; ++r) group.members.push_back(r);
  return group;
}

int RankGroup::indexOf(int rank) const {
  const auto it = std::find(members.begin(), members.end(), rank);
  return it == members.end() ? -1 : int(it - members.begin());
}

std::pair<int, int> RankGroup::epochAndKind(int tag) {
  if (tag < kFirstTag) return {-1, 0};
  return {(tag - kFirstTag) / kTagsPerEpoch, (tag - kFirstTag) % kTagsPerEpoch};
}

int RankGroup::lastEpoch(MPI_Comm comm) {
  int* bound = nullptr;
  int found = 0;
  MPI_Comm_get_attr(comm, MPI_TAG_UB, &bound, &found);
  const int64_t upper = found && bound ? *bound : 32767;
  return int((upper - kFirstTag) / kTagsPerEpoch - 1);
}

namespace {

constexpr size_t kRecord = 1024;

int rankOf(MPI_Comm comm) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  return rank;
}

}  // namespace

void sendCommand(const RankGroup& group, const std::string& text, double timeoutSeconds) {
  auto bytes = std::make_shared<std::string>(text);
  Transfers transfers(group.comm, timeoutSeconds);
  for (int r : group.members)
    if (r != 0) transfers.send(r, group.tag(kCommandTag), bytes->data(), bytes->size(), bytes, "a command");
  transfers.wait();
}

std::optional<Command> receiveCommand(MPI_Comm comm, int epoch, double timeoutSeconds,
                                      const std::function<bool()>& stop) {
  using Clock = std::chrono::steady_clock;
  // Commands taken from rank 0 and not yet handed out, in order: every command waiting is taken before one is handed
  // out, so that a rank that was stopped and goes on again skips the commands of an epoch rank 0 has since left.
  thread_local std::deque<Command> ahead;
  const auto deadline = Clock::now() + std::chrono::duration<double>(std::max(timeoutSeconds, 0.0));
  int idle = 0;
  uint32_t polls = 0;
  while (true) {
    // What waits first from rank 0: a command (taken, and the next one looked at), a message of an earlier epoch
    // (dropped), or another message of this epoch. That one belongs to a frame whose command came before it (rank 0
    // may be ahead: its pieces of the frame follow the command) and is left for it, unless no command was taken: then
    // it is left over from a frame given up, and dropped.
    int found = 0;
    MPI_Status peeked;
    int code = MPI_Iprobe(0, MPI_ANY_TAG, comm, &found, &peeked);
    if (code != MPI_SUCCESS) throw PeerError(0, "receiving a command from rank 0 failed: " + mpiErrorText(code));
    const auto [sentIn, kind] = RankGroup::epochAndKind(found ? peeked.MPI_TAG : 0);
    if (found && (kind == kCommandTag || sentIn < epoch || ahead.empty())) {
      MPI_Message message = MPI_MESSAGE_NULL;
      MPI_Status status;
      code = MPI_Improbe(0, peeked.MPI_TAG, comm, &found, &message, &status);
      if (code != MPI_SUCCESS) throw PeerError(0, "receiving a command from rank 0 failed: " + mpiErrorText(code));
      int count = 0;
      MPI_Get_count(&status, MPI_BYTE, &count);
      std::string text(size_t(std::max(count, 0)), '\0');
      MPI_Mrecv(text.data(), count, MPI_BYTE, &message, MPI_STATUS_IGNORE);
      if (kind == kCommandTag) ahead.push_back(Command{std::move(text), sentIn});
      idle = 0;
      continue;
    }
    // Nothing more waiting: the commands of the newest epoch taken (rank 0 left the earlier ones), in order.
    const int newest = ahead.empty() ? epoch : std::max(epoch, ahead.back().epoch);
    std::erase_if(ahead, [newest](const Command& c) { return c.epoch < newest; });
    if (!ahead.empty()) {
      Command command = std::move(ahead.front());
      ahead.pop_front();
      return command;
    }
    if (timeoutSeconds >= 0 && Clock::now() > deadline) {
      throw PeerError(0, "rank 0 did not send a command within " + std::to_string(int(timeoutSeconds * 1000)) + " ms");
    }
    if (timeoutSeconds < 0 && stop && ++polls % 256 == 0 && stop()) return std::nullopt;
    pauseBetweenPolls(idle);
  }
}

std::string broadcastText(const RankGroup& group, const std::string& text, double timeoutSeconds) {
  if (rankOf(group.comm) == 0) {
    sendCommand(group, text, std::max(timeoutSeconds, 0.0));
    return text;
  }
  return receiveCommand(group.comm, group.epoch, std::max(timeoutSeconds, 0.0))->text;
}

double rateOrCheapest(double rate) { return rate > 0 ? rate : 1e-9; }

double agreedRate(const RankGroup& group, double rate, double timeoutSeconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", rateOrCheapest(rate));  // 17 digits: the same double on every rank
  return rateOrCheapest(std::strtod(broadcastText(group, text, timeoutSeconds).c_str(), nullptr));
}

std::vector<std::string> gatherRecords(const RankGroup& group, const std::string& record, double timeoutSeconds) {
  if (rankOf(group.comm) != 0) {
    auto mine = std::make_shared<std::vector<char>>(kRecord, '\0');
    std::memcpy(mine->data(), record.data(), std::min(record.size(), kRecord - 1));
    Transfers transfers(group.comm, timeoutSeconds);
    transfers.send(0, group.tag(kRecordTag), mine->data(), kRecord, mine, "an answer");
    transfers.wait();
    return {};
  }
  std::vector<std::string> out(group.members.size());
  out[0] = record.substr(0, kRecord - 1);
  std::vector<std::shared_ptr<std::vector<char>>> records(group.members.size());
  Transfers transfers(group.comm, timeoutSeconds);
  for (size_t i = 1; i < group.members.size(); ++i) {
    records[i] = std::make_shared<std::vector<char>>(kRecord, '\0');
    transfers.receive(group.members[i], group.tag(kRecordTag), records[i]->data(), kRecord, records[i], "an answer");
  }
  transfers.wait();
  for (size_t i = 1; i < group.members.size(); ++i) out[i] = std::string(records[i]->data());
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

void agreeOnDataset(const RankGroup& group, const std::string& name, const std::string& record, double timeoutSeconds) {
  const auto records = gatherRecords(group, record, timeoutSeconds);
  std::string verdict;  // rank 0's: empty when every member opened the same files
  if (rankOf(group.comm) == 0) {
    for (size_t i = 0; i < records.size() && verdict.empty(); ++i) {
      if (records[i].rfind("error ", 0) == 0) {
        verdict = "dataset '" + name + "' cannot be opened on rank " + std::to_string(group.members[i]) + ": " +
                  records[i].substr(6);
      }
    }
    for (size_t i = 1; i < records.size() && verdict.empty(); ++i) {
      if (records[i] != records[0]) {
        verdict = "dataset '" + name + "' differs on rank " + std::to_string(group.members[i]) + " from rank 0 (" +
                  records[i].substr(3) + "against " + records[0].substr(3) + ")";
      }
    }
  }
  // The verdict travels as a message of its own kind, prefixed so that an empty one is a message too.
  Transfers transfers(group.comm, timeoutSeconds);
  auto text = std::make_shared<std::vector<char>>(kRecord * 2, '\0');
  if (rankOf(group.comm) == 0) {
    const std::string sent = "v" + verdict;
    std::memcpy(text->data(), sent.data(), std::min(sent.size(), text->size() - 1));
    for (size_t i = 1; i < group.members.size(); ++i)
      transfers.send(group.members[i], group.tag(kVerdictTag), text->data(), text->size(), text, "a verdict");
  } else {
    transfers.receive(0, group.tag(kVerdictTag), text->data(), text->size(), text, "a verdict");
  }
  transfers.wait();
  if (rankOf(group.comm) != 0) verdict = std::string(text->data()).substr(1);
  if (!verdict.empty()) throw render::RenderInputError(verdict);
}

std::shared_ptr<const render::Dataset> openOnEveryRank(
    const RankGroup& group, const std::string& name, const std::filesystem::path& path,
    const std::function<std::shared_ptr<const render::Dataset>()>& open, double timeoutSeconds) {
  std::shared_ptr<const render::Dataset> dataset;
  std::string record;
  try {
    dataset = open();
    record = "ok " + datasetIdentity(path);
  } catch (const std::exception& error) {
    record = std::string("error ") + error.what();
  }
  agreeOnDataset(group, name, record, timeoutSeconds);
  return dataset;
}

}  // namespace voxbrick::distributed
