#include "solver/summary_report.h"

#include "core/text.h"

namespace oslam {

std::string BriefReport(const SolverSummary& summary) {
  return Format("%s (%s), %d iterations, cost %.6g -> %.6g", TerminationName(summary.termination),
                summary.message.c_str(), summary.iterations, summary.initial_cost,
                summary.final_cost);
}

}  // namespace oslam
