// A solve's summary as one line for the terminal, the same in every command
// that prints one.
#pragma once

#include <string>

#include "solver/sparse_solver.h"

namespace oslam {

// "converged (function tolerance reached), 7 iterations, cost 5484.04 -> 2097.44"
std::string BriefReport(const SolverSummary& summary);

}  // namespace oslam
