// A dataset with a name and a kind and nothing behind it: for tests of what only passes a dataset along (a frame
// source that draws nothing) or refuses its kind.
#pragma once

#include <string>
#include <string_view>
#include <utility>

#include "render/core/Dataset.h"

namespace voxbrick::test {

class StubDataset final : public render::Dataset {
 public:
  StubDataset(std::string name, std::string kind) : Dataset(name, name), mKind(std::move(kind)) {}
  std::string_view kind() const override { return mKind; }
  std::string infoJson() const override { return "{}"; }
  store::CacheStats cacheStats() const override { return {}; }
  void setCacheBudget(size_t) const override {}

 private:
  std::string mKind;
};

}  // namespace voxbrick::test
