// Sessions counted per address and token; frame rates as token buckets.
#include "server/Quotas.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace voxbrick::server {
namespace {

std::string rateText(double rate) {
  std::ostringstream out;
  out << rate;
  return out.str();
}

}  // namespace

std::optional<std::string> Quotas::countToken(Entry& entry, const TokenGrant& token) {
  const int sessions = token.sessions.value_or(mConfig.sessionsPerToken);
  if (sessions > 0 && mTokens[token.id].sessions >= size_t(sessions))
    return "quota: token '" + token.id + "' holds " + std::to_string(mTokens[token.id].sessions) + " sessions (" +
           (token.sessions ? "its sessions" : "quotas.sessions_per_token") + " = " + std::to_string(sessions) + ")";
  entry.token = token.id;
  entry.tokenSessions = sessions;
  entry.tokenFrames = token.framesPerSecond.value_or(mConfig.framesPerSecondPerToken);
  ++mTokens[token.id].sessions;
  return std::nullopt;
}

std::optional<std::string> Quotas::admit(ConnectionId id, const std::string& address, bool loopback,
                                         const TokenGrant* token) {
  if (loopback && mConfig.loopbackExempt) return std::nullopt;
  std::lock_guard lock(mMutex);
  if (mConfig.sessionsPerAddress > 0 && mAddresses[address].sessions >= size_t(mConfig.sessionsPerAddress))
    return "quota: address " + address + " holds " + std::to_string(mAddresses[address].sessions) +
           " sessions (quotas.sessions_per_address = " + std::to_string(mConfig.sessionsPerAddress) + ")";
  Entry entry{address, "", 0, 0};
  if (token && !token->anonymous())
    if (auto refusal = countToken(entry, *token)) return refusal;
  ++mAddresses[address].sessions;
  mSessions[id] = std::move(entry);
  return std::nullopt;
}

std::optional<std::string> Quotas::attachToken(ConnectionId id, const TokenGrant& token) {
  std::lock_guard lock(mMutex);
  const auto it = mSessions.find(id);
  if (it == mSessions.end() || token.anonymous() || !it->second.token.empty()) return std::nullopt;
  return countToken(it->second, token);
}

void Quotas::remove(ConnectionId id) {
  std::lock_guard lock(mMutex);
  const auto it = mSessions.find(id);
  if (it == mSessions.end()) return;
  const auto release = [](std::map<std::string, Holder>& holders, const std::string& key) {
    auto h = holders.find(key);
    if (h == holders.end()) return;
    if (h->second.sessions > 0) --h->second.sessions;
    if (h->second.sessions == 0) holders.erase(h);  // a returning client starts with a full bucket
  };
  release(mAddresses, it->second.address);
  if (!it->second.token.empty()) release(mTokens, it->second.token);
  mSessions.erase(it);
}

double Quotas::refill(Bucket& bucket, double rate, Clock::time_point now) {
  const double capacity = std::max(1.0, rate);
  if (bucket.frames < 0) {
    bucket.frames = capacity;
  } else {
    const double seconds = std::chrono::duration<double>(now - bucket.updated).count();
    bucket.frames = std::min(capacity, bucket.frames + std::max(0.0, seconds) * rate);
  }
  bucket.updated = now;
  return bucket.frames >= 1 ? 0 : (1 - bucket.frames) / rate * 1000;
}

void Quotas::returnFrame(ConnectionId id) {
  std::lock_guard lock(mMutex);
  const auto it = mSessions.find(id);
  if (it == mSessions.end()) return;
  const auto giveBack = [](Bucket& bucket, double rate) {
    if (bucket.frames >= 0) bucket.frames = std::min(std::max(1.0, rate), bucket.frames + 1);
  };
  if (mConfig.framesPerSecondPerAddress > 0)
    if (auto a = mAddresses.find(it->second.address); a != mAddresses.end())
      giveBack(a->second.bucket, mConfig.framesPerSecondPerAddress);
  if (it->second.tokenFrames > 0 && !it->second.token.empty())
    if (auto t = mTokens.find(it->second.token); t != mTokens.end()) giveBack(t->second.bucket, it->second.tokenFrames);
}

std::optional<Quotas::Refusal> Quotas::takeFrame(ConnectionId id, Clock::time_point now) {
  std::lock_guard lock(mMutex);
  const auto it = mSessions.find(id);
  if (it == mSessions.end()) return std::nullopt;
  Bucket* address = mConfig.framesPerSecondPerAddress > 0 ? &mAddresses[it->second.address].bucket : nullptr;
  Bucket* token = it->second.tokenFrames > 0 && !it->second.token.empty() ? &mTokens[it->second.token].bucket : nullptr;
  const double addressWait = address ? refill(*address, mConfig.framesPerSecondPerAddress, now) : 0;
  const double tokenWait = token ? refill(*token, it->second.tokenFrames, now) : 0;
  if (addressWait > 0 || tokenWait > 0) {
    Refusal refusal;
    refusal.retryAfterMs = uint32_t(std::ceil(std::max(addressWait, tokenWait)));
    refusal.why = addressWait >= tokenWait ? "quota: address " + it->second.address + " may send " +
                                                 rateText(mConfig.framesPerSecondPerAddress) + " Renders a second " +
                                                 "(quotas.frames_per_s_per_address)"
                                           : "quota: token '" + it->second.token + "' may send " +
                                                 rateText(it->second.tokenFrames) + " Renders a second";
    return refusal;
  }
  if (address) address->frames -= 1;
  if (token) token->frames -= 1;
  return std::nullopt;
}

}  // namespace voxbrick::server
