// Reading Prometheus' text format in tests: the families and samples of a /metrics body, checked line by line, and
// the table of metrics in docs/server.md.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace voxbrick::test {

/// One sample line: its name, its labels as written (escapes kept, no braces), its value as written.
struct SampleLine {
  std::string name, labels, value;
};

struct ParsedMetrics {
  std::map<std::string, std::string> types;  ///< each family's TYPE, by name
  std::vector<std::string> order;            ///< the families in the order written
  std::vector<SampleLine> samples;

  /// The value of the sample `name` whose labels are exactly `labels` (as written, without braces); NaN if none.
  double value(const std::string& name, const std::string& labels = "") const;
  /// The sum of every sample named `name`, whatever its labels (0 if none).
  double sum(const std::string& name) const;
};

/// The families and samples of `text`. Adds a test failure for a line that is neither a comment nor a sample, a
/// TYPE without its HELP just before, and a family declared twice.
ParsedMetrics parseMetrics(const std::string& text);

/// The family a sample named `sampleName` belongs to (its name, less a histogram's _bucket, _sum or _count); empty if
/// none of `types`.
std::string familyOfSample(const std::string& sampleName, const std::map<std::string, std::string>& types);

/// The metrics of docs/server.md's table (its first two columns: `voxbrick_...` and the type), by name. Adds a test
/// failure for a metric listed twice.
std::map<std::string, std::string> documentedMetrics();

}  // namespace voxbrick::test
