// expect_error(fn, {"part", ...}): fn must throw imukit::Error whose message holds every part (a
// clear error names the file, the field and what was wrong: the tests say which words).
#pragma once

#include <gtest/gtest.h>

#include <initializer_list>
#include <string>

#include "imukit/core/error.hpp"

namespace imukit::testing {

template <typename Fn>
void expect_error(Fn fn, std::initializer_list<std::string> parts) {
  try {
    fn();
    ADD_FAILURE() << "expected an imukit::Error";
  } catch (const Error& e) {
    for (const std::string& p : parts) {
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos)
          << "message '" << e.what() << "' lacks '" << p << "'";
    }
  }
}

}  // namespace imukit::testing
