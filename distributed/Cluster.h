// The MPI world of `voxbrick render --mpi` and `serve --mpi`: MPI started for threads that take turns
// (MPI_THREAD_SERIALIZED) with errors returned rather than fatal; the group of ranks taking part in frames and its
// epoch (a server that lost a rank goes on with the others, in a new epoch whose messages cannot meet the old
// ones); and the steps the members take together with a deadline: sending a command from rank 0, gathering one
// record per rank on rank 0, agreeing that every rank opened the same dataset (refused naming the rank where it is
// missing or different), and the interactive rate every rank draws a reduced frame with.
#pragma once

#include <mpi.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
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

/// The ranks of a communicator that take part in frames, and the epoch of that membership. Every message of an
/// epoch carries tags of its own (tag()), so that nothing left in flight by a frame given up when a rank was lost (a
/// send never taken, a receive abandoned) is ever taken for a message of a later epoch. Member i draws part i.
struct RankGroup {
  static constexpr int kFirstTag = 1000;     ///< epoch 0's first tag
  static constexpr int kTagsPerEpoch = 256;  ///< each epoch's tags: TagKind below, then the compositor's
  MPI_Comm comm = MPI_COMM_WORLD;
  std::vector<int> members;  ///< ranks of comm, ascending, rank 0 first
  int epoch = 0;

  /// Every rank of `comm`, epoch 0.
  static RankGroup all(MPI_Comm comm);
  int size() const { return int(members.size()); }
  /// The index of `rank` among the members, -1 when it is not one.
  int indexOf(int rank) const;
  /// The tag of message kind `offset` (0 <= offset < kTagsPerEpoch) in this epoch.
  int tag(int offset) const { return kFirstTag + epoch * kTagsPerEpoch + offset; }
  /// The epoch and kind of a tag (epoch -1 for a tag below kFirstTag).
  static std::pair<int, int> epochAndKind(int tag);
  /// The last epoch whose tags the communicator allows (MPI_TAG_UB, at least 32767 by the standard).
  static int lastEpoch(MPI_Comm comm);
};

/// The kinds of message of an epoch (RankGroup::tag's offsets); the compositor takes kCompositeTags and above.
enum TagKind : int { kCommandTag = 0, kRecordTag = 1, kVerdictTag = 2, kAnswerTag = 3, kCompositeTags = 16 };

/// Rank 0 sends `text` to every other member (one message each, waited for with the deadline, so that a member that
/// does not take it is named by PeerError).
void sendCommand(const RankGroup& group, const std::string& text, double timeoutSeconds);

/// What a rank other than 0 took from rank 0: the text and the epoch it was sent in.
struct Command {
  std::string text;
  int epoch = 0;
};

/// A rank other than 0 takes the next command rank 0 sent in epoch `epoch` or a later one: every command waiting
/// from rank 0 is taken first, and only the newest epoch's are handed out, in order (a rank that was stopped skips
/// those of an epoch rank 0 has left). A message of an earlier epoch is dropped, and so is one of this epoch of
/// another kind that no command precedes (left by a frame given up); one that follows a command (rank 0 already
/// sending that frame's pieces) is left for the frame. Waits up
/// to `timeoutSeconds` (< 0: for ever, polling `stop` if given, which returns true to give up: then the result is
/// empty). Throws PeerError naming rank 0 when the deadline passes.
std::optional<Command> receiveCommand(MPI_Comm comm, int epoch, double timeoutSeconds,
                                      const std::function<bool()>& stop = {});

/// sendCommand on rank 0, receiveCommand in the group's epoch with the deadline on the other members: `text` (rank
/// 0's) on every member.
std::string broadcastText(const RankGroup& group, const std::string& text, double timeoutSeconds);

/// The interactive rate (samples per ms) a reduced frame is chosen by: `rate` when one is known (> 0), else a rate so
/// low that the cheapest drawing is chosen, as one process does before it has measured one.
double rateOrCheapest(double rate);

/// Collective: rank 0's interactive `rate` (rateOrCheapest) on every member, so that every rank draws the same
/// reduced frame; sent with broadcastText and its deadline (PeerError names a rank that does not take it).
double agreedRate(const RankGroup& group, double rate, double timeoutSeconds);

/// Every member's `record` (up to 1023 bytes, cut beyond) on rank 0, index = member index; the other members send
/// theirs and get an empty list. Every transfer with the deadline (PeerError names the rank).
std::vector<std::string> gatherRecords(const RankGroup& group, const std::string& record, double timeoutSeconds);

/// What identifies a dataset's files on disk: the CRC-32 of its small description file (store.json, mesh.json) and
/// every file's size (render::datasetFiles). Throws std::runtime_error when a file is missing.
std::string datasetIdentity(const std::filesystem::path& path);

/// Collective: every member's `record` for dataset `name` ("ok IDENTITY" or "error MESSAGE") compared on rank 0,
/// whose verdict every member takes. Throws render::RenderInputError on every member naming the first rank that
/// failed ("dataset 'NAME' cannot be opened on rank R: ...") or whose identity differs from rank 0's ("... differs
/// on rank R ..."); PeerError as gatherRecords.
void agreeOnDataset(const RankGroup& group, const std::string& name, const std::string& record, double timeoutSeconds);

/// Opens a dataset on every member (collective): each calls `open`, then they compare what they opened by
/// datasetIdentity. Throws render::RenderInputError on every member when the dataset failed to open on some rank
/// ("dataset 'NAME' cannot be opened on rank R: ...") or differs from rank 0's ("... differs on rank R ...").
std::shared_ptr<const render::Dataset> openOnEveryRank(
    const RankGroup& group, const std::string& name, const std::filesystem::path& path,
    const std::function<std::shared_ptr<const render::Dataset>()>& open, double timeoutSeconds);

}  // namespace voxbrick::distributed
