// geardyn: the error of bad input, thrown from every layer that reads what a user wrote.
#pragma once

#include <stdexcept>

namespace geardyn {

// Bad input: an unknown key, a wrong type, a value out of range, a file that cannot be read.
// The message names the source (file and line, or the --set override), the key, the value and
// what is allowed. The command-line tool exits with code 2 on it.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace geardyn
