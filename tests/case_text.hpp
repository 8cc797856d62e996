#pragma once
// Helpers of the tests that read case files from text.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "io/case_file.hpp"

namespace bondem::testing {

/// The CaseError message of parsing @p text as "case.yaml" with @p overrides ("" when it parses).
inline std::string error_of(const std::string& text,
                            const std::vector<std::string>& overrides = {}) {
  try {
    parse_case(text, "case.yaml", overrides);
  } catch (const CaseError& e) {
    return e.what();
  }
  return "";
}

/// @p text with its first @p from replaced by @p to; a missing @p from fails the test.
inline std::string replace(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

}  // namespace bondem::testing
