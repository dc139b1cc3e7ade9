#pragma once
/// \file cli_number.h
/// A command-line value read as one number: the whole string or nothing (the tools' flags).

#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>

namespace dypho::cli {

/// `text` as a double when all of it is one number (std::stod's syntax); std::nullopt otherwise
/// (empty, trailing characters, out of range).
inline std::optional<double> wholeStringNumber(const std::string& text) {
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (used == 0 || used != text.size()) return std::nullopt;
  return value;
}

}  // namespace dypho::cli
