// Atomic output: write beside the target, then rename, so a crash or Ctrl-C
// never leaves a half-written file under the final name.
#pragma once

#include <functional>
#include <string>

namespace oslam {

// Calls write(temp_path), then renames temp_path to path. On any exception the
// temp file is removed and the exception propagates. The temp file keeps the
// target's extension so extension-sniffing writers (cv::imwrite,
// cv::FileStorage) pick the right format.
void WriteAtomically(const std::string& path,
                     const std::function<void(const std::string& temp_path)>& write);

// Makes SIGINT and SIGTERM remove the temp files of writes still under way
// before the process ends, so an interrupted run leaves neither half-written
// files nor stray temp files. Call once, from main().
void InstallInterruptCleanup();

// Writes `contents` to `path` atomically.
void WriteTextFileAtomically(const std::string& path, const std::string& contents);

// Reads a whole text file; throws oslam::Error naming the file on failure.
std::string ReadTextFile(const std::string& path);

}  // namespace oslam
