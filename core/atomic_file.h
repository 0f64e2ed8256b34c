// Atomic output: write beside the target, then rename, so a crash, Ctrl-C or
// a full disk never leaves a half-written file under the final name.
#pragma once

#include <functional>
#include <string>
#include <string_view>

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

// When a written file reaches the disk: kEach syncs it before the rename
// (durable when the call returns); kDeferred leaves that to one
// SyncFileSystem call after a batch of files (an overlay per frame: one
// fsync each would cost more than drawing them).
enum class FileSync { kEach, kDeferred };

// Writes `bytes` to `path` atomically: a new temp file beside the target
// (created with O_CREAT | O_EXCL, so a file or symlink planted at its name is
// never followed), every write and the close checked, fsync (kEach), rename
// over the target, fsync of the folder. On any failure (a full disk
// included) the temp file is removed, `path` is left as it was, and
// oslam::Error names `path` and the reason. Writers that can produce their
// file in memory use this rather than WriteAtomically: a library writing to
// a path may not report a failed write.
void WriteFileAtomically(const std::string& path, std::string_view bytes,
                         FileSync sync = FileSync::kEach);

// Flushes every file written on the file system holding `folder` (syncfs),
// after a batch of FileSync::kDeferred writes. Throws oslam::Error naming
// `folder` when the flush reports a failure.
void SyncFileSystem(const std::string& folder);

// Writes `contents` to `path` as WriteFileAtomically does.
void WriteTextFileAtomically(const std::string& path, const std::string& contents);

// Throws oslam::Error naming `root`/`name` when it is a symlink leading out
// of the output folder `root`: the files written there would land elsewhere.
void CheckOutputSubfolder(const std::string& root, const std::string& name);

// Creates `root`/`name`, a folder for output inside the output folder
// `root` (both created when missing), after CheckOutputSubfolder; returns
// its path.
std::string PrepareOutputFolder(const std::string& root, const std::string& name);

// Throws oslam::Error naming `path` unless it is a regular file within the
// input size bound (core/bounds.h): a FIFO or a device given as an input
// would block or never end.
void CheckInputFile(const std::string& path);

// Reads a whole text file (CheckInputFile first); throws oslam::Error naming
// the file on failure.
std::string ReadTextFile(const std::string& path);

}  // namespace oslam
