// Session, pending-connection and per-address counts, and which pending connection gives way.
#include "server/Admission.h"

namespace voxbrick::server {

Admission::Verdict Admission::admit(ConnectionId id, const std::string& address, bool limited) {
  Verdict verdict;
  if (mSessions >= mLimits.maxSessions) {
    verdict.result = Verdict::Result::TooManySessions;
    return verdict;
  }
  if (limited && mLimits.maxPerAddress > 0 && fromAddress(address) >= mLimits.maxPerAddress) {
    verdict.result = Verdict::Result::TooManyFromAddress;
    return verdict;
  }
  if (mPending >= mLimits.maxPending) {
    verdict.evicted = evictionCandidate();
    if (verdict.evicted) {
      mConnections.at(*verdict.evicted).state = State::Evicted;
      --mPending;
    }
  }
  mConnections[id] = Entry{address, State::Pending};
  ++mPerAddress[address];
  ++mPending;
  return verdict;
}

std::optional<ConnectionId> Admission::evictionCandidate() const {
  std::map<std::string, size_t> pendingOf;
  for (const auto& [id, entry] : mConnections)
    if (entry.state == State::Pending) ++pendingOf[entry.address];
  std::optional<ConnectionId> oldest;
  size_t most = 0;
  // Ids ascend: the first pending connection met of an address is its oldest.
  for (const auto& [id, entry] : mConnections)
    if (entry.state == State::Pending && pendingOf[entry.address] > most) {
      most = pendingOf[entry.address];
      oldest = id;
    }
  return oldest;
}

bool Admission::greet(ConnectionId id) {
  const auto it = mConnections.find(id);
  if (it == mConnections.end() || it->second.state == State::Evicted) return false;
  if (it->second.state == State::Session) return true;
  if (mSessions >= mLimits.maxSessions) return false;
  it->second.state = State::Session;
  --mPending;
  ++mSessions;
  return true;
}

void Admission::remove(ConnectionId id) {
  const auto it = mConnections.find(id);
  if (it == mConnections.end()) return;
  if (it->second.state == State::Pending) --mPending;
  if (it->second.state == State::Session) --mSessions;
  const auto count = mPerAddress.find(it->second.address);
  if (--count->second == 0) mPerAddress.erase(count);
  mConnections.erase(it);
}

size_t Admission::fromAddress(const std::string& address) const {
  const auto it = mPerAddress.find(address);
  return it == mPerAddress.end() ? 0 : it->second;
}

}  // namespace voxbrick::server
