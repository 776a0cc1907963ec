// `voxbrick prep INPUT -o STORE`: ingest any supported volume into a brick store.
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "brickstore/format/Errors.h"
#include "brickstore/format/InputErrors.h"
#include "brickstore/ingest/Sources.h"
#include "brickstore/ingest/dicomweb/HttpClient.h"
#include "brickstore/prep/StoreWriter.h"
#include "cli/Commands.h"
#include "cli/Progress.h"
#include "common/EnumNames.h"
#include "mesh/MeshPrep.h"

namespace voxbrick::cli {
namespace {

std::atomic<bool> gInterrupted{false};
extern "C" void onInterrupt(int) { gInterrupted = true; }

struct PrepArgs {
  std::string input, output, dims, type, spacing, endian = "little", grid, nonFinite = "background";
  std::string quantise, quantiseRange, field, series;
  std::vector<std::string> inputs;  ///< the input; several for the files of a DICOM series or a TIFF stack
  int64_t headerBytes = 0, time = 0, channel = 0;
  uint32_t tetsPerChunk = mesh::MeshStoreOptions{}.tetsPerChunk;
  double background = 0;
  bool quiet = false;
  bool timings = false;
  std::string vdbCompression = "auto";
  store::PrepOptions options;
  store::DicomWebOptions dicomWeb;
};

/// `prep MESH -o STORE` (mesh::prepMeshStore): what was read, dropped and repaired, and what the store holds.
void runMeshPrep(const PrepArgs& a) {
  mesh::MeshPrepOptions options;
  options.field = a.field;
  options.store.tetsPerChunk = a.tetsPerChunk;
  options.store.zstdLevel = a.options.zstdLevel;
  options.store.overwrite = a.options.overwrite;
  const mesh::MeshPrepSummary summary =
      mesh::prepMeshStore(a.input, a.output, options, [&](const mesh::MeshPrepProgress& p) {
        if (p.stage == "read" && !a.quiet)
          std::fprintf(stderr, "prep: %s: %zu points, %zu tets, field '%s' -> %s\n", a.input.c_str(),
                       p.mesh->points.size(), p.mesh->tets.size(), p.mesh->field.c_str(), a.output.c_str());
        if (p.stage == "validated" && !p.mesh->dropped.empty())
          std::fprintf(stderr,
                       "prep: %s: dropped %s: only tetrahedra are volume cells (points, lines, surfaces are not)\n",
                       a.input.c_str(), p.mesh->dropped.c_str());
        if (gInterrupted) throw store::StoreError("interrupted; nothing was written");
      });
  const mesh::MeshRepairs& repairs = summary.repairs;
  const mesh::MeshStoreInfo& info = summary.info;
  if (repairs.flipped + repairs.removedDegenerate + repairs.unreferencedVertices > 0)
    std::fprintf(stderr,
                 "prep: repaired: %zu inverted tets flipped, %zu degenerate tets removed, %zu points no tet uses\n",
                 repairs.flipped, repairs.removedDegenerate, repairs.unreferencedVertices);
  std::printf(
      "prep: wrote mesh store %s: %llu tets, %llu points, %llu boundary faces, field '%s' in [%g, %g], "
      "%u chunks\n",
      a.output.c_str(), (unsigned long long)info.tetCount, (unsigned long long)info.vertexCount,
      (unsigned long long)info.boundaryFaceCount, info.field.c_str(), info.scalarMin, info.scalarMax, info.chunkCount);
  std::printf("prep: %s raw, %s stored (%.2fx, %.1f bytes a tet), %.2f s\n", formatBytes(double(info.bytesRaw)).c_str(),
              formatBytes(double(info.bytesStored)).c_str(),
              info.bytesStored > 0 ? double(info.bytesRaw) / double(info.bytesStored) : 0.0,
              info.tetCount > 0 ? double(info.bytesStored) / double(info.tetCount) : 0.0, summary.seconds);
}

/// How to read a volume input: --dims and --spacing (checked), the raw file's layout, the grid and the series.
store::SourceOptions sourceOptions(const PrepArgs& a) {
  store::SourceOptions so;
  if (!a.dims.empty()) {
    int64_t d[3];
    parseTriple(a.dims, "--dims", d, "256,256,128");
    so.dims = {d[0], d[1], d[2]};
  }
  if (!a.spacing.empty()) {
    double s[3];
    parseTriple(a.spacing, "--spacing", s, "0.5,0.5,1.25");
    so.spacing = {s[0], s[1], s[2]};
    so.spacingGiven = true;
    for (double v : s)
      if (!store::spacingInRange(v)) throw store::InputError("--spacing values must be in [1e-12, 1e12]");
  }
  so.type = a.type;
  so.bigEndian = a.endian == "big";
  so.headerBytes = a.headerBytes;
  so.gridName = a.grid;
  so.time = a.time;
  so.channel = a.channel;
  so.seriesUid = a.series;
  so.memoryBudgetMB = a.options.memoryBudgetMB;
  so.dicomWeb = a.dicomWeb;
  // A DICOMweb series is fetched beside the store it becomes: on its disk, not in a temporary directory that may be
  // memory (tmpfs) or small.
  const std::filesystem::path output = std::filesystem::absolute(a.output);
  so.dicomWeb.downloadDir = output.parent_path().string();
  so.dicomWeb.cancelled = [] { return gInterrupted.load(); };
  return so;
}

/// --quantise's mapping: the range --quantise-range gives, or the input's exact range, which takes a pass of its own
/// through a second reader of the same input.
store::Quantisation quantisation(const PrepArgs& a, const store::SourceOptions& so, const store::VolumeInfo& info,
                                 Progress& progress) {
  store::Quantisation q;
  q.type = store::parseQuantiseType(a.quantise);
  if (!a.quantiseRange.empty()) {
    store::parseQuantiseRange(a.quantiseRange, q);
  } else {
    auto first = store::openSource(a.inputs, so);
    const double background = a.options.haveBackground ? a.options.background : info.background;
    auto onSlices = [&](int64_t done, int64_t total) {
      if (gInterrupted) throw store::StoreError("interrupted; nothing was written");
      progress.update("value range", done, total, 0);
    };
    const store::Level0Stats range = store::scanLevel0(*first, background, a.options.nonFinite, onSlices);
    q.lo = range.min;
    q.hi = range.max > range.min ? range.max : range.min + 1;  // a constant volume: everything stored as 0
  }
  q.validate();
  if (!a.quiet) std::fprintf(stderr, "prep: quantising [%.9g, %.9g] to %s\n", q.lo, q.hi, a.quantise.c_str());
  return q;
}

/// What the store holds and what writing it took.
void printPrepSummary(const PrepArgs& a, const store::PrepSummary& summary) {
  const store::StoreMeta& m = summary.meta;
  int64_t total = 0, stored = 0;
  for (const auto& l : m.levels) total += l.bricksTotal(), stored += l.bricksStored;
  if (m.quantisation)
    std::fprintf(stderr, "prep: quantised [%.9g, %.9g] to %s (a step is %.3g); %lld voxels outside the range clamped\n",
                 m.quantisation->lo, m.quantisation->hi, std::string(store::valueTypeName(m.type)).c_str(),
                 (m.quantisation->hi - m.quantisation->lo) / m.quantisation->steps(),
                 static_cast<long long>(m.quantisationClamped));
  if (m.nonFiniteReplaced > 0)
    std::fprintf(stderr, "prep: non-finite voxels: %lld NaN/Inf values replaced by the background %g\n",
                 static_cast<long long>(m.nonFiniteReplaced), m.background);
  std::printf("prep: wrote %s: %lldx%lldx%lld %s, %zu levels, %lld of %lld bricks stored\n", a.output.c_str(),
              static_cast<long long>(m.dims.x), static_cast<long long>(m.dims.y), static_cast<long long>(m.dims.z),
              std::string(store::valueTypeName(m.type)).c_str(), m.levels.size(), static_cast<long long>(stored),
              static_cast<long long>(total));
  std::printf("prep: %s in, %s stored (%.2fx), %s vdb, %.2f s, %.1f MB/s in, peak RSS %s\n",
              formatBytes(double(summary.bytesIn)).c_str(), formatBytes(double(m.bytesStored)).c_str(),
              m.bytesStored > 0 ? double(m.bytesRaw) / double(m.bytesStored) : 0.0,
              formatBytes(double(m.bytesVdb)).c_str(), summary.seconds,
              summary.seconds > 0 ? summary.bytesIn / 1e6 / summary.seconds : 0.0,
              formatBytes(double(summary.peakRssBytes)).c_str());
  if (!a.timings) return;
  std::printf("prep: %.2f s wall, %.2f s CPU (user + system, all threads)\n", summary.seconds, summary.cpuSeconds);
  for (const store::PhaseTime& p : summary.phases)
    std::printf("prep:   %-45s %7.2f s wall %7.2f s CPU\n", p.name.c_str(), p.wallSeconds, p.cpuSeconds);
}

void runPrep(PrepArgs& a, CLI::App& cmd) {
  growHeapInLargeSteps();
  // Installed first, so that an early Ctrl-C also ends in the clean-up path rather than a killed process.
  std::signal(SIGINT, onInterrupt);
  std::signal(SIGTERM, onInterrupt);
  store::SourceOptions so = sourceOptions(a);
  a.input = a.inputs.front();
  if (a.inputs.size() > 1) {
    for (const std::string& in : a.inputs)
      if (mesh::isMeshInput(in)) throw store::InputError(in + ": a mesh is prepped on its own (one input)");
  }
  if (mesh::isMeshInput(a.input)) return runMeshPrep(a);
  if (!a.field.empty()) throw store::InputError("--field names a mesh's scalar; '" + a.input + "' is not a mesh");
  a.options.haveBackground = cmd.count("--background") > 0;
  a.options.vdbCompression =
      common::parseName<store::VdbCompression, store::InputError>(a.vdbCompression, "compression", "--vdb-compression");
  a.options.background = a.background;
  a.options.nonFinite =
      common::parseName<store::NonFinitePolicy, store::InputError>(a.nonFinite, "policy", "--nonfinite");

  Progress progress(a.quiet);
  so.dicomWeb.onFetched = [&](int64_t done, int64_t total, uint64_t bytes) {
    progress.update("fetch", done, total, int64_t(bytes));
  };
  auto source = store::openSource(a.inputs, so);
  so.dicomWeb.onFetched = nullptr;
  const store::VolumeInfo& info = source->info();
  if (!a.quiet)
    std::fprintf(stderr, "prep: %s -> %s (brick %d, zstd %d)\n", info.description.c_str(), a.output.c_str(),
                 a.options.brickSize, a.options.zstdLevel);

  if (gInterrupted) throw store::StoreError("interrupted; nothing was written");
  if (!a.quantiseRange.empty() && a.quantise.empty()) throw store::InputError("--quantise-range needs --quantise");
  if (!a.quantise.empty()) a.options.quantise = quantisation(a, so, info, progress);
  auto summary = store::prepStore(*source, a.output, a.options, [&](const store::PrepProgress& p) {
    if (gInterrupted) throw store::StoreError("interrupted; nothing was written");
    progress.update(p.stage, p.done, p.total, p.stage == "level 0" ? p.bytesIn : 0);
  });
  progress.finish();
  printPrepSummary(a, summary);
}

}  // namespace

void addPrepCommand(CLI::App& app) {
  auto args = std::make_shared<PrepArgs>();
  CLI::App* cmd =
      app.add_subcommand("prep", "Convert a volume into a brick store, or a tetrahedral mesh into a mesh store");
  cmd->add_option("input", args->inputs,
                  "raw file, .nrrd/.nhdr, .nii/.nii.gz, .vdb, or synthetic:NAME[,key=value...] (marschner-lobb, "
                  "shells, blobs, sparse, hdr); a DICOM series (a directory, one of its files, or its files / a "
                  "quoted glob); a DICOMweb series, dicomweb[s]://HOST[:PORT]/PATH/studies/UID/series/UID (or a "
                  "study, .../studies/UID); a TIFF stack (one multi-page .tif, or a directory / files / quoted glob "
                  "of single-page .tif files, z in natural name order); a tetrahedral mesh: .vtk (legacy "
                  "unstructured grid), .msh (gmsh 2 or 4), or synthetic-mesh:box|ball[,n=N][,field=blobs|linear]")
      ->required();
  cmd->add_option("-o,--output", args->output, "store directory to create")->required();
  cmd->add_option("--dims", args->dims, "raw: X,Y,Z voxels");
  cmd->add_option("--type", args->type, "raw: u8, u16, i16 or f32");
  cmd->add_option("--spacing", args->spacing, "voxel spacing a,b,c (default: the file's own; 1,1,1 for raw)");
  cmd->add_option("--endian", args->endian, "raw: byte order")
      ->capture_default_str()
      ->check(CLI::IsMember({"little", "big"}));
  cmd->add_option("--header-bytes", args->headerBytes, "raw: bytes to skip before the voxels")
      ->capture_default_str()
      ->check(between(0, 1e15, "bytes"));
  addZarrIndexOptions(cmd, args->time, args->channel);
  cmd->add_option("--grid", args->grid, "vdb: name of the float grid (default: the first)");
  cmd->add_option("--series", args->series, "dicom: the SeriesInstanceUID to read when the input holds several series");
  cmd->add_option("--ca", args->dicomWeb.caFile,
                  "dicomwebs: PEM file of the certificates to trust (default: the system's store)");
  cmd->add_option("--auth-file", args->dicomWeb.authFile,
                  std::string("dicomweb: file whose first line is 'basic USER:PASSWORD' or 'bearer TOKEN' (default: "
                              "the variable ") +
                      store::kDicomWebAuthVariable + ", else no credentials)");
  cmd->add_option("--http-timeout", args->dicomWeb.timeoutSeconds,
                  "dicomweb: seconds to connect, and the longest a transfer may receive nothing")
      ->capture_default_str()
      ->check(between(1, 3600, "seconds"));
  cmd->add_option("--retries", args->dicomWeb.retries,
                  "dicomweb: further attempts of a request answered 5xx, refused, timed out or cut (0.5 s, 1 s, 2 s "
                  "... apart)")
      ->capture_default_str()
      ->check(between(0, 10));
  cmd->add_option("--connections", args->dicomWeb.connections, "dicomweb: instances fetched at a time")
      ->capture_default_str()
      ->check(between(1, 32));
  cmd->add_option("--max-rate", args->dicomWeb.maxMBPerSecond,
                  "dicomweb: MB/s that all connections together may receive (0: no limit)")
      ->capture_default_str()
      ->check(between(0, 1e6, "MB/s"));
  cmd->add_option("--brick", args->options.brickSize, "brick size B (power of two, 8..256)")
      ->capture_default_str()
      ->check(between(8, 256, "voxels"));
  cmd->add_option("--zstd-level", args->options.zstdLevel, "zstd compression level")
      ->capture_default_str()
      ->check(between(-7, 22));
  cmd->add_option("--memory", args->options.memoryBudgetMB, "memory bound in MB for slabs and VDB chunks")
      ->capture_default_str()
      ->check(between(128, 1 << 20, "MB"));
  cmd->add_option("--background", args->background, "value of empty space (default: the source's, 0 for files)")
      ->check(between(-3.4e38, 3.4e38));
  cmd->add_option("--nonfinite", args->nonFinite,
                  "NaN/Inf voxels: 'background' replaces and counts them, 'error' refuses the input")
      ->check(CLI::IsMember(common::enumNameList<store::NonFinitePolicy>()))
      ->capture_default_str();
  cmd->add_flag("!--no-vdb", args->options.writeVdb, "do not write the canonical OpenVDB grid");
  cmd->add_option("--vdb-chunk", args->options.vdbChunkSlices, "z-slices per OpenVDB file (0: as --memory allows)")
      ->capture_default_str()
      ->check(between(0, 1 << 20, "slices"));
  cmd->add_option("--vdb-compression", args->vdbCompression,
                  "OpenVDB leaf values: 'blosc' (LZ4, OpenVDB's default), 'none' (larger files, far less CPU) or "
                  "'auto' (blosc for a chunk where it halves the bytes)")
      ->check(CLI::IsMember(common::enumNameList<store::VdbCompression>()))
      ->capture_default_str();
  cmd->add_option("--quantise", args->quantise,
                  "store u8 or u16: the value range mapped linearly onto 0..255 or 0..65535");
  cmd->add_option("--quantise-range", args->quantiseRange,
                  "lo,hi: the values stored as 0 and as the largest integer (default: the input's exact range, "
                  "found by a first pass over the input)");
  cmd->add_option("--field", args->field, "mesh: the point scalar to keep (default: the first)");
  cmd->add_option("--tets-per-chunk", args->tetsPerChunk, "mesh: tetrahedra per store chunk")
      ->capture_default_str()
      ->check(between(1, mesh::kMaxTetsPerChunk, "tets"));
  cmd->add_flag("--force", args->options.overwrite, "replace an existing store (once the new one is complete)");
  cmd->add_option("--threads", args->options.threads, "worker threads (0: all cores)")
      ->capture_default_str()
      ->check(between(0, 1024));
  cmd->add_flag("-q,--quiet", args->quiet, "no progress output");
  cmd->add_flag("--timings", args->timings, "print the wall and CPU time of each phase of the prep");
  cmd->callback([args, cmd] {
    // An error from reading the input names it, whatever raised it; the output's own errors name the output.
    std::vector<std::string> named = args->inputs;
    named.push_back(args->output);
    store::namingInput(named, [&] { runPrep(*args, *cmd); });
  });
}

}  // namespace voxbrick::cli
