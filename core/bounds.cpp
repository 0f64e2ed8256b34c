#include "core/bounds.h"

#include <cstdio>

namespace oslam {
namespace bounds {

std::string OutsideMessage(double value, double low, double high, const std::string& unit) {
  char text[160];
  std::snprintf(text, sizeof(text), "%.6g is outside [%.6g, %.6g]%s%s (docs/formats.md, Bounds)",
                value, low, high, unit.empty() ? "" : " ", unit.c_str());
  return text;
}

std::string ReachMessage(double x_m, double y_m, const std::string& where) {
  char text[200];
  std::snprintf(text, sizeof(text),
                "the odometry reaches (%.6g, %.6g) m at %s, beyond the position bound of "
                "+-%.6g m (docs/formats.md, Bounds)",
                x_m, y_m, where.c_str(), kCoordinateM);
  return text;
}

}  // namespace bounds
}  // namespace oslam
