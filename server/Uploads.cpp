// Uploads: checks, the scratch folder, `voxbrick prep` in a child process and the move into place.
#include "server/Uploads.h"

#include <fcntl.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>  // renameat2
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "server/Datasets.h"
#include "server/ErrorReply.h"

namespace voxbrick::server {
namespace {

using proto::ErrorCode;
using proto::ProtocolError;

constexpr const char* kScratchPrefix = ".upload-";
/// The longest side an upload may have (a guard against products that overflow; prep has its own limits).
constexpr uint64_t kMaxSide = uint64_t(1) << 20;

/// The voxel types an upload may name (NRRD's names, as `voxbrick prep` reads them) and their sizes.
struct VoxelType {
  const char* name;
  uint64_t bytes;
};
constexpr VoxelType kTypes[] = {{"uint8", 1}, {"int8", 1},  {"uint16", 2}, {"int16", 2},
                                {"uint32", 4}, {"int32", 4}, {"float", 4},  {"double", 8}};

[[noreturn]] void malformed(const std::string& what) { throw ProtocolError(ErrorCode::Malformed, "Upload." + what); }

std::vector<double> vector3(const nlohmann::json& meta, const char* key, bool positive) {
  const nlohmann::json& v = meta[key];
  if (!v.is_array() || v.size() != 3)
    malformed(std::string("meta_json: '") + key + "' must be an array of three numbers (x, y, z)");
  std::vector<double> out;
  for (const nlohmann::json& item : v) {
    if (!item.is_number() || !std::isfinite(item.get<double>()) || (positive && item.get<double>() <= 0))
      malformed(std::string("meta_json: '") + key + "' must hold three finite" + (positive ? " positive" : "") +
                " numbers, not " + v.dump());
    out.push_back(item.get<double>());
  }
  return out;
}

/// Every write of `data` to `fd`, or the errno of the failure.
int writeAll(int fd, const uint8_t* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    data += n;
    size -= size_t(n);
  }
  return 0;
}

}  // namespace

std::string Uploads::nrrdHeader(const proto::Upload& request, const std::filesystem::path& voxels) {
  const nlohmann::json meta = nlohmann::json::parse(request.metaJson, nullptr, false);
  if (meta.is_discarded() || !meta.is_object()) malformed("meta_json: not a JSON object");
  for (const auto& [key, value] : meta.items())
    if (key != "dims" && key != "type" && key != "endian" && key != "spacing" && key != "origin" && key != "patient")
      malformed("meta_json: unknown key '" + key + "' (dims, type, endian, spacing, origin, patient)");
  if (!meta.contains("dims")) malformed("meta_json: 'dims' is missing: [x, y, z] voxels");
  const nlohmann::json& dims = meta["dims"];
  if (!dims.is_array() || dims.size() != 3)
    malformed("meta_json: 'dims' must be an array of three positive integers (x, y, z)");
  uint64_t voxelCount = 1;
  std::vector<uint64_t> sizes;
  for (const nlohmann::json& d : dims) {
    if (!d.is_number_integer() || d.get<int64_t>() < 1 || uint64_t(d.get<int64_t>()) > kMaxSide)
      malformed("meta_json: 'dims' " + dims.dump() + ": each must be an integer from 1 to " +
                std::to_string(kMaxSide));
    sizes.push_back(uint64_t(d.get<int64_t>()));
    voxelCount *= sizes.back();
  }
  if (!meta.contains("type") || !meta["type"].is_string())
    malformed("meta_json: 'type' is missing: uint8, int8, uint16, int16, uint32, int32, float or double");
  const std::string type = meta["type"];
  const VoxelType* voxelType = nullptr;
  for (const VoxelType& t : kTypes)
    if (type == t.name) voxelType = &t;
  if (!voxelType)
    malformed("meta_json: 'type' \"" + type + "\" is not uint8, int8, uint16, int16, uint32, int32, float or double");
  // At most 2^60 voxels of 8 bytes: no overflow.
  if (voxelCount * voxelType->bytes != request.bytes)
    malformed("bytes: " + std::to_string(request.bytes) + " where dims " + dims.dump() + " of " + type + " take " +
              std::to_string(voxelCount * voxelType->bytes));
  std::string endian = "little";
  if (meta.contains("endian")) {
    if (!meta["endian"].is_string() || (meta["endian"] != "little" && meta["endian"] != "big"))
      malformed("meta_json: 'endian' must be \"little\" or \"big\"");
    endian = meta["endian"];
  }
  const std::vector<double> spacing = meta.contains("spacing") ? vector3(meta, "spacing", true)
                                                                : std::vector<double>{1, 1, 1};
  bool patient = false;
  if (meta.contains("patient")) {
    if (!meta["patient"].is_boolean()) malformed("meta_json: 'patient' must be true or false");
    patient = meta["patient"];
  }
  std::ostringstream out;
  out << "NRRD0004\n# an upload\ntype: " << type << "\ndimension: 3\nsizes: " << sizes[0] << " " << sizes[1] << " "
      << sizes[2] << "\nencoding: raw\nendian: " << endian << "\ndata file: " << voxels.string() << "\n";
  // Numbers in their shortest exact form, as Python's repr writes them, so an array prepped here and by
  // voxbrick.prep gets the same store.
  if (meta.contains("origin") || patient) {
    const std::vector<double> origin =
        meta.contains("origin") ? vector3(meta, "origin", false) : std::vector<double>{0, 0, 0};
    out << "space: " << (patient ? "RAS" : "3D-right-handed") << "\n"
        << fmt::format("space directions: ({},0,0) (0,{},0) (0,0,{})\n", spacing[0], spacing[1], spacing[2])
        << fmt::format("space origin: ({},{},{})\n", origin[0], origin[1], origin[2]);
  } else {
    out << fmt::format("spacings: {} {} {}\n", spacing[0], spacing[1], spacing[2]);
  }
  return out.str();
}

Uploads::Uploads(const UploadConfig& config, std::filesystem::path datasets, std::filesystem::path voxbrick,
                 uint32_t chunkBytes)
    : mConfig(config), mDatasets(std::move(datasets)), mVoxbrick(std::move(voxbrick)), mChunkBytes(chunkBytes) {
  // A server that stopped in the middle of an upload left its scratch: nothing in it is a dataset.
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(mDatasets, ec))
    if (entry.path().filename().string().starts_with(kScratchPrefix)) {
      spdlog::info("removing {}, left by an upload that did not finish", entry.path().string());
      std::filesystem::remove_all(entry.path(), ec);
    }
}

std::shared_ptr<Upload> Uploads::begin(const proto::Upload& request, const TokenGrant* grant) {
  if (!enabled())
    throw ProtocolError(ErrorCode::Forbidden, "this server takes no uploads (its [upload] max_bytes is 0)");
  if (!grant || grant->anonymous())
    throw ProtocolError(ErrorCode::Forbidden, "uploads need an access token that may upload: this session presented "
                                              "none");
  if (!grant->upload)
    throw ProtocolError(ErrorCode::Forbidden, "token '" + grant->id + "' may not upload (its [[tokens]] entry has no "
                                              "upload = true)");
  if (!DatasetRegistry::validName(request.name))
    malformed("name: '" + request.name + "' is not a dataset name: letters, digits, '.', '-' and '_', not starting "
              "with '.', at most 255 bytes");
  if (!grant->mayOpen(request.name))
    throw ProtocolError(ErrorCode::Forbidden,
                        "token '" + grant->id + "' may not open a dataset named '" + request.name + "'");
  if (request.bytes > mConfig.maxBytes)
    throw LimitExceededError("an upload of " + std::to_string(request.bytes) + " bytes is above this server's quota "
                             "of " + std::to_string(mConfig.maxBytes) + " bytes ([upload] max_bytes)");
  const std::filesystem::path voxels = "voxels.raw";  // relative here; the header names the absolute path below
  (void)nrrdHeader(request, voxels);                  // checks meta_json and bytes
  std::error_code ec;
  if (std::filesystem::symlink_status(mDatasets / request.name, ec).type() != std::filesystem::file_type::not_found)
    throw ProtocolError(ErrorCode::AlreadyExists, "a dataset named '" + request.name + "' exists");
  std::unique_lock lock(mMutex);
  if (mNames.count(request.name))
    throw ProtocolError(ErrorCode::AlreadyExists, "a dataset named '" + request.name + "' is being uploaded");
  if (int(mActive.size()) >= mConfig.maxConcurrent)
    throw ProtocolError(ErrorCode::Busy,
                        proto::busyMessage(std::to_string(mActive.size()) + " upload(s) in progress, as many as this "
                                           "server takes at once ([upload] max_concurrent)",
                                           5000));
  // Room for the voxels and about as much again for their store (compressed, with borders and a pyramid).
  struct statvfs fs {};
  if (::statvfs(mDatasets.c_str(), &fs) == 0) {
    const uint64_t room = uint64_t(fs.f_bavail) * fs.f_frsize, need = 2 * request.bytes + (64u << 20);
    if (room < need)
      throw LimitExceededError("the server's disk has " + std::to_string(room >> 20) + " MiB free; an upload of " +
                               std::to_string(request.bytes) + " bytes needs about " + std::to_string(need >> 20));
  }
  // Not named after the upload: a name of 255 bytes leaves no room in a file name for more.
  std::string pattern = (mDatasets / (std::string(kScratchPrefix) + "XXXXXX")).string();
  if (!::mkdtemp(pattern.data()))
    throw std::runtime_error("cannot make a scratch folder in the datasets folder: " + std::string(std::strerror(errno)));
  std::shared_ptr<Upload> upload(new Upload(*this, request.name, pattern, request.bytes));
  mNames.insert(request.name);
  mActive.insert(upload.get());
  lock.unlock();
  const std::filesystem::path absolute = std::filesystem::absolute(upload->mScratch / voxels);
  {
    std::ofstream header(upload->mScratch / "voxels.nhdr");
    header << nrrdHeader(request, absolute);
    if (!header.flush()) throw std::runtime_error("cannot write the upload's header in its scratch folder");
  }
  upload->mFd = ::open(absolute.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (upload->mFd < 0)
    throw std::runtime_error("cannot create the upload's voxel file: " + std::string(std::strerror(errno)));
  spdlog::info("upload '{}' of {} bytes started", request.name, request.bytes);
  return upload;
}

int Uploads::active() const {
  std::lock_guard lock(mMutex);
  return int(mActive.size());
}

void Uploads::cancelAll() {
  std::lock_guard lock(mMutex);
  for (Upload* upload : mActive) upload->cancel();
}

void Uploads::ended(Upload& upload) {
  std::lock_guard lock(mMutex);
  mNames.erase(upload.name());
  mActive.erase(&upload);
}

Upload::Upload(Uploads& owner, std::string name, std::filesystem::path scratch, uint64_t expected)
    : mOwner(owner), mName(std::move(name)), mScratch(std::move(scratch)), mExpected(expected) {}

Upload::~Upload() { release(); }

void Upload::release() {
  if (mReleased) return;
  mReleased = true;
  if (mFd >= 0) ::close(mFd);
  mFd = -1;
  // The name first: once its scratch is gone, a client may take the name again at once (an abandoned upload's
  // client, seeing the folder clean, was refused "is being uploaded" in the moment between). Scratch folders are
  // each their own (mkdtemp), so a new upload of the name never meets this one's.
  mOwner.ended(*this);
  std::error_code ec;
  std::filesystem::remove_all(mScratch, ec);
  if (ec) spdlog::warn("upload '{}': cannot remove {}: {}", mName, mScratch.string(), ec.message());
}

bool Upload::append(std::span<const uint8_t> data) {
  const auto refuse = [](const std::string& why) { throw ProtocolError(ErrorCode::Malformed, "UploadChunk.data: " + why); };
  if (data.empty()) refuse("empty; the upload is abandoned");
  if (data.size() > mOwner.chunkBytes())
    refuse(std::to_string(data.size()) + " bytes, above the chunk size of " + std::to_string(mOwner.chunkBytes()) +
           " (UploadReady); the upload is abandoned");
  if (data.size() > mExpected - mReceived)
    refuse(std::to_string(data.size()) + " bytes past the upload's end: " + std::to_string(mExpected - mReceived) +
           " of its " + std::to_string(mExpected) + " bytes were left; the upload is abandoned");
  if (const int error = writeAll(mFd, data.data(), data.size()); error != 0) {
    if (error == ENOSPC || error == EDQUOT)
      throw LimitExceededError("upload '" + mName + "': the server's disk is full");
    throw std::runtime_error("upload '" + mName + "': writing its voxels failed: " + std::strerror(error));
  }
  mReceived += data.size();
  if (!complete()) return false;
  ::close(mFd);
  mFd = -1;
  return true;
}

void Upload::cancel() { mPrep.cancel(); }

void Upload::prepare() {
  const std::filesystem::path store = mScratch / "store";
  mPrep.run(mOwner.mVoxbrick, {"prep", (mScratch / "voxels.nhdr").string(), "-o", store.string(), "-q"},
            mScratch / "prep.log", "upload '" + mName + "'");
  // One step, never over a dataset: RENAME_NOREPLACE fails with EEXIST if the name was taken meanwhile.
  const std::filesystem::path target = mOwner.mDatasets / mName;
  if (::renameat2(AT_FDCWD, store.c_str(), AT_FDCWD, target.c_str(), RENAME_NOREPLACE) != 0) {
    if (errno == EEXIST)
      throw ProtocolError(ErrorCode::AlreadyExists, "a dataset named '" + mName + "' appeared during the upload");
    throw std::runtime_error("upload '" + mName + "': cannot move its store into the datasets folder: " +
                             std::strerror(errno));
  }
  spdlog::info("upload '{}' of {} bytes prepped into {}", mName, mExpected, target.string());
}

}  // namespace voxbrick::server
