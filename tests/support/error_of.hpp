#pragma once
// The alphainv::Error that a call throws, for tests of error messages and fields. Test-only.

#include <functional>

#include <gtest/gtest.h>

#include "alphainv/error.hpp"

namespace alphainv::test {

/// The Error `f` throws; a test failure (and an empty Error) when it throws none.
inline Error error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "expected alphainv::Error, none thrown";
  return Error("no error thrown");
}

}  // namespace alphainv::test
