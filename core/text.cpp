#include "core/text.h"

#include <charconv>
#include <cstdarg>
#include <cstdio>
#include <vector>

namespace oslam {

std::string Number(double value) {
  char buffer[64];
  // to_chars writes "inf", "-inf" and "nan" for the non-finite values.
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string Format(const char* format, ...) {
  va_list args;
  va_start(args, format);
  va_list again;
  va_copy(again, args);
  const int size = std::vsnprintf(nullptr, 0, format, args);
  va_end(args);
  std::vector<char> buffer(static_cast<size_t>(size < 0 ? 0 : size) + 1);
  std::vsnprintf(buffer.data(), buffer.size(), format, again);
  va_end(again);
  return std::string(buffer.data(), buffer.size() - 1);
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace oslam
