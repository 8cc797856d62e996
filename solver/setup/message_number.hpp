#pragma once
/// @file message_number.hpp
/// Numbers in messages: one way to print them everywhere.

#include <sstream>
#include <string>

namespace bondem {

/// @p value as messages print it: six significant digits.
inline std::string message_number(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

}  // namespace bondem
