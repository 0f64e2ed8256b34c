#include "omap/omap.h"

namespace oslam {

const OMapReport* FindReport(const OMap& map, const std::string& name) {
  for (const OMapReport& report : map.reports)
    if (report.name == name) return &report;
  return nullptr;
}

}  // namespace oslam
