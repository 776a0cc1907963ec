// Quality tables (quality.json) and the choice of a setting for a target.
#include "render/core/Quality.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "image/ImageFile.h"
#include "render/core/RenderErrors.h"
#include "render/core/Scene.h"

namespace voxbrick::render {
namespace {

using nlohmann::json;

std::string format(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.10g", v);
  return text;
}

/// A setting's figures over the entries chosen for a scene (the worst where several entries share it).
struct Candidate {
  QualitySetting setting;
  double ms = 0, psnr = 0;
};

std::vector<Candidate> candidates(const std::vector<const QualityEntry*>& entries, double timeScale) {
  std::vector<Candidate> out;
  for (const QualityEntry* e : entries) {
    auto it = std::find_if(out.begin(), out.end(), [&](const Candidate& c) { return c.setting == e->setting; });
    if (it == out.end()) {
      out.push_back({e->setting, e->msMedian * timeScale, e->psnrMin});
    } else {
      it->ms = std::max(it->ms, e->msMedian * timeScale);
      it->psnr = std::min(it->psnr, e->psnrMin);
    }
  }
  return out;
}

template <typename T>
T get(const json& j, const char* key, const std::string& what) {
  if (!j.is_object() || !j.contains(key)) throw RenderInputError(what + ": missing key '" + key + "'");
  try {
    return j.at(key).get<T>();
  } catch (const json::exception&) {
    throw RenderInputError(what + ": key '" + key + "' has the wrong type");
  }
}

}  // namespace

QualityTarget QualityTarget::parse(const std::string& text, const std::string& what) {
  const size_t colon = text.find(':');
  const std::string kind = text.substr(0, colon), number = colon == std::string::npos ? "" : text.substr(colon + 1);
  char* end = nullptr;
  const double v = number.empty() ? NAN : std::strtod(number.c_str(), &end);
  const bool parsed = !number.empty() && end == number.c_str() + number.size() && std::isfinite(v);
  QualityTarget t;
  if (kind == "psnr" && parsed && v >= kMinPsnr && v <= kMaxPsnr) {
    t.kind = Kind::Psnr;
  } else if (kind == "ms" && parsed && v >= kMinMs && v <= kMaxMs) {
    t.kind = Kind::Ms;
  } else {
    throw RenderInputError(what + " '" + text + "': expected psnr:DB (worst-view PSNR against the reference, " +
                           format(kMinPsnr) + " to " + format(kMaxPsnr) + ") or ms:N (median frame time, " +
                           format(kMinMs) + " to " + format(kMaxMs) + ")");
  }
  t.value = v;
  return t;
}

std::string QualityTarget::text() const { return (kind == Kind::Psnr ? "psnr:" : "ms:") + format(value); }

void QualitySetting::applyTo(GridTechnique& technique) const {
  technique.step = step;
  technique.raycast = raycast;
  technique.slab = slab;
  technique.ert = ert;
  technique.preIntegration = preIntegration;
  technique.subBlock = subBlock;
  technique.lod = lod;
}

std::string QualitySetting::label() const {
  std::string s = "step " + format(step) + (raycast ? ", raycast" : slab == 0 ? ", slicing" : ", slab " + format(slab));
  if (ert > 0) s += ", ert " + format(ert);
  if (preIntegration) s += ", pre-int";
  if (subBlock > 0) s += ", sub-block " + format(subBlock);
  if (lod > 0) s += ", lod " + format(lod);
  return s;
}

json QualityChoice::toJson() const {
  return {{"target", target.text()},
          {"setting", setting.label()},
          {"expected_psnr", expectedPsnr},
          {"expected_ms", expectedMs},
          {"met", met},
          {"basis", basis}};
}

std::string QualityTable::toJson() const {
  json rows = json::array();
  for (const QualityEntry& e : entries) {
    const QualitySetting& s = e.setting;
    rows.push_back({{"transfer_function", e.transferFunction},
                    {"shading", e.shading},
                    {"step", s.step},
                    {"raycast", s.raycast},
                    {"slab", s.slab},
                    {"ert", s.ert},
                    {"pre_integration", s.preIntegration},
                    {"sub_block", s.subBlock},
                    {"lod", s.lod},
                    {"ms_median", e.msMedian},
                    {"psnr_min", e.psnrMin}});
  }
  return json{{"format", "voxbrick-quality"},
              {"version", kFormatVersion},
              {"device", device},
              {"size", {width, height}},
              {"views", views},
              {"entries", rows}}
             .dump(1) +
         "\n";
}

QualityTable QualityTable::fromJson(const std::string& text, const std::string& what) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw RenderInputError(what + ": not valid JSON (" + e.what() + ")");
  }
  if (!j.is_object() || j.value("format", "") != "voxbrick-quality")
    throw RenderInputError(what + ": not a voxbrick quality table");
  if (get<int>(j, "version", what) != kFormatVersion)
    throw RenderInputError(what + ": quality table version " + j["version"].dump() + ", this build reads " +
                           std::to_string(kFormatVersion));
  QualityTable t;
  t.device = get<std::string>(j, "device", what);
  const auto size = get<std::vector<int>>(j, "size", what);
  if (size.size() != 2 || size[0] < 1 || size[1] < 1) throw RenderInputError(what + ": 'size' is not [w, h]");
  t.width = size[0], t.height = size[1];
  t.views = get<int>(j, "views", what);
  const json& rows = j.contains("entries") ? j["entries"] : json();
  if (!rows.is_array()) throw RenderInputError(what + ": 'entries' is not an array");
  for (const json& r : rows) {
    QualityEntry e;
    e.transferFunction = get<std::string>(r, "transfer_function", what);
    e.shading = get<bool>(r, "shading", what);
    QualitySetting& s = e.setting;
    s.step = get<double>(r, "step", what);
    s.raycast = get<bool>(r, "raycast", what);
    s.slab = get<int>(r, "slab", what);
    s.ert = get<double>(r, "ert", what);
    s.preIntegration = get<bool>(r, "pre_integration", what);
    s.subBlock = get<int>(r, "sub_block", what);
    s.lod = get<double>(r, "lod", what);
    e.msMedian = get<double>(r, "ms_median", what);
    e.psnrMin = get<double>(r, "psnr_min", what);
    if (!(e.msMedian >= 0) || !std::isfinite(e.msMedian) || std::isnan(e.psnrMin))
      throw RenderInputError(what + ": an entry has a time or PSNR that is not a number");
    // The setting must be one a scene accepts, so that a table cannot make a frame fail validation.
    Scene probe;
    s.applyTo(probe);
    try {
      probe.validate();
    } catch (const RenderInputError& error) {
      throw RenderInputError(what + ": an entry's setting is invalid (" + error.what() + ")");
    }
    t.entries.push_back(std::move(e));
  }
  return t;
}

std::filesystem::path QualityTable::pathFor(const std::filesystem::path& dataset) {
  if (std::filesystem::is_directory(dataset)) return dataset / "quality.json";
  return std::filesystem::path(dataset.string() + ".quality.json");
}

std::optional<QualityTable> QualityTable::load(const std::filesystem::path& dataset) {
  const std::filesystem::path path = pathFor(dataset);
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return fromJson(text.str(), path.string());
}

void QualityTable::save(const std::filesystem::path& dataset) const {
  const std::string text = toJson();
  try {
    image::writeFileAtomically(pathFor(dataset), {reinterpret_cast<const uint8_t*>(text.data()), text.size()});
  } catch (const image::ImageFailure& e) {
    throw RenderInputError(std::string("cannot write the quality table: ") + e.what());
  }
}

QualityChoice QualityTable::choose(const QualityTarget& target, const Scene& scene) const {
  if (entries.empty()) throw RenderInputError("the quality table has no entries");
  std::vector<const QualityEntry*> chosen;
  for (const QualityEntry& e : entries)
    if (e.transferFunction == scene.transferFunctionName && e.shading == scene.shading) chosen.push_back(&e);
  QualityChoice choice;
  choice.target = target;
  choice.basis = scene.transferFunctionName + (scene.shading ? ", shaded" : ", unshaded");
  if (chosen.empty()) {
    for (const QualityEntry& e : entries) chosen.push_back(&e);
    choice.basis = "no entry for " + choice.basis + ": the worst over every measured transfer function";
  }
  const double timeScale = double(scene.width) * scene.height / (double(width) * height);
  const std::vector<Candidate> all = candidates(chosen, timeScale);
  auto faster = [](const Candidate& a, const Candidate& b) { return a.ms < b.ms; };
  auto moreAccurate = [](const Candidate& a, const Candidate& b) {
    return a.psnr != b.psnr ? a.psnr > b.psnr : a.ms < b.ms;
  };
  std::vector<Candidate> meeting;
  for (const Candidate& c : all)
    if (target.kind == QualityTarget::Kind::Psnr ? c.psnr >= target.value + kPsnrMargin
                                                 : c.ms <= target.value * kTimeMargin)
      meeting.push_back(c);
  choice.met = !meeting.empty();
  const Candidate best = target.kind == QualityTarget::Kind::Psnr
                             ? (choice.met ? *std::min_element(meeting.begin(), meeting.end(), faster)
                                           : *std::min_element(all.begin(), all.end(), moreAccurate))
                             : (choice.met ? *std::min_element(meeting.begin(), meeting.end(), moreAccurate)
                                           : *std::min_element(all.begin(), all.end(), faster));
  choice.setting = best.setting;
  choice.expectedPsnr = best.psnr;
  choice.expectedMs = best.ms;
  return choice;
}

}  // namespace voxbrick::render
