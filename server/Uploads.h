// Volumes sent by clients to become datasets (PROTOCOL.md, Upload; docs/server.md, "Uploads"): who may send one, the
// size quota and how many at once ([upload]), the voxels written to a scratch folder inside the datasets folder as
// they arrive, then `voxbrick prep` run on them in a child process and the store moved into place in one step, never
// over an existing dataset. Nothing of an upload that fails or is abandoned is left behind. No sockets here.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <set>
#include <span>
#include <string>

#include "proto/Messages.h"
#include "server/AccessTokens.h"
#include "server/PrepProcess.h"
#include "server/ServerConfig.h"

namespace voxbrick::server {

class Uploads;

/// One upload in progress: its scratch folder (removed when the last reference goes) and its place among the
/// server's uploads. Its calls are made on its session's serial context, but prepare() (on a thread aside) and
/// cancel() (from anywhere).
class Upload {
 public:
  ~Upload();
  Upload(const Upload&) = delete;
  Upload& operator=(const Upload&) = delete;

  const std::string& name() const { return mName; }
  uint64_t expected() const { return mExpected; }
  uint64_t received() const { return mReceived; }
  /// Whether every byte arrived (then prepare() may run, and no chunk is taken).
  bool complete() const { return mReceived == mExpected; }

  /// Writes the next chunk of voxels; true when it was the last. Throws proto::ProtocolError Malformed for an empty
  /// chunk, one above the chunk size or one past the announced size, LimitExceededError when the disk is full,
  /// std::runtime_error for another write failure: the upload is then over (its owner drops it).
  bool append(std::span<const uint8_t> data);
  /// Preps the voxels into a brick store (`voxbrick prep`, a child process) and moves it into the datasets folder
  /// under the upload's name. Blocks until done. Throws proto::ProtocolError AlreadyExists when the name was taken
  /// meanwhile, std::runtime_error with prep's last words when it failed, or when cancel() stopped it.
  void prepare();
  /// Stops a prep in progress (its child is killed) and any prep to come. Safe from any thread.
  void cancel();
  /// Deletes the scratch folder and frees the upload's place among the server's uploads (its name, its share of
  /// max_concurrent), once its answer is known: before it is sent, so a client that goes on at once finds them free.
  /// Idempotent; the destructor does it too. Not while prepare() runs.
  void release();

 private:
  friend class Uploads;
  Upload(Uploads& owner, std::string name, std::filesystem::path scratch, uint64_t expected);

  Uploads& mOwner;
  const std::string mName;
  const std::filesystem::path mScratch;  ///< DATASETS/.upload-XXXXXX
  const uint64_t mExpected;
  uint64_t mReceived = 0;
  int mFd = -1;  ///< the voxels' file while chunks arrive
  PrepProcess mPrep;
  bool mReleased = false;
};

/// The server's uploads. Thread-safe.
class Uploads {
 public:
  /// Uploads into `datasets` as `config` allows, prepped by running `voxbrick` (the server's own executable) as
  /// `voxbrick prep`; a chunk carries at most `chunkBytes`. Removes the scratch folders a stopped server left.
  Uploads(const UploadConfig& config, std::filesystem::path datasets, std::filesystem::path voxbrick,
          uint32_t chunkBytes);

  /// Whether the server takes uploads at all (upload.max_bytes above 0).
  bool enabled() const { return mConfig.maxBytes > 0; }
  uint32_t chunkBytes() const { return mChunkBytes; }

  /// Starts the upload `request` for a session holding `grant` (null or anonymous: no token presented). Throws
  /// proto::ProtocolError: Forbidden (uploads off, no token, a token that may not upload or may not open the name),
  /// Malformed (the name, meta_json or bytes; naming what), AlreadyExists (a dataset or an upload of that name),
  /// LimitExceeded (above max_bytes, or the disk lacks room), Busy (max_concurrent uploads in progress).
  std::shared_ptr<Upload> begin(const proto::Upload& request, const TokenGrant* grant);
  /// Uploads in progress now.
  int active() const;
  /// Stops every prep in progress (the server is stopping).
  void cancelAll();

  /// The NRRD header `voxbrick prep` reads the voxels of `request` with (its `data file` is `voxels`), after
  /// checking its meta_json and bytes (proto::ProtocolError Malformed naming the key).
  static std::string nrrdHeader(const proto::Upload& request, const std::filesystem::path& voxels);

 private:
  friend class Upload;
  void ended(Upload& upload);

  const UploadConfig mConfig;
  const std::filesystem::path mDatasets, mVoxbrick;
  const uint32_t mChunkBytes;
  mutable std::mutex mMutex;
  std::set<std::string> mNames;  ///< of the uploads in progress
  std::set<Upload*> mActive;
};

}  // namespace voxbrick::server
