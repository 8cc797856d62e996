#pragma once
/// @file case_file.hpp
/// Reading and validating YAML case files (format: docs/case-file.md).

#include <stdexcept>
#include <string>
#include <vector>

#include "solver/setup/case.hpp"

namespace bondem {

/// Bad input: the message names the file, line, column and key (or the --set that caused it).
class CaseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Read a case file, apply `KEY=VALUE` overrides by dotted path, validate everything.
/// Throws CaseError on any problem.
Case load_case(const std::string& path, const std::vector<std::string>& overrides = {});

/// As load_case, from text; @p source names it in messages.
Case parse_case(const std::string& text, const std::string& source,
                const std::vector<std::string>& overrides = {});

}  // namespace bondem
