// A slow link between a client and the server, on one machine: a TCP relay that passes each direction's bytes
// through a bottleneck of RATE bit/s with DELAY ms one way (a round trip of 2 x DELAY) and a queue of QUEUE ms of
// bytes in front of it (a router's buffer: when full the relay stops reading, and TCP's own back-pressure takes
// over). The same link as bench/link_relay.mjs, for machines without Node (the GPU kit carries this one).
//
//   bench_link_relay --target PORT [--listen 0] [--port-file F] [--mbit 10] [--delay-ms 20] [--queue-ms 200]
//
// Prints "relay: listening on PORT" once ready; runs until killed.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <deque>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <boost/asio.hpp>

namespace {

namespace asio = boost::asio;
using asio::ip::tcp;
using Clock = std::chrono::steady_clock;

struct Link {
  double bytesPerSecond = 10e6 / 8;
  Clock::duration delay = std::chrono::milliseconds(20);
  size_t queueBytes = 250000;
};

/// One direction: what `from` sends reaches `to` once the bottleneck has carried it, plus the delay. Reads stop
/// while more than the queue's bytes wait, and go on below half of it.
class Pipe : public std::enable_shared_from_this<Pipe> {
 public:
  Pipe(std::shared_ptr<tcp::socket> from, std::shared_ptr<tcp::socket> to, const Link& link)
      : mFrom(std::move(from)), mTo(std::move(to)), mLink(link), mTimer(mTo->get_executor()) {}

  void start() { read(); }

 private:
  struct Chunk {
    std::vector<char> bytes;
    Clock::time_point at;  ///< when it reaches the far end
  };

  void read() {
    if (mReading || mDone || mQueued > mLink.queueBytes) return;
    mReading = true;
    auto self = shared_from_this();
    mFrom->async_read_some(asio::buffer(mBuffer), [self](boost::system::error_code ec, size_t n) {
      self->mReading = false;
      if (ec) return self->finish();
      const auto now = Clock::now();
      const auto carry = std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(double(n) / self->mLink.bytesPerSecond));
      self->mLinkFreeAt = std::max(now, self->mLinkFreeAt) + carry;
      self->mChunks.push_back({std::vector<char>(self->mBuffer.begin(), self->mBuffer.begin() + long(n)),
                               self->mLinkFreeAt + self->mLink.delay});
      self->mQueued += n;
      self->write();
      self->read();
    });
  }

  void write() {
    if (mWriting || mChunks.empty()) {
      if (!mWriting && mChunks.empty() && mDone) closeTo();
      return;
    }
    mWriting = true;
    auto self = shared_from_this();
    mTimer.expires_at(mChunks.front().at);
    mTimer.async_wait([self](boost::system::error_code) {
      asio::async_write(*self->mTo, asio::buffer(self->mChunks.front().bytes),
                        [self](boost::system::error_code ec, size_t) {
                          self->mWriting = false;
                          if (ec) {
                            self->mChunks.clear();
                            self->mDone = true;
                            boost::system::error_code ignored;
                            self->mFrom->close(ignored);
                            return;
                          }
                          self->mQueued -= self->mChunks.front().bytes.size();
                          self->mChunks.pop_front();
                          if (self->mQueued <= self->mLink.queueBytes / 2) self->read();
                          self->write();
                        });
    });
  }

  /// The sender closed: what is on the link still arrives, then the far end is told.
  void finish() {
    mDone = true;
    write();
  }
  void closeTo() {
    boost::system::error_code ignored;
    mTo->shutdown(tcp::socket::shutdown_send, ignored);
  }

  std::shared_ptr<tcp::socket> mFrom, mTo;
  Link mLink;
  asio::steady_timer mTimer;
  std::array<char, 65536> mBuffer{};
  std::deque<Chunk> mChunks;
  Clock::time_point mLinkFreeAt{};
  size_t mQueued = 0;
  bool mReading = false, mWriting = false, mDone = false;
};

void accept(tcp::acceptor& acceptor, uint16_t target, const Link& link) {
  acceptor.async_accept([&acceptor, target, link](boost::system::error_code ec, tcp::socket client) {
    if (!ec) {
      auto near = std::make_shared<tcp::socket>(std::move(client));
      auto far = std::make_shared<tcp::socket>(acceptor.get_executor());
      far->async_connect(tcp::endpoint(asio::ip::address_v4::loopback(), target),
                         [near, far, link](boost::system::error_code connectError) {
                           if (connectError) {
                             std::fprintf(stderr, "relay: the target refused: %s\n", connectError.message().c_str());
                             return;
                           }
                           near->set_option(tcp::no_delay(true));
                           far->set_option(tcp::no_delay(true));
                           std::make_shared<Pipe>(near, far, link)->start();
                           std::make_shared<Pipe>(far, near, link)->start();
                         });
    }
    accept(acceptor, target, link);
  });
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"bench_link_relay: a TCP relay through a slow link (a rate, a one-way delay, a queue)"};
  int listen = 0, target = 0;
  double mbit = 10, delayMs = 20, queueMs = 200;
  std::string portFile;
  app.add_option("--target", target, "the port relayed to, on 127.0.0.1")->required()->check(CLI::Range(1, 65535));
  app.add_option("--listen", listen, "the port to listen on, on 127.0.0.1 (0: any free one)")->check(CLI::Range(0, 65535));
  app.add_option("--port-file", portFile, "a file to write the port listened on to");
  app.add_option("--mbit", mbit, "the link's rate each way, Mbit/s")->check(CLI::Range(0.01, 100000.0));
  app.add_option("--delay-ms", delayMs, "one way's delay, ms")->check(CLI::Range(0.0, 10000.0));
  app.add_option("--queue-ms", queueMs, "the queue in front of the link, in ms of its rate")->check(CLI::Range(1.0, 10000.0));
  CLI11_PARSE(app, argc, argv);
  Link link;
  link.bytesPerSecond = mbit * 1e6 / 8;
  link.delay = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(delayMs));
  link.queueBytes = std::max<size_t>(16384, size_t(queueMs / 1000 * link.bytesPerSecond));
  asio::io_context io;
  tcp::acceptor acceptor(io, tcp::endpoint(asio::ip::address_v4::loopback(), uint16_t(listen)));
  const uint16_t port = acceptor.local_endpoint().port();
  if (!portFile.empty()) std::ofstream(portFile) << port << "\n";
  std::printf("relay: listening on %u\n", unsigned(port));
  std::fflush(stdout);
  accept(acceptor, uint16_t(target), link);
  io.run();
  return 0;
}
