// Reading Prometheus' text format in tests.
#include "PrometheusText.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

namespace voxbrick::test {

double ParsedMetrics::value(const std::string& name, const std::string& labels) const {
  for (const SampleLine& s : samples)
    if (s.name == name && s.labels == labels) return std::stod(s.value);
  return std::nan("");
}

double ParsedMetrics::sum(const std::string& name) const {
  double total = 0;
  for (const SampleLine& s : samples)
    if (s.name == name) total += std::stod(s.value);
  return total;
}

ParsedMetrics parseMetrics(const std::string& text) {
  ParsedMetrics parsed;
  std::istringstream in(text);
  std::string line, lastHelp;
  // A name, optional {labels} (a quoted value may hold escaped quotes), one space, the value.
  const std::regex sample(
      R"(^([a-zA-Z_:][a-zA-Z0-9_:]*)(\{((?:[a-zA-Z_][a-zA-Z0-9_]*="(?:[^"\\]|\\.)*",?)*)\})? (\S+)$)");
  while (std::getline(in, line)) {
    std::smatch m;
    if (line.rfind("# HELP ", 0) == 0) {
      lastHelp = line.substr(7, line.find(' ', 7) - 7);
    } else if (line.rfind("# TYPE ", 0) == 0) {
      std::istringstream words(line.substr(7));
      std::string name, type;
      words >> name >> type;
      EXPECT_EQ(lastHelp, name) << "HELP comes just before TYPE: " << line;
      EXPECT_TRUE(parsed.types.emplace(name, type).second) << "family declared twice: " << name;
      parsed.order.push_back(name);
    } else if (std::regex_match(line, m, sample)) {
      parsed.samples.push_back({m[1], m[3], m[4]});
    } else {
      ADD_FAILURE() << "not a line of the text format: '" << line << "'";
    }
  }
  return parsed;
}

std::string familyOfSample(const std::string& sampleName, const std::map<std::string, std::string>& types) {
  if (types.count(sampleName)) return sampleName;
  for (const std::string suffix : {"_bucket", "_sum", "_count"}) {
    if (sampleName.size() <= suffix.size() || !sampleName.ends_with(suffix)) continue;
    const std::string base = sampleName.substr(0, sampleName.size() - suffix.size());
    if (types.count(base) && types.at(base) == "histogram") return base;
  }
  return "";
}

std::map<std::string, std::string> documentedMetrics() {
  std::ifstream in(std::string(VOXBRICK_SOURCE_DIR) + "/docs/server.md");
  EXPECT_TRUE(in) << "docs/server.md";
  std::map<std::string, std::string> types;
  std::string line;
  const std::regex row(R"(^\| `(voxbrick_[a-z0-9_]+)` \| ([a-z]+) \|)");
  while (std::getline(in, line)) {
    std::smatch m;
    if (std::regex_search(line, m, row)) {
      EXPECT_TRUE(types.emplace(m[1], m[2]).second) << "listed twice: " << m[1];
    }
  }
  return types;
}

}  // namespace voxbrick::test
