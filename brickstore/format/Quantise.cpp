// Quantisation of prep's input: the linear map and its option parsing.
#include "brickstore/format/Quantise.h"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {

double Quantisation::quantise(double v) const { return std::clamp(std::floor(toSteps(v) + 0.5), 0.0, steps()); }

void Quantisation::validate() const {
  if (type != ValueType::U8 && type != ValueType::U16)
    throw InputError("--quantise: type " + std::string(valueTypeName(type)) + " is not u8 or u16");
  if (!std::isfinite(lo) || !std::isfinite(hi))
    throw InputError("--quantise-range " + std::to_string(lo) + "," + std::to_string(hi) + ": not finite");
  if (!(lo < hi))
    throw InputError("--quantise-range " + std::to_string(lo) + "," + std::to_string(hi) + ": lo must be below hi");
}

ValueType parseQuantiseType(const std::string& text) {
  if (text == "u8") return ValueType::U8;
  if (text == "u16") return ValueType::U16;
  throw InputError("--quantise '" + text + "': expected u8 or u16");
}

void parseQuantiseRange(const std::string& text, Quantisation& q) {
  const size_t comma = text.find(',');
  double values[2] = {0, 0};
  bool ok = comma != std::string::npos;
  for (int i = 0; ok && i < 2; ++i) {
    const char* first = text.data() + (i == 0 ? 0 : comma + 1);
    const char* last = text.data() + (i == 0 ? comma : text.size());
    auto [end, ec] = std::from_chars(first, last, values[i]);
    ok = ec == std::errc() && end == last && first != last;
  }
  if (!ok) throw InputError("--quantise-range '" + text + "': expected two numbers lo,hi");
  if (!std::isfinite(values[0]) || !std::isfinite(values[1]))
    throw InputError("--quantise-range '" + text + "': lo and hi must be finite");
  if (!(values[0] < values[1])) throw InputError("--quantise-range '" + text + "': lo must be below hi");
  q.lo = values[0];
  q.hi = values[1];
}

}  // namespace voxbrick::store
