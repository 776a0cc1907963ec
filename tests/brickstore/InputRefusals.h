// A check shared by the ingest tests: a call is refused with a store::InputError whose message names the problem.
#pragma once

#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <vector>

#include "brickstore/Errors.h"

namespace voxbrick::test {

/// Expects `fn` to throw store::InputError with every one of `words` in its message.
inline void expectRefused(const std::function<void()>& fn, const std::vector<std::string>& words) {
  try {
    fn();
    ADD_FAILURE() << "no error; expected one with '" << words.front() << "'";
  } catch (const store::InputError& e) {
    const std::string m = e.what();
    for (const std::string& w : words) EXPECT_NE(m.find(w), std::string::npos) << "missing '" << w << "' in: " << m;
  }
}

}  // namespace voxbrick::test
