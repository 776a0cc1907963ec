// The faults of `voxbrick load`: each misbehaves in one way and checks the server's documented answer.
#include "cli/LoadFaults.h"
#include "render/engine/Datasets.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

namespace voxbrick::cli {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

std::string sceneJson(const LoadArgs& a, int width, int height, double azimuth) {
  return json{{"camera", {{"orbit", {azimuth, 20, 2.5}}}},
              {"size", {width, height}},
              {"transfer_function", a.tf},
              {"step", a.step}}
      .dump();
}

namespace {

/// Reads replies until the server closes the connection (or `limit` passes); returns the error codes seen.
std::vector<proto::ErrorCode> drain(client::Client& c, Clock::duration limit) {
  std::vector<proto::ErrorCode> codes;
  const auto end = Clock::now() + limit;
  try {
    while (Clock::now() < end) {
      auto [id, m] = c.receive();
      if (auto* e = std::get_if<proto::Error>(&m)) codes.push_back(e->code);
    }
  } catch (const std::exception&) {
  }
  return codes;
}

std::chrono::milliseconds millis(double seconds) { return std::chrono::milliseconds(int64_t(seconds * 1000)); }

bool hasCode(const std::vector<proto::ErrorCode>& codes, proto::ErrorCode code) {
  return std::find(codes.begin(), codes.end(), code) != codes.end();
}

/// Connects and says nothing: closed at the Hello deadline with Timeout, or sooner with LimitExceeded when it gave
/// way to newer connections.
bool silentFault(client::Client& c, FaultRun& r) {
  const auto start = Clock::now();
  const std::vector<proto::ErrorCode> codes = drain(c, millis(r.deadlines.helloS + 5));
  const bool inTime = Clock::now() - start < millis(r.deadlines.helloS + 2);
  return inTime && codes.size() == 1 &&
         (codes[0] == proto::ErrorCode::Timeout || codes[0] == proto::ErrorCode::LimitExceeded);
}

/// Random bytes that never start with the magic: answered BadMagic.
bool garbageFault(client::Client& c, FaultRun& r) {
  std::vector<uint8_t> bytes(64);
  for (uint8_t& b : bytes) b = uint8_t(r.rng());
  bytes[0] = 'G';  // never the magic
  c.sendBytes(bytes);
  return hasCode(drain(c, std::chrono::seconds(5)), proto::ErrorCode::BadMagic);
}

/// A header announcing a 4 GiB body: answered TooLarge.
bool hugeFault(client::Client& c, FaultRun&) {
  proto::Header h;
  h.type = proto::MessageType::Render;
  h.bodyBytes = 0xFFFFFFFFu;
  const auto head = proto::encodeHeader(h);
  c.sendBytes(std::vector<uint8_t>(head.begin(), head.end()));
  return hasCode(drain(c, std::chrono::seconds(5)), proto::ErrorCode::TooLarge);
}

/// A message one byte at a time, 16 bytes over twice the read timeout: closed with Timeout within the read timeout
/// of its first byte, before the header is complete.
bool trickleFault(client::Client& c, FaultRun& r) {
  const std::vector<uint8_t> bytes = proto::encode(proto::ListDatasets{}, 7);
  const auto interval = millis(r.deadlines.readS / 8);
  const auto start = Clock::now();
  try {
    for (uint8_t byte : bytes) {
      c.sendBytes({byte});
      std::this_thread::sleep_for(interval);
    }
  } catch (const client::ConnectionError&) {  // the server closed it: what is expected
  }
  const bool inTime = Clock::now() - start < millis(r.deadlines.readS + 1) + 2 * interval;
  return inTime && drain(c, std::chrono::seconds(5)) == std::vector<proto::ErrorCode>{proto::ErrorCode::Timeout};
}

/// A Render one byte short of its declared string: answered Malformed, and the session goes on.
bool malformedFault(client::Client& c, FaultRun&) {
  std::vector<uint8_t> bytes = proto::encode(proto::RenderRequest{proto::Encoding::Png, "{}"}, 99);
  bytes.pop_back();                                         // one byte short of its declared string
  bytes[12] = uint8_t(bytes.size() - proto::kHeaderBytes);  // body length matches what is sent
  c.sendBytes(bytes);
  auto [id, m] = c.receive();
  const auto* e = std::get_if<proto::Error>(&m);
  const bool ok = e && e->code == proto::ErrorCode::Malformed;
  c.listDatasets();  // the session goes on
  c.goodbye();
  return ok;
}

/// A damaged dataset: every Render of it is answered Internal, the first by the failed frame, the later ones at once
/// (quarantined); the session goes on.
bool corruptFault(client::Client& c, FaultRun& r) {
  c.openDataset(r.a.corruptDataset);
  bool ok = false;
  try {
    c.render(sceneJson(r.a, 64, 64, double(r.rng() % 360)));
  } catch (const client::ServerError& e) {
    ok = e.code() == proto::ErrorCode::Internal && std::string(e.what()).find("quarantined") != std::string::npos;
  }
  c.listDatasets();
  c.goodbye();
  return ok;
}

/// A heavy render (256², a step 50 times finer than the good clients'), left after a fifth of a second: the server
/// gives it up part way (Stats renders.cancelled) instead of drawing it for nobody.
bool abandonFault(client::Client& c, FaultRun& r) {
  json heavy = json::parse(sceneJson(r.a, 256, 256, double(r.rng() % 360)));
  heavy["step"] = std::max(0.001, r.a.step / 50);
  c.send(proto::RenderRequest{proto::Encoding::Png, heavy.dump()});
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  c.close();
  return true;
}

/// Leaves before the frame asked for arrives.
bool disconnectFault(client::Client& c, FaultRun&) {
  c.close();
  return true;
}

/// Floods requests of small messages with large replies (OpenDataset: about 40 bytes in, kilobytes out), reads
/// nothing for a second, then takes every reply: the server stops reading while they wait, and loses none.
bool unreadFault(client::Client& c, FaultRun& r) {
  const std::vector<uint8_t> one = proto::encode(proto::OpenDataset{r.a.dataset}, 0);
  // Within what the socket buffers hold, so that sending never waits on a server that stopped reading.
  const uint32_t n = uint32_t(std::clamp<size_t>((48u << 10) / one.size(), 1, 2000));
  std::vector<uint8_t> flood;
  for (uint32_t i = 0; i < n; ++i) {
    const std::vector<uint8_t> bytes = proto::encode(proto::OpenDataset{r.a.dataset}, 1000 + i);
    flood.insert(flood.end(), bytes.begin(), bytes.end());
  }
  c.receive();  // the frame asked for
  c.sendBytes(flood);
  std::this_thread::sleep_for(std::chrono::seconds(1));
  bool ok = true;
  for (uint32_t i = 0; i < n && ok; ++i) {
    auto [id, m] = c.receive();
    ok = id == 1000 + i && std::holds_alternative<proto::DatasetInfo>(m);
  }
  c.goodbye();
  return ok;
}

/// Takes the frame 2 KiB at a time, 100 times a second at most, for a second, then leaves.
bool slowFault(client::Client& c, FaultRun&) {
  const auto end = Clock::now() + std::chrono::seconds(1);
  while (Clock::now() < end && !c.receiveBytes(2048).empty())
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  c.close();
  return true;
}

/// What faulty clients do, in turn.
const std::vector<Fault> kFaults = {
    {"disconnect", "", FaultStage::FrameAsked, nullptr, disconnectFault},
    {"garbage", "", FaultStage::Connected, nullptr, garbageFault},
    {"huge", "", FaultStage::Connected, nullptr, hugeFault},
    {"malformed", "", FaultStage::Greeted, nullptr, malformedFault},
    {"slow", "", FaultStage::FrameAsked, nullptr, slowFault},
    {"silent", "never speaks; lasts the server's Hello timeout", FaultStage::Connected, &ServerDeadlines::helloS,
     silentFault},
    {"trickle", "a message a byte at a time; lasts its read timeout", FaultStage::Greeted, &ServerDeadlines::readS,
     trickleFault},
    {"unread", "floods requests, reads nothing for a second", FaultStage::FrameAsked, nullptr, unreadFault},
    {"abandon", "a heavy render, left after 0.2 s", FaultStage::Opened, nullptr, abandonFault},
    {"corrupt", "renders --corrupt-dataset", FaultStage::Greeted, nullptr, corruptFault},
};

const Fault& faultNamed(const std::string& name) {
  for (const Fault& f : kFaults)
    if (name == f.name) return f;
  throw std::invalid_argument("unknown fault '" + name + "'");
}

}  // namespace

std::vector<std::string> faultNames() {
  std::vector<std::string> names;
  for (const Fault& f : kFaults) names.push_back(f.name);
  return names;
}

std::string faultUsage() {
  std::string text;
  for (const Fault& f : kFaults)
    text += std::string(text.empty() ? "" : ", ") + f.name + (*f.usage ? std::string(" (") + f.usage + ")" : "");
  return text;
}

std::vector<const Fault*> faultsToRun(const LoadArgs& a) {
  std::vector<const Fault*> faults;
  for (const std::string& name : a.faults) faults.push_back(&faultNamed(name));
  if (a.faults.empty())
    for (const Fault& f : kFaults)
      if (std::string(f.name) != "corrupt" || !a.corruptDataset.empty()) faults.push_back(&f);
  if (a.corruptDataset.empty() &&
      std::any_of(faults.begin(), faults.end(), [](const Fault* f) { return std::string(f->name) == "corrupt"; }))
    throw std::runtime_error("the 'corrupt' fault needs --corrupt-dataset NAME (a damaged dataset of the server)");
  return faults;
}

bool runFault(const Fault& f, const std::string& host, int port, FaultRun& r) {
  client::Client c(host, port, std::chrono::seconds(10) + millis(f.waits ? r.deadlines.*f.waits : 0));
  if (f.stage >= FaultStage::Greeted) c.hello("voxbrick-load-fault");
  if (f.stage >= FaultStage::Opened) c.openDataset(r.a.dataset);
  if (f.stage >= FaultStage::FrameAsked)
    c.send(proto::RenderRequest{proto::Encoding::RawRgba8, sceneJson(r.a, 256, 256, double(r.rng() % 360))});
  return f.run(c, r);
}

}  // namespace voxbrick::cli
