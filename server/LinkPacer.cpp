// Pacing by the client's reports, and the link's rate from frames that queued behind one another or from large frames.
#include "server/LinkPacer.h"

#include <algorithm>
#include <array>
#include <vector>

#include "common/Median.h"

namespace voxbrick::server {
namespace {

/// Frames remembered while the client does not report (a client that never reports must not grow the list).
constexpr size_t kMaxRemembered = 64;
/// A reading of the link's capacity older than this no longer holds the bitrate down.
constexpr double kLinkFreshMs = 2000;
/// A frame written before the one ahead of it was reported queued behind it only if it also arrived later than the
/// quickest delivery by at least this share of the time between the two reports: frames that merely overlap on a far
/// link (a round trip longer than the time between frames) each arrive in the quickest time, and the time between
/// their reports is the sender's spacing, not the link's.
constexpr double kQueuedShare = 0.25;
/// A queued frame smaller than this says nothing of the link on its own: it passes 10 Mbit/s in 3 ms, less than a
/// browser may take to report it, so the time between the reports measures the client (a 128x128 video drag on
/// loopback read as a link of about 1 Mbit/s, and got the slow link's encodings). Such frames read a full link only
/// together, where the time between their reports followed their sizes (queuedReading), and settle nothing.
constexpr uint64_t kQueuedMinBytes = 4096;
/// A frame at least this many bytes larger than the quickest delivered one measures the link on its own: the extra
/// bytes over the extra time they took (the round trip cancels). Smaller differences drown in the timing's noise.
constexpr uint64_t kMeasuringBytes = 32 * 1024;
/// Three measurements from smaller frames settle the link's rate when the fastest is at most this many times the
/// slowest: a shaped link's frames agree within tens of per cent, a busy client's hiccups read anything from 2 to
/// 100 Mbit/s on loopback.
constexpr double kAgreement = 2;
/// The least time the client's pace must leave a video frame's own bytes for a smaller frame to be worth it (ms).
constexpr double kMinPaceBudgetMs = 2;
/// The client's pace cuts the bitrate only where at least this share of what it leaves a frame past the quickest
/// delivery is left to the frame's bytes once the client's own delays are counted.
constexpr double kPaceRoomLeastShare = 1.0 / 3;
/// A cut by the client's pace: to the share its frames' time exceeds, but at least to half and at most to 90 %.
constexpr double kPaceCutMin = 0.5, kPaceCutMax = 0.9;
/// Frames under kQueuedMinBytes read the link (all but one of the last six queued) only where the largest is at
/// least this many times the smallest: alike in size, their reports' spacing cannot tell the link from the client.
constexpr double kSmallBytesSpread = 1.25;
/// Frames of the last twice as many reported that must have queued at the link for it to be read as full.
constexpr size_t kQueuedReadings = 3;
/// Frames whose bytes take less than this share of what the pace leaves them lift its limit a step (of this factor).
constexpr double kPaceRoomShare = 0.5, kPaceStep = 1.15;

double msBetween(LinkPacer::Clock::time_point a, LinkPacer::Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

}  // namespace

void LinkPacer::sent(uint64_t bytes, Clock::time_point at, bool video) {
  mOnTheWay.push_back({bytes, at, video});
  if (mOnTheWay.size() > kMaxRemembered) mOnTheWay.pop_front();
}

bool LinkPacer::received(Clock::time_point at) {
  if (mOnTheWay.empty()) return false;
  const OnTheWay frame = mOnTheWay.front();
  mOnTheWay.pop_front();
  const double delivery = std::max(0.0, msBetween(frame.at, at));
  for (auto* recent : {&mRecentDeliveries, frame.video ? &mVideoDeliveries : nullptr}) {
    if (!recent) continue;
    recent->push_back({delivery, frame.at, frame.bytes});
    if (recent->size() > kRecentDeliveries) recent->pop_front();
  }
  if (!mMinDeliveryMs || delivery < *mMinDeliveryMs) {
    mMinDeliveryMs = delivery;
    mMinDeliveryBytes = frame.bytes;
  }
  const double extraMs = delivery - *mMinDeliveryMs;
  // Two readings. Its bytes beyond the quickest delivered frame's over its time beyond the quickest delivery: at most
  // the link's rate, since a late report, the client's own delays or a wait behind another frame only lengthen that
  // time. And where it was written before the one ahead of it was reported and came later than the quickest delivery,
  // its bytes over the time between the two reports: its own transfer if it queued behind that one at the link; the
  // sender's spacing too if it reached the link after that one had passed.
  std::optional<double> extraKbps, queuedKbps;
  if (frame.bytes >= mMinDeliveryBytes + kQueuedMinBytes && extraMs > 0.5)
    extraKbps = double(frame.bytes - mMinDeliveryBytes) * 8 / extraMs;  // kbit/s
  if (mReporting && frame.at < mLastReport) {
    const double gapMs = msBetween(mLastReport, at);
    if (gapMs > 0.5 && extraMs >= kQueuedShare * gapMs) queuedKbps = double(frame.bytes) * 8 / gapMs;
  }
  // The capacity (capacityKbps) takes the second only where the frame reached the link before the one ahead had
  // passed it: written earlier than that one's report less the quickest delivery (a round trip). Else the time between
  // the reports holds the sender's spacing, or the window's wait for a report where the round trip is longer than the
  // frames' transfer. It takes the first only from frames that did not queue so (their extra time holds their wait).
  const bool queuedAtTheLink = queuedKbps && msBetween(frame.at, mLastReport) > *mMinDeliveryMs;
  if (queuedAtTheLink)
    mReadings.push_back({at, std::nullopt, queuedKbps, frame.bytes});
  else
    mReadings.push_back({at, extraKbps, std::nullopt, frame.bytes});
  while (msBetween(mReadings.front().at, at) >= kLinkFreshMs) mReadings.pop_front();
  if (queuedReading(mReadings)) mFullAt = at;
  // The settled rate takes the larger of the two (the second alone read a 10 Mbit/s link at 2.5 to 5 Mbit/s during a
  // drag), or the first from a frame much larger than the quickest delivered one.
  std::optional<double> sample = frame.bytes >= kQueuedMinBytes ? queuedKbps : std::nullopt;
  if (sample && extraKbps) sample = std::max(*sample, *extraKbps);
  if (!sample && frame.bytes >= mMinDeliveryBytes + kMeasuringBytes) sample = extraKbps;
  if (sample) settle({*sample, frame.bytes});
  mReporting = true;
  mLastReport = at;
  return true;
}

bool LinkPacer::mayWrite(Clock::time_point now) const {
  if (!mReporting || mOnTheWay.size() < size_t(framesInFlightAllowed())) return true;
  return msBetween(mOnTheWay.front().at, now) >= kStaleMs;
}

int LinkPacer::framesInFlightAllowed() const {
  if (!mMinDeliveryMs || mRecentDeliveries.size() < kRecentDeliveries) return kFramesInFlight;
  const bool queueless = std::all_of(mRecentDeliveries.begin(), mRecentDeliveries.end(), [this](const Delivery& d) {
    return d.ms <= *mMinDeliveryMs + kNoQueueMs;
  });
  return kFramesInFlight + (queueless ? 1 : 0);
}

LinkPacer::Clock::time_point LinkPacer::releaseAt() const {
  if (mOnTheWay.empty()) return Clock::time_point{};
  return mOnTheWay.front().at + std::chrono::microseconds(int64_t(kStaleMs * 1000));
}

std::optional<LinkPacer::Clock::time_point> LinkPacer::roomExpectedAt(Clock::time_point now) const {
  if (mayWrite(now)) return now;
  const std::optional<double> delivery = medianMs(mRecentDeliveries);
  if (!delivery) return std::nullopt;
  return std::min(mOnTheWay.front().at + std::chrono::microseconds(int64_t(*delivery * 1000)), releaseAt());
}

std::optional<double> LinkPacer::medianMs(const std::deque<Delivery>& deliveries) {
  if (deliveries.empty()) return std::nullopt;
  std::vector<double> ms;
  for (const Delivery& d : deliveries) ms.push_back(d.ms);
  return upperMedian(std::move(ms));
}

std::optional<double> LinkPacer::videoWaitMs() const {
  if (!mMinDeliveryMs || mVideoDeliveries.size() < kRecentDeliveries) return std::nullopt;
  return *medianMs(mVideoDeliveries) - *mMinDeliveryMs;
}

std::optional<double> LinkPacer::lastDeliveryMs() const {
  if (mRecentDeliveries.empty()) return std::nullopt;
  return mRecentDeliveries.back().ms;
}

std::optional<double> LinkPacer::minDeliveryMs() const { return mMinDeliveryMs; }

std::optional<double> LinkPacer::capacityKbps(Clock::time_point now) const {
  // Half the last few frames queued at the link: it is full, and they read it. Fewer are the reports of a busy client,
  // late behind one another. Else the most the others read since the link was last full (the readings of a faster
  // link before it would raise the bitrate again at once).
  if (!mReadings.empty() && msBetween(mReadings.back().at, now) < kLinkFreshMs)
    if (const auto full = queuedReading(mReadings)) return full;
  std::optional<double> most;
  for (const Reading& r : mReadings)
    if (r.extraKbps && r.at > mFullAt && msBetween(r.at, now) < kLinkFreshMs)
      most = std::max(most.value_or(0), *r.extraKbps);
  return most;
}

std::optional<double> LinkPacer::queuedReading(const std::deque<Reading>& readings) {
  std::vector<double> queued, any, bytes;
  for (auto r = readings.rbegin(); r != readings.rend() && r - readings.rbegin() < std::ptrdiff_t(2 * kQueuedReadings);
       ++r) {
    if (r->queuedKbps && r->bytes >= kQueuedMinBytes) queued.push_back(*r->queuedKbps);
    if (r->queuedKbps) any.push_back(*r->queuedKbps), bytes.push_back(double(r->bytes));
  }
  if (queued.size() >= kQueuedReadings) return upperMedian(std::move(queued));
  // Frames too small to read the link alone: all but one of the last six queued, and the time between their reports
  // followed their sizes (what they read varies less than half as much as their bytes, in ratio's logarithm): a link
  // passes each frame in its bytes' time, a busy client reports each after its own (a page's frame time, a steady
  // lag), whatever its size. Frames alike in size cannot tell the two apart, and read nothing.
  if (any.size() + 1 < 2 * kQueuedReadings) return std::nullopt;
  const auto [lo, hi] = std::minmax_element(any.begin(), any.end());
  const auto [fewest, most] = std::minmax_element(bytes.begin(), bytes.end());
  const double spread = *hi / *lo, bytesSpread = *most / *fewest;
  if (bytesSpread < kSmallBytesSpread || spread * spread > bytesSpread || spread > kAgreement) return std::nullopt;
  return upperMedian(std::move(any));
}

std::optional<double> LinkPacer::settledLinkKbps() const {
  if (mSettledKbps <= 0) return std::nullopt;
  return mSettledKbps;
}

void LinkPacer::settle(Sample sample) {
  mRecent.push_back(sample);
  if (mRecent.size() > 3) mRecent.pop_front();
  if (sample.bytes >= kConclusiveBytes) {
    mSettledKbps = sample.kbps;
    return;
  }
  if (mRecent.size() < 3) return;
  std::array<double, 3> kbps{mRecent[0].kbps, mRecent[1].kbps, mRecent[2].kbps};
  std::sort(kbps.begin(), kbps.end());
  if (kbps[2] <= kAgreement * kbps[0]) mSettledKbps = kbps[1];
}

double LinkPacer::videoKbps(double startKbps, double capKbps, Clock::time_point now, std::optional<double> paceMs) {
  capKbps = std::max(capKbps, kMinKbps);
  const std::optional<double> capacity = capacityKbps(now);
  if (const auto link = capacity) {
    mTargetKbps = std::clamp(kLinkShare * *link, kMinKbps, capKbps);
  } else if (mTargetKbps <= 0) {
    mTargetKbps = std::clamp(startKbps, kMinKbps, capKbps);
  } else if (const auto waits = videoWaitMs(); !waits || *waits <= kRaiseWaitMs) {
    // Nothing queued on the link lately: it keeps up, so the stream may take more (half as much again a second). Not
    // where its frames wait at the link though nothing reads it (frames under 4 KiB, alike in size: a link that
    // slowed to 1 Mbit/s under a 60 ms round trip): raised there, the stream took the whole link.
    const double seconds = std::clamp(msBetween(mTargetAt, now) / 1000, 0.0, 1.0);
    mTargetKbps = std::clamp(mTargetKbps * (1 + 0.5 * seconds), kMinKbps, capKbps);
  }
  mTargetAt = now;
  if (paceMs) followPace(*paceMs, mTargetKbps, capacity ? capacity : settledLinkKbps(), now);
  if (mPaceKbps <= 0) return mTargetKbps;
  return std::max(kMinKbps, std::min(mTargetKbps, mPaceKbps));
}

void LinkPacer::followPace(double paceMs, double targetKbps, std::optional<double> link, Clock::time_point now) {
  // Frames encoded at the limit as it now stands: each of the last few was written after it last changed.
  if (!mMinDeliveryMs || mVideoDeliveries.size() < kRecentDeliveries ||
      std::any_of(mVideoDeliveries.begin(), mVideoDeliveries.end(),
                  [this](const Delivery& d) { return d.sentAt < mPaceChangedAt; }))
    return;
  // The time the pace leaves a frame past the quickest delivery: none on a far link whose round trip alone is longer
  // than the pace allows, where smaller frames would not come sooner.
  const double budgetMs = kPaceShare * paceMs - *mMinDeliveryMs;
  if (budgetMs < kMinPaceBudgetMs) return;
  // Only the frame's own bytes come down with the bitrate: the link's rate tells their time from the rest (the
  // client's own delays: a busy browser reports tens of ms late). Without a rate nothing tells them apart: nothing is
  // cut, and a limit is lifted only where the whole time past the quickest delivery is well within the pace (a limit
  // that waited for a rate to be read again held a stream at its lowest for the rest of a drag).
  std::vector<double> bytes;
  for (const Delivery& d : mVideoDeliveries) bytes.push_back(double(d.bytes));
  const double extraMs = *videoWaitMs();
  const double bytesMs = link ? std::min(extraMs, upperMedian(std::move(bytes)) * 8 / *link) : extraMs;
  const double roomMs = budgetMs - (extraMs - bytesMs);  // what the pace leaves the bytes
  const double current = mPaceKbps > 0 ? std::min(mPaceKbps, targetKbps) : targetKbps;
  if (extraMs > budgetMs) {
    if (!link) return;
    // The client's own delays take most of the pace (a busy browser): smaller frames would hardly come sooner, and
    // chasing the little left cut a busy two-core Chromium's 1024² stream to 0.9 Mbit/s, 35 dB.
    if (roomMs < std::max(kMinPaceBudgetMs, kPaceRoomLeastShare * budgetMs)) return;
    mPaceKbps = std::max(kMinKbps, current * std::clamp(roomMs / bytesMs, kPaceCutMin, kPaceCutMax));
    mPaceChangedAt = now;
  } else if (mPaceKbps > 0 && bytesMs < kPaceRoomShare * roomMs) {
    mPaceKbps *= kPaceStep;
    if (mPaceKbps >= targetKbps) mPaceKbps = 0;  // no longer below what the link allows: lifted
    mPaceChangedAt = now;
  }
}

}  // namespace voxbrick::server
