// Prometheus' text exposition format: the writer and the lock-free histogram.
#include "server/Metrics.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <stdexcept>

namespace voxbrick::server {
namespace {

bool metricNameChar(char c, bool first) {
  const bool letter = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
  return letter || (!first && c >= '0' && c <= '9');
}

bool validMetricName(std::string_view name) {
  if (name.empty()) return false;
  for (size_t i = 0; i < name.size(); ++i)
    if (!metricNameChar(name[i], i == 0) && name[i] != ':') return false;
  return true;
}

bool validLabelName(std::string_view name) {
  if (name.empty() || name == "le" || name.starts_with("__")) return false;
  for (size_t i = 0; i < name.size(); ++i)
    if (!metricNameChar(name[i], i == 0)) return false;
  return true;
}

/// HELP text escaped as the format asks: backslash and line feed.
std::string escapeHelp(std::string_view help) {
  std::string out;
  for (const char c : help) {
    if (c == '\\')
      out += "\\\\";
    else if (c == '\n')
      out += "\\n";
    else
      out += c;
  }
  return out;
}

const char* typeName(MetricsText::Type type) {
  switch (type) {
    case MetricsText::Type::Counter: return "counter";
    case MetricsText::Type::Gauge: return "gauge";
    case MetricsText::Type::Histogram: return "histogram";
  }
  return "untyped";
}

}  // namespace

Histogram::Histogram(std::span<const double> bounds)
    : mBounds(bounds.begin(), bounds.end()), mBuckets(new std::atomic<uint64_t>[bounds.size() + 1]) {
  for (size_t i = 0; i < mBounds.size(); ++i) {
    if (!std::isfinite(mBounds[i]) || (i > 0 && mBounds[i] <= mBounds[i - 1]))
      throw std::invalid_argument("Histogram: bounds must be finite and strictly ascending (bound " +
                                  std::to_string(i) + " is " + std::to_string(mBounds[i]) + ")");
  }
  for (size_t i = 0; i <= mBounds.size(); ++i) mBuckets[i].store(0, std::memory_order_relaxed);
}

void Histogram::observe(double value) {
  if (std::isnan(value)) return;  // it would make the sum NaN for good
  const size_t bucket = size_t(std::lower_bound(mBounds.begin(), mBounds.end(), value) - mBounds.begin());
  mBuckets[bucket].fetch_add(1, std::memory_order_relaxed);
  mSum.fetch_add(value, std::memory_order_relaxed);
}

HistogramCounts Histogram::counts() const {
  HistogramCounts c;
  c.bounds = mBounds;
  c.cumulative.resize(mBounds.size() + 1);
  uint64_t running = 0;
  for (size_t i = 0; i <= mBounds.size(); ++i) c.cumulative[i] = running += mBuckets[i].load(std::memory_order_relaxed);
  c.sum = mSum.load(std::memory_order_relaxed);
  return c;
}

std::string MetricsText::formatValue(double value) {
  if (std::isnan(value)) return "NaN";
  if (std::isinf(value)) return value > 0 ? "+Inf" : "-Inf";
  char buffer[64];
  // Whole numbers (counts, bytes) as integers, exactly; others in the shortest form that reads back the same.
  const auto [end, ec] = std::abs(value) < 9.0e15 && value == std::floor(value)
                             ? std::to_chars(buffer, buffer + sizeof buffer, int64_t(value))
                             : std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, end);
}

std::string MetricsText::escapeLabelValue(std::string_view value) {
  std::string out;
  out.reserve(value.size());
  for (const char c : value) {
    if (c == '\\')
      out += "\\\\";
    else if (c == '"')
      out += "\\\"";
    else if (c == '\n')
      out += "\\n";
    else
      out += c;
  }
  return out;
}

MetricsText& MetricsText::family(std::string_view name, Type type, std::string_view help) {
  if (!validMetricName(name)) throw std::invalid_argument("MetricsText: '" + std::string(name) + "' is no metric name");
  if (type == Type::Counter && !name.ends_with("_total"))
    throw std::invalid_argument("MetricsText: counter '" + std::string(name) + "' must end in _total");
  if (std::find(mFamilies.begin(), mFamilies.end(), name) != mFamilies.end())
    throw std::invalid_argument("MetricsText: family '" + std::string(name) + "' written twice");
  mFamilies.emplace_back(name);
  mType = type;
  mText += "# HELP " + mFamilies.back() + " " + escapeHelp(help) + "\n";
  mText += "# TYPE " + mFamilies.back() + " " + typeName(type) + "\n";
  return *this;
}

MetricsText& MetricsText::sample(double value, const MetricLabels& labels) {
  if (mFamilies.empty() || mType == Type::Histogram)
    throw std::logic_error("MetricsText: a plain sample needs a counter or gauge family first");
  writeSample("", labels, nullptr, value);
  return *this;
}

MetricsText& MetricsText::histogram(const HistogramCounts& counts, const MetricLabels& labels) {
  if (mFamilies.empty() || mType != Type::Histogram)
    throw std::logic_error("MetricsText: histogram counts need a histogram family first");
  if (counts.cumulative.size() != counts.bounds.size() + 1)
    throw std::invalid_argument("MetricsText: a histogram needs one cumulative count per bound and one for +Inf");
  for (size_t i = 0; i <= counts.bounds.size(); ++i) {
    const std::string le = i < counts.bounds.size() ? formatValue(counts.bounds[i]) : "+Inf";
    writeSample("_bucket", labels, &le, double(counts.cumulative[i]));
  }
  writeSample("_sum", labels, nullptr, counts.sum);
  writeSample("_count", labels, nullptr, double(counts.count()));
  return *this;
}

void MetricsText::writeSample(std::string_view suffix, const MetricLabels& labels, const std::string* le,
                              double value) {
  mText += mFamilies.back();
  mText += suffix;
  if (!labels.empty() || le) {
    mText += '{';
    bool first = true;
    for (const auto& [name, labelValue] : labels) {
      if (!validLabelName(name)) throw std::invalid_argument("MetricsText: '" + name + "' is no label name");
      if (!first) mText += ',';
      first = false;
      mText += name + "=\"" + escapeLabelValue(labelValue) + "\"";
    }
    if (le) mText += std::string(first ? "" : ",") + "le=\"" + *le + "\"";
    mText += '}';
  }
  mText += ' ';
  mText += formatValue(value);
  mText += '\n';
}

}  // namespace voxbrick::server
