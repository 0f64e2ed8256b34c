// Numbers and durations as text, written the same way wherever they are
// printed, shown as defaults or stored in a configuration.
#pragma once

#include <chrono>
#include <string>

namespace oslam {

// Shortest text that reads back as the same double ("0.1", "1e-08", "inf").
std::string Number(double value);

// printf into a std::string.
std::string Format(const char* format, ...) __attribute__((format(printf, 1, 2)));

// Wall-clock seconds since `start`.
double SecondsSince(std::chrono::steady_clock::time_point start);

}  // namespace oslam
