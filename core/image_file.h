// Image files in and out, without surprises: the size an image declares is
// checked against the bounds (core/bounds.h) from its header, before any
// pixel is decoded; a truncated or corrupt PNG or JPEG is an oslam::Error
// naming the file, never a half-grey image or a line printed by libpng or
// libjpeg; images are encoded in memory and written atomically.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/atomic_file.h"

namespace oslam {

struct ImageHeader {
  std::string format;  // png, jpeg, bmp, tiff or pnm
  int width = 0, height = 0;
};

// The format and size that the first bytes of an image file declare; throws
// oslam::Error naming `path` when they are none of these formats or the
// header is cut short.
ImageHeader ReadImageHeader(const std::string& bytes, const std::string& path);

enum class ImageColour { kBgr, kGray };

// An 8-bit BGR (or gray) image decoded from `path` as cv::imread would
// decode it, or oslam::Error naming the file: not an image, a declared size
// beyond the bounds, truncated or corrupt data.
cv::Mat ReadImage(const std::string& path, ImageColour colour = ImageColour::kBgr);

// Encodes `image` in memory in the format of path's extension (cv::imencode
// with `params`), then WriteFileAtomically: every write checked.
void WriteImage(const std::string& path, const cv::Mat& image, const std::vector<int>& params = {},
                FileSync sync = FileSync::kEach);

}  // namespace oslam
