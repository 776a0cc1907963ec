// The Error a request to the real server is answered with, for the tests of refusals.
#pragma once

#include <functional>

#include <gtest/gtest.h>

#include "client/Client.h"

namespace voxbrick::test {

/// The ServerError `request` throws (code and message); fails the test, and returns Internal "none", if it succeeds.
inline client::ServerError serverErrorOf(const std::function<void()>& request) {
  try {
    request();
  } catch (const client::ServerError& e) {
    return e;
  }
  ADD_FAILURE() << "the request succeeded";
  return client::ServerError(proto::ErrorCode::Internal, "none");
}

}  // namespace voxbrick::test
