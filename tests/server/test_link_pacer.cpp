// A session's link from its client's FrameReceived reports, driven with made-up times: the window of frames on their
// way, the stale client, the link's rate from frames that queued behind one another or from a large frame (and none
// from frames that only overlap on a far link), and the video bitrate.
#include <gtest/gtest.h>

#include <algorithm>
#include <deque>
#include <vector>

#include "common/Median.h"
#include "server/LinkPacer.h"
#include "server/RenderJob.h"
#include "support/MadeUpTime.h"

namespace voxbrick::server {
namespace {

using Clock = LinkPacer::Clock;
using std::chrono::milliseconds;

using test::at;

TEST(LinkPacer, AClientThatNeverReportsIsNotPaced) {
  LinkPacer pacer;
  for (int i = 0; i < 200; ++i) {
    EXPECT_TRUE(pacer.mayWrite(at(i)));
    pacer.sent(1000, at(i));
  }
  EXPECT_FALSE(pacer.reporting());
  EXPECT_EQ(pacer.inFlight(), 0);
}

TEST(LinkPacer, AReportingClientHasAtMostTwoFramesOnTheirWay) {
  LinkPacer pacer;
  pacer.sent(1000, at(0));
  ASSERT_TRUE(pacer.received(at(50)));
  EXPECT_TRUE(pacer.reporting());
  pacer.sent(1000, at(60));
  EXPECT_TRUE(pacer.mayWrite(at(61)));
  pacer.sent(1000, at(61));
  EXPECT_EQ(pacer.inFlight(), LinkPacer::kFramesInFlight);
  EXPECT_FALSE(pacer.mayWrite(at(62))) << "a third frame waits at the server";
  EXPECT_EQ(pacer.releaseAt(), at(60 + LinkPacer::kStaleMs));
  ASSERT_TRUE(pacer.received(at(110)));
  EXPECT_TRUE(pacer.mayWrite(at(111)));
  EXPECT_EQ(*pacer.minDeliveryMs(), 50);
  EXPECT_EQ(*pacer.lastDeliveryMs(), 50);
  EXPECT_TRUE(pacer.received(at(120)));
  EXPECT_FALSE(pacer.received(at(121))) << "more reports than frames written";
}

// A far link that does not queue (each frame delivered within kNoQueueMs of the quickest) may carry a third frame:
// two a round trip held an 80 ms link to about 22 frames a second. Once frames queue, two again.
TEST(LinkPacer, AThirdFrameMayBeOnItsWayWhileTheLinkShowsNoQueue) {
  LinkPacer pacer;
  double t = 0;
  const auto onItsWay = [&](int frames) {
    for (int i = 0; i < frames; ++i) pacer.sent(20000, at(t + i));
  };
  for (int i = 0; i < 3; ++i) {  // each alone on the link: 80 ms, 82 ms, 81 ms
    onItsWay(1);
    pacer.received(at(t + 80 + (i % 2) * 2 + (i == 2 ? 1 : 0)));
    t += 100;
  }
  EXPECT_EQ(pacer.framesInFlightAllowed(), LinkPacer::kFramesInFlight + 1);
  onItsWay(2);
  EXPECT_TRUE(pacer.mayWrite(at(t + 2))) << "a third frame goes";
  pacer.sent(20000, at(t + 2));
  EXPECT_FALSE(pacer.mayWrite(at(t + 3))) << "a fourth waits";
  // Frames that queue: each 10 ms later than the quickest.
  for (int i = 0; i < 3; ++i) pacer.received(at(t + 90 + i));
  EXPECT_EQ(pacer.framesInFlightAllowed(), LinkPacer::kFramesInFlight);
  t += 200;
  onItsWay(2);
  EXPECT_FALSE(pacer.mayWrite(at(t + 2)));
}

TEST(LinkPacer, AClientThatStopsReportingIsReleasedAfterASecond) {
  LinkPacer pacer;
  pacer.sent(1000, at(0));
  pacer.received(at(10));
  pacer.sent(1000, at(20));
  pacer.sent(1000, at(21));
  EXPECT_FALSE(pacer.mayWrite(at(500)));
  EXPECT_TRUE(pacer.mayWrite(at(20 + LinkPacer::kStaleMs)));
}

/// 20 frames of 25 000 bytes written every `writeMs` on a link that takes `passMs` to pass each, with 40 ms of round
/// trip; each frame's report comes as the next one has passed.
void queueFrames(LinkPacer& pacer, double writeMs, double passMs) {
  double linkFree = 0;
  for (int i = 0; i < 20; ++i) {
    const double sentAt = writeMs * i;
    pacer.sent(25000, at(sentAt));
    linkFree = std::max(linkFree, sentAt) + passMs;
    if (i >= 1) pacer.received(at(linkFree - passMs + 40));  // the previous frame's report
  }
}

TEST(LinkPacer, FramesThatQueuedBehindOneAnotherMeasureTheLink) {
  LinkPacer pacer;
  // A 10 Mbit/s link (10 kbit a ms): a 25 000-byte frame takes 20 ms to pass; written faster than that.
  queueFrames(pacer, 10, 20);
  const auto link = pacer.capacityKbps(at(450));
  ASSERT_TRUE(link);
  EXPECT_NEAR(*link, 10000, 500);
  EXPECT_NEAR(pacer.videoKbps(2000, 50000, at(450)), LinkPacer::kLinkShare * 10000, 500);
  EXPECT_FALSE(pacer.capacityKbps(at(5000))) << "an old reading no longer holds";
}

TEST(LinkPacer, FramesOnAnIdleLinkMeasureNoRateAndTheBitrateClimbsToItsCap) {
  LinkPacer pacer;
  // Each frame is reported before the next is written: the link keeps up.
  for (int i = 0; i < 10; ++i) {
    pacer.sent(5000, at(100.0 * i));
    pacer.received(at(100.0 * i + 45));
  }
  EXPECT_FALSE(pacer.capacityKbps(at(1000)));
  EXPECT_EQ(pacer.videoKbps(1000, 8000, at(1000)), 1000) << "the start";
  const double later = pacer.videoKbps(1000, 8000, at(2000));
  EXPECT_NEAR(later, 1500, 1) << "half as much again after a second";
  double kbps = later;
  for (int s = 3; s < 12; ++s) kbps = pacer.videoKbps(1000, 8000, at(1000.0 * s));
  EXPECT_EQ(kbps, 8000) << "never above the cap";
  EXPECT_EQ(pacer.videoKbps(1, 1, at(13000)), LinkPacer::kMinKbps) << "nor below the floor";
}

// A drag's frames on a slow link, each written before the one ahead was reported but reaching the link after that one
// had passed: 12 000 bytes every 33 ms on 10 Mbit/s (9.6 ms each) with 40 ms of round trip. The time between their
// reports is the sender's 33 ms, and read as their transfer it made the link 2.9 Mbit/s (a 1024x1024 drag's video
// then ran at 2 Mbit/s on a 10 Mbit/s link); their bytes beyond the quickest frame's over their time beyond the
// quickest delivery read the link itself.
TEST(LinkPacer, FramesThatReachTheLinkAfterTheOneAheadMeasureTheLinkNotTheirSpacing) {
  LinkPacer pacer;
  pacer.sent(1000, at(0), true);
  pacer.received(at(40 + 0.8));  // the quickest: the round trip and 1000 bytes' time
  for (int i = 0; i < 10; ++i) {
    pacer.sent(12000, at(100 + 33.0 * i), true);
    if (i >= 1) pacer.received(at(100 + 33.0 * (i - 1) + 40 + 9.6));  // the one ahead's report, after this write
  }
  pacer.received(at(100 + 33.0 * 9 + 40 + 9.6));
  const auto link = pacer.capacityKbps(at(500));
  ASSERT_TRUE(link);
  EXPECT_NEAR(*link, 10000, 500);
  ASSERT_TRUE(pacer.settledLinkKbps());
  EXPECT_NEAR(*pacer.settledLinkKbps(), 10000, 500);
}

// A far link that keeps up: 100 Mbit/s with 80 ms of round trip, a 15 000-byte frame every 33 ms (a drag's video
// frames). Each frame is written before the one ahead is reported, but none waits: the time between reports is the
// sender's 33 ms, not the link's 1.2 ms, and measures nothing (it read 3.6 Mbit/s, a slow link, before).
TEST(LinkPacer, FramesThatOnlyOverlapOnAFarLinkMeasureNothing) {
  LinkPacer pacer;
  for (int i = 0; i < 30; ++i) {
    pacer.sent(15000, at(33.0 * i));
    if (i >= 3) pacer.received(at(33.0 * (i - 3) + 81.2));  // the report of the frame written three frames ago
  }
  EXPECT_FALSE(pacer.capacityKbps(at(33.0 * 29))) << *pacer.capacityKbps(at(33.0 * 29)) << " kbit/s";
  EXPECT_FALSE(pacer.settledLinkKbps());
  EXPECT_FALSE(webpFor(pacer.settledLinkKbps()));
  EXPECT_EQ(pngSpeedFor(pacer.settledLinkKbps()), image::PngSpeed::Fast);
}

// Tiny frames (a 128x128 drag's video frames, 700 bytes) reported a few ms apart by a busy client: they queued, but
// the time between the reports is the client's, not their transfer's. They measure nothing.
TEST(LinkPacer, TinyFramesMeasureTheClientNotTheLink) {
  LinkPacer pacer;
  for (int i = 0; i < 30; ++i) {
    pacer.sent(700, at(4.0 * i));
    if (i >= 1) pacer.received(at(4.0 * (i - 1) + 1 + 1.5 * (i - 1)));  // each report later than the quickest
  }
  EXPECT_FALSE(pacer.capacityKbps(at(120))) << *pacer.capacityKbps(at(120)) << " kbit/s";
  EXPECT_FALSE(pacer.settledLinkKbps());
}

// A frame much larger than the quickest delivered one measures the link by itself, on a slow link and on a fast one:
// an exact png after small video frames, each written onto an idle link.
TEST(LinkPacer, ALargeFrameMeasuresTheLinkOnItsOwn) {
  for (const double mbit : {10.0, 100.0}) {
    LinkPacer pacer;
    const double bytesPerMs = mbit * 1000 / 8;
    double t = 0;
    for (const uint64_t bytes : {uint64_t(8000), uint64_t(9000), uint64_t(440000)}) {
      pacer.sent(bytes, at(t));
      pacer.received(at(t + 40 + double(bytes) / bytesPerMs));  // 40 ms of round trip, then the bytes' time
      t += 1000;
    }
    const auto link = pacer.capacityKbps(at(t));
    ASSERT_TRUE(link) << mbit << " Mbit/s";
    EXPECT_NEAR(*link, mbit * 1000, mbit * 1000 * 0.02);
    EXPECT_EQ(webpFor(link), mbit < 12);
    // Frames that keep up measure nothing new: the video's bitrate may climb again after two seconds, while lossless
    // frames still go by the rate the large frame found (one large enough to settle it on its own).
    EXPECT_FALSE(pacer.capacityKbps(at(t + 3000)));
    ASSERT_TRUE(pacer.settledLinkKbps());
    EXPECT_EQ(*pacer.settledLinkKbps(), *link);
  }
  // Frames alike in size on an idle link say nothing.
  LinkPacer alike;
  for (int i = 0; i < 5; ++i) {
    alike.sent(30000, at(100.0 * i));
    alike.received(at(100.0 * i + 64));
  }
  EXPECT_FALSE(alike.capacityKbps(at(500)));
  EXPECT_FALSE(alike.settledLinkKbps());
}

// A busy browser's reports come late by up to tens of ms: on loopback a frame of a few KB that queued behind another
// then reads as a link of a few Mbit/s, or, when the report before it was the late one, of 100. Such readings may
// hold a video's bitrate down for a moment, but they never settle the rate the lossless encodings follow; three in a
// row that agree do, as do the queued frames of a shaped link.
TEST(LinkPacer, AClientsHiccupsDoNotSettleTheLinksRate) {
  LinkPacer pacer;
  double t = 0;
  // A small frame reported `lateMs` late, then one of `bytes` written before that report, reported `gapMs` after it.
  const auto queued = [&](uint64_t bytes, double gapMs, double lateMs = 0) {
    pacer.sent(2000, at(t));
    pacer.sent(bytes, at(t + 0.5));
    pacer.received(at(t + 1.5 + lateMs));
    pacer.received(at(t + 1.5 + lateMs + gapMs));
    t += 500;
  };
  queued(9070, 7.5);  // the readings a headless Chromium's hiccups gave on loopback, two cores busy
  // Its extra bytes over its extra time: lower than the link, as every such reading; the video's capacity is the most.
  ASSERT_TRUE(pacer.capacityKbps(at(t)));
  const double read = *pacer.capacityKbps(at(t));
  EXPECT_NEAR(read, (9070 - 2000) * 8 / 7.0, 1);
  queued(7387, 0.58, 20);
  // The report ahead of it was late: the time between the two reads 100 Mbit/s, which raises nothing.
  EXPECT_EQ(*pacer.capacityKbps(at(t)), read);
  queued(9314, 38.6);
  EXPECT_EQ(*pacer.capacityKbps(at(t)), read) << "a lower reading lowers nothing";
  EXPECT_FALSE(pacer.settledLinkKbps()) << *pacer.settledLinkKbps() << " kbit/s";
  EXPECT_FALSE(webpFor(pacer.settledLinkKbps()));
  EXPECT_EQ(pngSpeedFor(pacer.settledLinkKbps()), image::PngSpeed::Fast);
  // Three in a row that agree settle it: a link of about 5 Mbit/s.
  for (const double gapMs : {14.0, 12.5, 16.0}) queued(8000, gapMs);
  ASSERT_TRUE(pacer.settledLinkKbps());
  EXPECT_NEAR(*pacer.settledLinkKbps(), 8000 * 8 / 14.0, 1);
  // A hiccup after that changes nothing.
  queued(8000, 0.6, 20);
  EXPECT_NEAR(*pacer.settledLinkKbps(), 8000 * 8 / 14.0, 1);
}

TEST(LinkPacer, PngFramesAreEncodedSmallOnlyOnALinkMeasuredSlow) {
  EXPECT_EQ(pngSpeedFor(std::nullopt), image::PngSpeed::Fast) << "no measurement: the link keeps up";
  LinkPacer slow, fast;
  queueFrames(slow, 10, 40);  // 5 Mbit/s
  queueFrames(fast, 0.5, 1);  // 200 Mbit/s
  ASSERT_TRUE(slow.settledLinkKbps() && fast.settledLinkKbps());
  EXPECT_EQ(pngSpeedFor(slow.settledLinkKbps()), image::PngSpeed::Small);
  EXPECT_EQ(pngSpeedFor(fast.settledLinkKbps()), image::PngSpeed::Fast);
  // Lossless webp in place of png below kWebpBelowKbps, if the scene accepts it (RenderJob::webpForPng).
  EXPECT_FALSE(webpFor(std::nullopt));
  EXPECT_TRUE(webpFor(slow.settledLinkKbps()));
  EXPECT_FALSE(webpFor(fast.settledLinkKbps()));
  // The queued frames agree: they settle the rate the lossless encodings follow, and read the video's capacity.
  EXPECT_NEAR(*slow.capacityKbps(at(900)), 5000, 50);
  EXPECT_NEAR(*fast.capacityKbps(at(900)), 200000, 2000);
  EXPECT_NEAR(*slow.settledLinkKbps(), 5000, 50);
  EXPECT_NEAR(*fast.settledLinkKbps(), 200000, 2000);
}

TEST(LinkPacer, RoomIsExpectedWhenTheOldestFrameShouldBeReported) {
  LinkPacer pacer;
  EXPECT_EQ(pacer.roomExpectedAt(at(0)), at(0)) << "an idle link has room";
  pacer.sent(1000, at(0));
  pacer.received(at(50));
  pacer.sent(1000, at(60));
  pacer.sent(1000, at(70));
  ASSERT_FALSE(pacer.mayWrite(at(80)));
  ASSERT_TRUE(pacer.roomExpectedAt(at(80)));
  EXPECT_EQ(*pacer.roomExpectedAt(at(80)), at(110)) << "the oldest's write plus the usual delivery";
  pacer.received(at(130));  // 70 ms
  pacer.sent(1000, at(131));
  pacer.received(at(150));  // 80 ms
  pacer.sent(1000, at(151));
  ASSERT_FALSE(pacer.mayWrite(at(152)));
  EXPECT_EQ(*pacer.roomExpectedAt(at(152)), at(131 + 70)) << "the median of the last three: 50, 70 and 80 ms";
}

/// A drag's video through a modelled link for `ms`, at most `cap` kbit/s: a frame every 33 ms as the window allows,
/// of the bytes its bitrate gives at 30 frames a second times `size(n)` (the n-th frame written), through a link of
/// `linkKbps(t)` with `roundTripMs` of round trip, reported `lateMs(n)` late (reports leave the client in order).
/// `seen(t, kbps)` is told each frame's bitrate. Returns the frames written.
template <class Size, class Link, class Late, class Seen>
int dragThroughALink(LinkPacer& pacer, double ms, double cap, Size size, Link linkKbps, Late lateMs, Seen seen,
                     double roundTripMs = 40) {
  std::deque<double> reports;  // when each frame's report arrives
  double linkFree = 0, lastReport = 0;
  int frames = 0;
  for (double t = 0; t < ms; t += 1000.0 / 30) {
    while (!reports.empty() && reports.front() <= t) {
      pacer.received(at(reports.front()));
      reports.pop_front();
    }
    if (!pacer.mayWrite(at(t))) continue;
    const double kbps = pacer.videoKbps(cap / 3, cap, at(t));
    const double bytes = kbps * 1000 / 8 / 30 * size(frames);
    pacer.sent(uint64_t(bytes), at(t), true);
    linkFree = std::max(linkFree, t) + bytes * 8 / linkKbps(t);
    lastReport = std::max(lastReport, linkFree + roundTripMs + lateMs(frames));
    reports.push_back(lastReport);
    ++frames;
    seen(t, kbps);
  }
  return frames;
}

// A drag's video on a 10 Mbit/s link with 40 ms of round trip, its frames give or take 30 % of what the bitrate gives,
// each reported 1 to 15 ms late (a busy client). The frames keep up with the link, and the bitrate climbs to its cap
// and stays there. A rate smoothed over the time between reports read the link as the frames' own rate and the
// bitrate followed it down, to 0.5 Mbit/s here and to 1 Mbit/s with 4 KB frames in Chromium on such a link.
TEST(LinkPacer, ADragsFramesThatKeepUpWithTheLinkDoNotBringItsBitrateDown) {
  const double cap = 4719, linkKbps = 10000;
  const double lateMs[] = {2, 9, 4, 12, 6, 1, 15, 3, 8, 5};
  const double sizes[] = {0.8, 1.2, 1.0, 0.9, 1.1, 1.3, 0.7};
  LinkPacer pacer;
  double lowest = cap;
  const int frames = dragThroughALink(
      pacer, 8000, cap, [&](int n) { return sizes[n % 7]; }, [&](double) { return linkKbps; },
      [&](int n) { return lateMs[n % 10]; },
      [&](double t, double kbps) {
        if (t > 3000) lowest = std::min(lowest, kbps);
      });
  EXPECT_GE(lowest, 0.95 * cap) << "kbit/s after 3 s, of " << frames << " frames";
  ASSERT_TRUE(pacer.capacityKbps(at(8000)));
  // At most what the link carries, give or take the quickest frame's own lateness (it read 1.17 times the link).
  EXPECT_LE(*pacer.capacityKbps(at(8000)), linkKbps * 1.25);
}

// A link that becomes slower than the stream (10 Mbit/s, then 1): frames queue behind one another, the time between
// their reports reads the link, and the bitrate comes down to its share of it within a second.
TEST(LinkPacer, ALinkThatSlowsBringsTheBitrateDown) {
  const double cap = 4719;
  LinkPacer pacer;
  double lowestInTheFirstSecond = cap;
  std::vector<double> later;  // the bitrates after a second on the slow link
  dragThroughALink(
      pacer, 6000, cap, [](int n) { return n % 2 ? 0.9 : 1.1; },
      [](double t) { return t < 3000 ? 10000 : 1000; }, [](int n) { return (n % 3) * 2.0; },
      [&](double t, double kbps) {
        if (t > 2900 && t < 3000) {
          EXPECT_EQ(kbps, cap) << "the fast link's";
        }
        if (t >= 3000 && t < 4000) lowestInTheFirstSecond = std::min(lowestInTheFirstSecond, kbps);
        if (t >= 4000) later.push_back(kbps);
      });
  EXPECT_LE(lowestInTheFirstSecond, LinkPacer::kLinkShare * 1000 * 1.05);
  // Then it keeps near its share, climbing while frames keep up and brought down again by those that queue.
  ASSERT_FALSE(later.empty());
  EXPECT_LE(upperMedian(later), 1000) << "kbit/s on the slow link";
  EXPECT_GE(upperMedian(later), 0.5 * LinkPacer::kLinkShare * 1000);
}

// A link that slows to 1 Mbit/s under a 60 ms round trip: the frames that fit it (4 KB, alike in size) are too small
// to read it, and with the round trip only two are on their way, so none reads it as full either. Their deliveries
// show the wait, and the bitrate is held there instead of climbing to the whole link (the stream took 1 Mbit/s and
// more, and its frames' p99 latency in bench_link_pacer --drop rose from 89 to 135 ms).
TEST(LinkPacer, ABitrateIsNotRaisedWhereItsFramesWaitThoughNothingReadsTheLink) {
  const double cap = 4719, slowKbps = 1000;
  LinkPacer pacer;
  std::vector<double> later;  // the bitrates after two seconds on the slow link
  dragThroughALink(
      pacer, 9000, cap, [](int n) { return n % 2 ? 0.9 : 1.1; },
      [&](double t) { return t < 3000 ? 5000 : slowKbps; }, [](int n) { return (n % 3) * 1.0; },
      [&](double t, double kbps) {
        if (t >= 5000) later.push_back(kbps);
      },
      60);
  ASSERT_FALSE(later.empty());
  EXPECT_LE(*std::max_element(later.begin(), later.end()), 0.9 * slowKbps) << "kbit/s on the slow link";
  EXPECT_GE(upperMedian(later), 0.5 * LinkPacer::kLinkShare * slowKbps);
}

// A link that slows from 1 to 0.25 Mbit/s: the stream's frames are under 4 KiB, too small for one to read it, but every
// one queues, and the time between their reports follows their sizes (a link passes each in its bytes' time). They
// read it together, and the bitrate comes down below the link (it was held at 515 kbit/s, twice the link; with a
// browser's late reports on a link slowing to 0.4 Mbit/s, p99 127 ms in bench_link_pacer --drop).
TEST(LinkPacer, SmallFramesThatAllQueueReadASlowLinkByTheirSizes) {
  const double cap = 4719, slowKbps = 250;
  const double sizes[] = {0.75, 1.25, 1.0, 0.85, 1.15, 1.3, 0.7};
  LinkPacer pacer;
  std::vector<double> later;  // the bitrates after two seconds on the slow link
  dragThroughALink(
      pacer, 9000, cap, [&](int n) { return sizes[n % 7]; }, [&](double t) { return t < 4000 ? 1000 : slowKbps; },
      [](int n) { return (n % 5) * 2.0; },
      [&](double t, double kbps) {
        if (t >= 6000) later.push_back(kbps);
      });
  ASSERT_FALSE(later.empty());
  EXPECT_LE(upperMedian(later), 0.9 * slowKbps) << "kbit/s on the slow link";
  EXPECT_LE(*std::max_element(later.begin(), later.end()), slowKbps);
}

// Small frames of many sizes that a busy page reports at its own pace (one every 40 ms, whatever their size) on a
// fast link read nothing: the time between the reports does not follow their sizes.
TEST(LinkPacer, SmallFramesReportedAtAPagesPaceReadNothing) {
  LinkPacer pacer;
  const double sizes[] = {0.75, 1.25, 1.0, 0.85, 1.15, 1.3, 0.7};
  for (int i = 0; i < 40; ++i) {
    pacer.sent(uint64_t(2000 * sizes[i % 7]), at(33.0 * i), true);
    if (i >= 2) pacer.received(at(2 + 40.0 * (i - 2)));  // each report 40 ms after the one before
  }
  EXPECT_FALSE(pacer.capacityKbps(at(33.0 * 40))) << *pacer.capacityKbps(at(33.0 * 40)) << " kbit/s";
}

/// Three video frames of `bytes` on an idle link, each written `everyMs` after the last and reported `deliveryMs`
/// after its write, from `t`; `t` moves past them.
void videoFrames(LinkPacer& pacer, double& t, uint64_t bytes, double deliveryMs, double everyMs = 100) {
  for (int i = 0; i < 3; ++i) {
    pacer.sent(bytes, at(t), true);
    pacer.received(at(t + deliveryMs));
    t += everyMs;
  }
}

/// The quickest delivery (a 1000-byte video frame in 45 ms, written at 0) and a still frame of 441 000 bytes on a
/// 10 Mbit/s link, which settles its rate on its own; `t` moves past them.
void slowLinkMeasured(LinkPacer& pacer, double& t) {
  pacer.sent(1000, at(0), true);
  pacer.received(at(45));
  pacer.sent(441000, at(100));
  pacer.received(at(100 + 45 + 440000.0 * 8 / 10000));
  t = 600;
}

// A drag asks a frame every 33 ms and two may be on their way: a frame that takes longer than 60 ms from write to
// report (90 % of 67 ms) holds the stream below the client's pace. Of the time past the quickest delivery (the round
// trip), the frame's own bytes take what the link's rate says: the bitrate comes down so that they fit in what the
// pace leaves them besides the client's own delays (a 1024x1024 drag on 10 Mbit/s with 40 ms of round trip
// sometimes ran at 17 frames a second with frames of 40 KB, its bitrate at its cap, where 10 KB frames kept 29).
// Frames well within it lift the limit a step at a time.
TEST(LinkPacer, AVideoStreamsBitrateComesDownToKeepTheClientsPace) {
  const double paceMs = LinkPacer::kFramesInFlight * 33.3, cap = 4719;
  const double budgetMs = LinkPacer::kPaceShare * paceMs - 45;  // 15 ms
  LinkPacer pacer, unpaced;
  double t = 0, u = 0;
  slowLinkMeasured(pacer, t);
  slowLinkMeasured(unpaced, u);
  ASSERT_TRUE(pacer.settledLinkKbps());
  EXPECT_NEAR(*pacer.settledLinkKbps(), 10000, 1);
  EXPECT_EQ(pacer.videoKbps(cap, cap, at(t), paceMs), cap) << "nothing delivered at this bitrate yet";
  // Three frames of 30 KB take 74 ms each: 29 ms past the quickest, 24 ms of it their bytes, 5 the client's.
  videoFrames(pacer, t, 30000, 74);
  videoFrames(unpaced, u, 30000, 74);
  EXPECT_EQ(unpaced.videoKbps(cap, cap, at(u)), cap) << "without the pace the bitrate stays at its cap";
  const double cut = pacer.videoKbps(cap, cap, at(t), paceMs);
  EXPECT_NEAR(cut, cap * 0.5, 1) << "10 ms left for 24: cut to half, the most one step cuts";
  EXPECT_EQ(pacer.videoKbps(cap, cap, at(t + 10), paceMs), cut) << "once per frames written after the last change";
  // Frames of the new bitrate still too slow: 15 000 bytes (12 ms) in 65 ms, 8 ms the client's: cut in proportion.
  videoFrames(pacer, t, 15000, 65);
  const double again = pacer.videoKbps(cap, cap, at(t), paceMs);
  EXPECT_NEAR(again, cut * (budgetMs - 8) / 12, 1);
  // Within the pace, but their bytes not well within what it leaves them (8.8 ms of 13.8): held.
  videoFrames(pacer, t, 11000, 55);
  EXPECT_EQ(pacer.videoKbps(cap, cap, at(t), paceMs), again);
  // Well within it (5 ms): lifted a step at a time, and no longer limited once it reaches what the link allows.
  videoFrames(pacer, t, 8000, 50);
  const double lifted = pacer.videoKbps(cap, cap, at(t), paceMs);
  EXPECT_NEAR(lifted, again * 1.15, 1);
  for (int i = 0; i < 10; ++i) {
    videoFrames(pacer, t, 8000, 50);
    pacer.videoKbps(cap, cap, at(t), paceMs);
  }
  EXPECT_EQ(pacer.videoKbps(cap, cap, at(t), paceMs), cap);
  // Still frames (an exact png after the drag) do not count: only the stream's own frames judge its bitrate.
  for (int i = 0; i < 3; ++i) {
    pacer.sent(20000, at(t));
    pacer.received(at(t + 90));
    t += 100;
  }
  EXPECT_EQ(pacer.videoKbps(cap, cap, at(t), paceMs), cap);
}

// A limit the pace set is lifted by frames well within the pace also where the link's rate is no longer known (its
// readings are older than two seconds, and nothing settled it): a limit that waited for a rate to be read again held
// a stream at its lowest for the rest of a drag whose frames were too alike in size to read it.
TEST(LinkPacer, APaceLimitIsLiftedWhereTheLinksRateIsNoLongerKnown) {
  const double paceMs = LinkPacer::kFramesInFlight * 33.3, cap = 4719;
  LinkPacer pacer;
  pacer.sent(1000, at(0), true);
  pacer.received(at(45));
  double t = 100;
  videoFrames(pacer, t, 30000, 74);  // 29 ms past the quickest, read as 8 Mbit/s
  ASSERT_TRUE(pacer.capacityKbps(at(t)));
  ASSERT_FALSE(pacer.settledLinkKbps());
  const double cut = pacer.videoKbps(cap, cap, at(t), paceMs);
  ASSERT_LT(cut, 0.6 * cap);
  t += 2500;
  videoFrames(pacer, t, 4000, 47);  // 2 ms past the quickest, too close to it in size to read the link
  ASSERT_FALSE(pacer.capacityKbps(at(t)));
  EXPECT_GT(pacer.videoKbps(cap, cap, at(t), paceMs), cut * 1.1);
}

// A client that asks every 60 ms because it waits for the server's frames (a busy two-core Chromium keeping three
// Renders unanswered) is held to a drag's pace of 30 a second: frames of 30 KB taking 74 ms come down as for a client
// asking every 33 ms. Judged by its own 60 ms, they would stay (and came slower still).
TEST(LinkPacer, AClientAskingSlowerThanADragsPaceIsHeldToIt) {
  const double cap = 4719;
  EXPECT_EQ(LinkPacer::paceMsFor(60), LinkPacer::kFramesInFlight * LinkPacer::kDragIntervalMs);
  EXPECT_EQ(LinkPacer::paceMsFor(20), LinkPacer::kFramesInFlight * 20) << "a quicker client keeps its own";
  LinkPacer pacer, byItsOwn;
  double t = 0, u = 0;
  slowLinkMeasured(pacer, t);
  slowLinkMeasured(byItsOwn, u);
  videoFrames(pacer, t, 30000, 74);
  videoFrames(byItsOwn, u, 30000, 74);
  EXPECT_LT(pacer.videoKbps(cap, cap, at(t), LinkPacer::paceMsFor(60)), 0.6 * cap);
  EXPECT_EQ(byItsOwn.videoKbps(cap, cap, at(u), LinkPacer::kFramesInFlight * 60), cap);
}

// Frames late by the client's own delays (a busy browser reports tens of ms late) are not made smaller: 5 000 bytes
// pass a 10 Mbit/s link in 4 ms, and the other 30 ms past the quickest delivery would stay. Nor, where the link's
// rate is unknown, is anything changed: nothing tells the frames' bytes from the rest.
TEST(LinkPacer, TheClientsOwnDelaysOrAnUnknownLinkLeaveTheBitrate) {
  const double paceMs = LinkPacer::kFramesInFlight * 33.3, cap = 4719;
  LinkPacer busy;
  double t = 0;
  slowLinkMeasured(busy, t);
  videoFrames(busy, t, 5000, 45 + 4 + 30);
  EXPECT_EQ(busy.videoKbps(cap, cap, at(t), paceMs), cap);
  // Nor where they leave the bytes only a little of the pace: 10 000 bytes (8 ms) and 12 ms of the client's, past
  // the quickest delivery, where the pace leaves 15 ms: 3 ms left would cut the frames to a third.
  videoFrames(busy, t, 10000, 45 + 8 + 12);
  EXPECT_EQ(busy.videoKbps(cap, cap, at(t), paceMs), cap);
  LinkPacer unknown;  // frames alike in size read nothing
  t = 0;
  unknown.sent(30000, at(t), true);
  unknown.received(at(t + 45));
  t = 100;
  videoFrames(unknown, t, 30000, 80);
  ASSERT_FALSE(unknown.settledLinkKbps());
  EXPECT_EQ(unknown.videoKbps(cap, cap, at(t), paceMs), cap);
}

// A far link's round trip alone (85 ms) is longer than the client's pace allows two frames on their way: smaller
// frames would not arrive sooner, and the bitrate is left as the link allows.
TEST(LinkPacer, AFarLinksRoundTripDoesNotLowerTheBitrate) {
  const double paceMs = LinkPacer::kFramesInFlight * 33.3, cap = 4719;
  LinkPacer pacer;
  double t = 0;
  pacer.sent(30000, at(t), true);
  pacer.received(at(t + 85));
  t = 100;
  videoFrames(pacer, t, 30000, 130, 200);  // alike in size, as a drag's are: they read nothing of the link
  EXPECT_EQ(pacer.videoKbps(cap, cap, at(t), paceMs), cap);
}

}  // namespace
}  // namespace voxbrick::server
