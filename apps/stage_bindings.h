// The binding tables of the stages' options. `oslam detect`, `oslam slam`
// (and `oslam map`'s O-SLAM mode), `oslam export` and `oslam eval` declare
// their flags from them, and `oslam run` reads its configuration sections
// detect, slam, export and eval through the same tables, so a parameter has
// one flag, one key, one default (the struct's) and one parser.
#pragma once

#include <string>

#include "apps/bindings.h"
#include "core/odometry_sync.h"
#include "pipeline/detect_stage.h"
#include "pipeline/eval_stage.h"
#include "pipeline/export_stage.h"
#include "pipeline/slam_stage.h"
#include "pipeline/stage_output.h"

namespace oslam {

void BindDetectOptions(DetectStageOptions* options, Bindings* bindings);
void BindSlamOptions(SlamStageOptions* options, Bindings* bindings);
void BindExportOptions(ExportStageOptions* options, Bindings* bindings);
void BindEvalOptions(EvalStageOptions* options, Bindings* bindings);
// `oslam run`'s frames section (configuration keys only): the frames a run
// with odometry by time keeps.
void BindFrameOptions(FrameSelectionOptions* options, Bindings* bindings);

// A stage's output for a command: report lines on stdout, warnings on
// stderr as "oslam COMMAND: warning: ...".
StageOutput CommandOutput(const std::string& command, bool quiet);

}  // namespace oslam
