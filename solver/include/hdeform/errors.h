#pragma once
/// @file
/// The two kinds of failure a caller must tell apart: the input is wrong (the user fixes a file)
/// or the numerics failed on valid input (the user changes the constraints).
#include <stdexcept>
#include <string>

namespace hdeform {

/// Malformed or inconsistent input. The message names the file, the line or the element, and
/// the problem, so that it can be shown to the user unchanged.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A linear system could not be factored or solved (not positive definite, out of memory).
class SolveError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace hdeform
