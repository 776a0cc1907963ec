// Prometheus' text exposition format (version 0.0.4) without sockets: a writer of metric families (counters, gauges,
// histograms with cumulative buckets) and a histogram that any thread observes into without a lock.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace voxbrick::server {

/// The Content-Type of the text MetricsText writes.
inline constexpr std::string_view kMetricsContentType = "text/plain; version=0.0.4; charset=utf-8";

/// Label names and values of one sample, in the order they are written.
using MetricLabels = std::vector<std::pair<std::string, std::string>>;

/// A histogram's counts at one moment.
struct HistogramCounts {
  std::vector<double> bounds;        ///< the buckets' upper bounds, ascending (+Inf implied after the last)
  std::vector<uint64_t> cumulative;  ///< observations at most each bound, then all of them: bounds.size() + 1
  double sum = 0;                    ///< of every observation
  uint64_t count() const { return cumulative.empty() ? 0 : cumulative.back(); }
};

/// Observations counted into buckets of fixed upper bounds. observe() and counts() are thread-safe and take no lock;
/// counts() read while others observe may lag the sum by the observations in flight.
class Histogram {
 public:
  /// `bounds`: finite and strictly ascending; throws std::invalid_argument otherwise.
  explicit Histogram(std::span<const double> bounds);
  Histogram(const Histogram&) = delete;
  Histogram& operator=(const Histogram&) = delete;

  /// Counts `value` in the first bucket whose bound is at least it (the +Inf bucket past the last bound).
  void observe(double value);
  HistogramCounts counts() const;

 private:
  std::vector<double> mBounds;
  std::unique_ptr<std::atomic<uint64_t>[]> mBuckets;  ///< per bucket, not cumulative: bounds.size() + 1
  std::atomic<double> mSum{0};
};

/// Writes metric families in the text format: `# HELP` and `# TYPE` once per family, then its samples, label values
/// escaped. Misuse (a bad name, a family written twice, a sample of another type than its family's) throws
/// std::invalid_argument or std::logic_error: it is a programming error, caught by the tests.
class MetricsText {
 public:
  enum class Type { Counter, Gauge, Histogram };

  /// Begins family `name` ([a-zA-Z_:][a-zA-Z0-9_:]*; a counter's ends in "_total") with its help text.
  MetricsText& family(std::string_view name, Type type, std::string_view help);
  /// A sample of the current family, a counter or a gauge. Label names are [a-zA-Z_][a-zA-Z0-9_]* and not "le".
  MetricsText& sample(double value, const MetricLabels& labels = {});
  /// A sample of the current family, a histogram: NAME_bucket{..., le="BOUND"} (cumulative, +Inf last),
  /// NAME_sum and NAME_count.
  MetricsText& histogram(const HistogramCounts& counts, const MetricLabels& labels = {});

  /// The text so far.
  const std::string& text() const { return mText; }
  /// The families begun so far, in order.
  const std::vector<std::string>& families() const { return mFamilies; }

  /// `value` as the format spells it: integers without a fraction, "+Inf", "-Inf", "NaN".
  static std::string formatValue(double value);
  /// `value` escaped for a label value: backslash, double quote and line feed.
  static std::string escapeLabelValue(std::string_view value);

 private:
  void writeSample(std::string_view suffix, const MetricLabels& labels, const std::string* le, double value);

  std::string mText;
  std::vector<std::string> mFamilies;
  Type mType = Type::Gauge;
};

}  // namespace voxbrick::server
