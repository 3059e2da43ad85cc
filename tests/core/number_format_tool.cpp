// Reads "VALUE U" lines (numbers as strtod reads them; "nan" for no uncertainty) and prints each pair as
// core/number_format.hpp's with_uncertainty() writes it, one line each: number_rounding_test.py holds
// the output against its own implementation of the GUM rounding rule.
#include <cstdlib>
#include <iostream>
#include <string>

#include "core/number_format.hpp"

int main() {
  std::string value, u;
  while (std::cin >> value >> u)
    std::cout << guideway::with_uncertainty(std::strtod(value.c_str(), nullptr), std::strtod(u.c_str(), nullptr))
              << "\n";
  return 0;
}
