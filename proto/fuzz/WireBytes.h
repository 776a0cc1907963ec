// Building wire bytes by hand, valid or not, for the seed corpus and the codec tests: little-endian integers,
// length-prefixed strings, concatenation.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

namespace voxbrick::proto::wire {

using Bytes = std::vector<uint8_t>;

inline Bytes concat(std::initializer_list<Bytes> parts) {
  Bytes all;
  for (const Bytes& p : parts) all.insert(all.end(), p.begin(), p.end());
  return all;
}
inline Bytes u16(uint16_t v) { return {uint8_t(v), uint8_t(v >> 8)}; }
inline Bytes u32(uint32_t v) { return {uint8_t(v), uint8_t(v >> 8), uint8_t(v >> 16), uint8_t(v >> 24)}; }
inline Bytes u64(uint64_t v) { return concat({u32(uint32_t(v)), u32(uint32_t(v >> 32))}); }
inline Bytes str(const std::string& s) { return concat({u32(uint32_t(s.size())), Bytes(s.begin(), s.end())}); }

}  // namespace voxbrick::proto::wire
