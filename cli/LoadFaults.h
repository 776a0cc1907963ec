// `voxbrick load`'s faulty clients: a table of faults, each a named function with the server's documented answer
// to it, and what the load's clients share.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "cli/ConnectOptions.h"
#include "client/Client.h"

namespace voxbrick::cli {

/// The server's deadlines that faults wait out (its Stats "limits"; the documented defaults if it has none).
struct ServerDeadlines {
  double helloS = 5, readS = 30;
};

/// The options of `voxbrick load`.
struct LoadArgs {
  std::string address, dataset, tf = "grayscale", jsonPath, size = "128x128", corruptDataset;
  std::string encoding = "zstd";  ///< of the good and dragging clients' frames: raw, png, zstd or jpeg
  std::vector<std::string> faults;
  int clients = 4, faultClients = 0, idleSessions = 0;
  double duration = 10, step = 1, dragHz = 0;
  /// Dragging clients: the time budget of `"interactive": true` Renders in ms (0: not interactive), and the encoding
  /// of provisional frames (`provisional_encoding`; empty: the Render's own).
  double interactiveMs = 0;
  std::string provisionalEncoding;
  bool vp9FullChroma = false;  ///< --vp9-444: the drags' scenes say accepts_vp9_444
  /// --drag-cycle DRAG,REST: dragging clients drag DRAG seconds and rest REST, over and over, each from its own phase
  /// (empty: they drag throughout).
  std::vector<double> dragCycle;
  /// The good and dragging clients' scenes carry `"batch": true` (work nobody watches as it happens).
  bool batch = false;
  bool requireClean = false;
  ConnectArgs connect;  ///< TLS and the access token of every well-behaved, dragging and idle client
};

/// The scene the load's clients render: an orbit view at `azimuth`, --tf and --step, `width`×`height`.
std::string sceneJson(const LoadArgs& a, int width, int height, double azimuth);

/// What a fault needs besides its connection: the run's options, the server's deadlines, and the faulty client's
/// random numbers.
struct FaultRun {
  const LoadArgs& a;
  const ServerDeadlines& deadlines;
  std::mt19937& rng;
};

/// How far a fault's connection gets before it misbehaves.
enum class FaultStage {
  Connected,  ///< nothing sent yet
  Greeted,    ///< after Hello
  Opened,     ///< after opening --dataset
  FrameAsked  ///< after asking for a 256² raw frame (256 KiB) of it
};

/// A fault: its name (--faults), what the usage adds to the name, where its connection starts, the server deadline
/// it waits out (beside the usual 10 s), and what it does; returns whether the server answered as documented.
struct Fault {
  const char* name;
  const char* usage;
  FaultStage stage;
  double ServerDeadlines::*waits;
  bool (*run)(client::Client& c, FaultRun& r);
};

/// The faults' names, in the order faulty clients take them in turn.
std::vector<std::string> faultNames();

/// "disconnect, garbage, ..., silent (never speaks; ...), ...": each fault with what the usage adds to its name.
std::string faultUsage();

/// The faults --faults names, or all of them ("corrupt" only with a damaged dataset to render); throws if
/// "corrupt" is asked for without one.
std::vector<const Fault*> faultsToRun(const LoadArgs& a);

/// One fault: its connection brought to the fault's stage, then the fault; whether the server answered as
/// documented.
bool runFault(const Fault& f, const std::string& host, int port, FaultRun& r);

}  // namespace voxbrick::cli
