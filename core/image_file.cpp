#include "core/image_file.h"

#include <algorithm>
#include <cctype>
#include <climits>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <jpeglib.h>
#include <png.h>

#include <opencv2/imgcodecs.hpp>

#include "core/bounds.h"
#include "core/error.h"

namespace oslam {
namespace {

const unsigned char* Bytes(const std::string& bytes) {
  return reinterpret_cast<const unsigned char*>(bytes.data());
}

unsigned BigEndian16(const unsigned char* p) {
  return (unsigned{p[0]} << 8) | p[1];
}
unsigned long BigEndian32(const unsigned char* p) {
  return (static_cast<unsigned long>(BigEndian16(p)) << 16) | BigEndian16(p + 2);
}

// ---------------------------------------------------------------- headers

// TIFF structures (a TIFF file, or the EXIF block of a JPEG or PNG): the
// byte order, then the offset of the first directory of 12-byte entries.
class TiffReader {
 public:
  TiffReader(const unsigned char* data, size_t size) : data_(data), size_(size) {}

  bool Valid() const {
    return size_ >= 8 && ((data_[0] == 'I' && data_[1] == 'I' && U16(2) == 42) ||
                          (data_[0] == 'M' && data_[1] == 'M' && U16(2) == 42));
  }
  // The value of `tag` in the first directory (SHORT or LONG), or -1.
  long Tag(unsigned tag) const {
    const unsigned long directory = U32(4);
    if (directory > size_ || size_ - directory < 2) return -1;
    const unsigned count = U16(directory);
    for (unsigned i = 0; i < count; ++i) {
      const unsigned long entry = directory + 2 + 12ul * i;
      if (entry + 12 > size_) return -1;
      if (U16(entry) != tag) continue;
      const unsigned type = U16(entry + 2);
      if (type == 3) return static_cast<long>(U16(entry + 8));
      if (type == 4) return static_cast<long>(U32(entry + 8));
      return -1;
    }
    return -1;
  }

 private:
  bool LittleEndian() const { return data_[0] == 'I'; }
  unsigned U16(unsigned long at) const {
    if (at + 2 > size_) return 0;
    return LittleEndian() ? (unsigned{data_[at + 1]} << 8) | data_[at] : BigEndian16(data_ + at);
  }
  unsigned long U32(unsigned long at) const {
    if (at + 4 > size_) return 0;
    return LittleEndian() ? (static_cast<unsigned long>(U16(at + 2)) << 16) | U16(at)
                          : BigEndian32(data_ + at);
  }

  const unsigned char* data_;
  size_t size_;
};

bool IsJpegFrameMarker(unsigned marker) {
  // SOF0..SOF15 except DHT (C4), JPG (C8) and DAC (CC).
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
}

// Width and height from the first frame header (SOFn) of a JPEG.
bool JpegSize(const std::string& bytes, int* width, int* height) {
  const unsigned char* p = Bytes(bytes);
  size_t at = 2;
  while (at + 4 <= bytes.size()) {
    if (p[at] != 0xFF) return false;
    const unsigned marker = p[at + 1];
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {  // no length
      at += 2;
      continue;
    }
    if (marker == 0xDA || marker == 0xD9) return false;  // scan or end before any frame
    const unsigned length = BigEndian16(p + at + 2);
    if (length < 2) return false;
    if (IsJpegFrameMarker(marker)) {
      if (length < 7 || at + 9 > bytes.size()) return false;
      *height = static_cast<int>(BigEndian16(p + at + 5));
      *width = static_cast<int>(BigEndian16(p + at + 7));
      return true;
    }
    at += 2 + length;
  }
  return false;
}

// Width and height of a PNM (PBM, PGM, PPM) file: "P5", then the numbers as
// text, separated by white space and '#' comments.
bool PnmSize(const std::string& bytes, int* width, int* height) {
  size_t at = 2;
  long numbers[2];
  for (long& number : numbers) {
    while (at < bytes.size() &&
           (std::isspace(static_cast<unsigned char>(bytes[at])) || bytes[at] == '#')) {
      if (bytes[at] == '#')
        while (at < bytes.size() && bytes[at] != '\n') ++at;
      else
        ++at;
    }
    if (at >= bytes.size() || !std::isdigit(static_cast<unsigned char>(bytes[at]))) return false;
    number = 0;
    for (; at < bytes.size() && std::isdigit(static_cast<unsigned char>(bytes[at])); ++at)
      number = std::min(number * 10 + (bytes[at] - '0'), 0x7FFFFFFFl);
  }
  *width = static_cast<int>(numbers[0]);
  *height = static_cast<int>(numbers[1]);
  return true;
}

// ---------------------------------------------------------------- PNG

struct PngSource {
  const unsigned char* data;
  size_t size, position;
  char message[200];
};

extern "C" void PngRead(png_structp png, png_bytep out, size_t count) {
  auto* source = static_cast<PngSource*>(png_get_io_ptr(png));
  if (count > source->size - source->position) png_error(png, "the file ends early (truncated)");
  std::memcpy(out, source->data + source->position, count);
  source->position += count;
}

// libpng's default handlers print to stderr; these keep the message.
extern "C" void PngFail(png_structp png, png_const_charp message) {
  auto* source = static_cast<PngSource*>(png_get_error_ptr(png));
  std::snprintf(source->message, sizeof(source->message), "%s", message);
  png_longjmp(png, 1);
}
extern "C" void PngWarn(png_structp, png_const_charp) {}

// The phases of a PNG decode that libpng may leave by longjmp: each in a
// function of its own with no object to destroy, so nothing is skipped.
bool PngReadInfo(png_structp png, png_infop info, bool bgr) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  const int bit_depth = png_get_bit_depth(png, info);
  const int colour_type = png_get_color_type(png, info);
  // The transformations cv::imread applies for an 8-bit BGR or gray result.
  if (bit_depth == 16) png_set_strip_16(png);
  png_set_strip_alpha(png);
  if (colour_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if ((colour_type & PNG_COLOR_MASK_COLOR) == 0 && bit_depth < 8)
    png_set_expand_gray_1_2_4_to_8(png);
  if ((colour_type & PNG_COLOR_MASK_COLOR) && bgr)
    png_set_bgr(png);
  else if (bgr)
    png_set_gray_to_rgb(png);
  else
    png_set_rgb_to_gray(png, 1, 0.299, 0.587);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  return true;
}

bool PngReadRows(png_structp png, png_infop info, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_image(png, rows);
  png_read_end(png, info);
  return true;
}

// Decodes as cv::imread would to 8-bit BGR or gray. `*opencv` is set when
// the file carries EXIF data, whose orientation cv::imread applies: the
// caller decodes it with OpenCV then (this decode proved the data sound).
bool DecodePng(const std::string& bytes, ImageColour colour, cv::Mat* out, bool* opencv,
               std::string* error) {
  PngSource source{Bytes(bytes), bytes.size(), 0, {}};
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &source, PngFail, PngWarn);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  const auto fail = [&](const char* what) {
    png_destroy_read_struct(&png, &info, nullptr);
    *error = std::string("corrupt PNG: ") + (source.message[0] ? source.message : what);
    return false;
  };
  if (info == nullptr) return fail("cannot start the decoder");
  png_set_read_fn(png, &source, PngRead);
  const bool bgr = colour == ImageColour::kBgr;
  if (!PngReadInfo(png, info, bgr)) return fail("bad header");
  const int width = static_cast<int>(png_get_image_width(png, info));
  const int height = static_cast<int>(png_get_image_height(png, info));
  if (png_get_rowbytes(png, info) != static_cast<size_t>(width) * (bgr ? 3 : 1))
    return fail("unsupported pixel layout");
  out->create(height, width, bgr ? CV_8UC3 : CV_8UC1);
  std::vector<png_bytep> rows(static_cast<size_t>(height));
  for (int y = 0; y < height; ++y) rows[y] = out->ptr<png_byte>(y);
  if (!PngReadRows(png, info, rows.data())) return fail("bad data");
  png_uint_32 exif_size = 0;
  png_bytep exif = nullptr;
  *opencv = png_get_eXIf_1(png, info, &exif_size, &exif) != 0;
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

// ---------------------------------------------------------------- JPEG

// A progressive JPEG can hold any number of scans, each a pass over the
// whole image; real encoders write about ten.
constexpr int kMaxJpegScans = 1000;

struct JpegErrors {
  jpeg_error_mgr manager;
  jpeg_progress_mgr progress;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

extern "C" void JpegFail(j_common_ptr info) {
  auto* errors = reinterpret_cast<JpegErrors*>(info->err);
  (*info->err->format_message)(info, errors->message);
  std::longjmp(errors->jump, 1);
}

// libjpeg prints its first warning (corrupt or truncated data) to stderr
// and carries on with grey pixels; here every warning is an error.
extern "C" void JpegMessage(j_common_ptr info, int level) {
  if (level < 0) JpegFail(info);
}

extern "C" void JpegProgress(j_common_ptr info) {
  auto* decompress = reinterpret_cast<j_decompress_ptr>(info);
  if (decompress->input_scan_number > kMaxJpegScans) {
    auto* errors = reinterpret_cast<JpegErrors*>(info->err);
    std::snprintf(errors->message, sizeof(errors->message), "more than %d scans", kMaxJpegScans);
    std::longjmp(errors->jump, 1);
  }
}

// The orientation an EXIF block (APP1 "Exif\0\0" + TIFF) declares; 1 when none.
long ExifOrientation(const jpeg_decompress_struct& info) {
  for (jpeg_saved_marker_ptr marker = info.marker_list; marker; marker = marker->next) {
    if (marker->marker != JPEG_APP0 + 1 || marker->data_length < 14 ||
        std::memcmp(marker->data, "Exif\0\0", 6) != 0)
      continue;
    const TiffReader tiff(marker->data + 6, marker->data_length - 6);
    if (tiff.Valid()) {
      const long orientation = tiff.Tag(0x0112);
      return orientation < 0 ? 1 : orientation;
    }
  }
  return 1;
}

bool JpegReadHeader(jpeg_decompress_struct* info, JpegErrors* errors, const std::string& bytes) {
  if (setjmp(errors->jump)) return false;
  jpeg_create_decompress(info);
  errors->progress.progress_monitor = JpegProgress;
  info->progress = &errors->progress;
  jpeg_mem_src(info, Bytes(bytes), static_cast<unsigned long>(bytes.size()));
  jpeg_save_markers(info, JPEG_APP0 + 1, 0xFFFF);
  jpeg_read_header(info, TRUE);
  return true;
}

bool JpegStart(jpeg_decompress_struct* info, JpegErrors* errors) {
  if (setjmp(errors->jump)) return false;
  jpeg_start_decompress(info);
  return true;
}

// Rows into `image`, or each into `scratch` when image is null.
bool JpegReadRows(jpeg_decompress_struct* info, JpegErrors* errors, cv::Mat* image,
                  JSAMPROW scratch) {
  if (setjmp(errors->jump)) return false;
  while (info->output_scanline < info->output_height) {
    JSAMPROW row = image ? image->ptr<JSAMPLE>(static_cast<int>(info->output_scanline)) : scratch;
    jpeg_read_scanlines(info, &row, 1);
  }
  jpeg_finish_decompress(info);
  return true;
}

// As DecodePng. `*opencv` is set for files cv::imread treats specially
// (CMYK, a rotating EXIF orientation); the data are still checked here.
bool DecodeJpeg(const std::string& bytes, ImageColour colour, cv::Mat* out, bool* opencv,
                std::string* error) {
  jpeg_decompress_struct info;
  JpegErrors errors;
  std::memset(&info, 0, sizeof(info));
  std::memset(&errors, 0, sizeof(errors));
  info.err = jpeg_std_error(&errors.manager);
  errors.manager.error_exit = JpegFail;
  errors.manager.emit_message = JpegMessage;
  const auto fail = [&] {
    jpeg_destroy_decompress(&info);
    *error = std::string("corrupt JPEG: ") + errors.message;
    return false;
  };
  if (!JpegReadHeader(&info, &errors, bytes)) return fail();
  const bool bgr = colour == ImageColour::kBgr;
  const bool cmyk = info.num_components == 4;
  *opencv = cmyk || ExifOrientation(info) != 1;
  if (cmyk)
    info.out_color_space = JCS_CMYK;
  else
    info.out_color_space = bgr ? JCS_EXT_BGR : JCS_GRAYSCALE;
  if (!JpegStart(&info, &errors)) return fail();
  std::vector<JSAMPLE> scratch;
  if (*opencv)
    scratch.resize(static_cast<size_t>(info.output_width) * info.output_components);
  else
    out->create(static_cast<int>(info.output_height), static_cast<int>(info.output_width),
                bgr ? CV_8UC3 : CV_8UC1);
  if (!JpegReadRows(&info, &errors, *opencv ? nullptr : out, scratch.data())) return fail();
  jpeg_destroy_decompress(&info);
  return true;
}

}  // namespace

ImageHeader ReadImageHeader(const std::string& bytes, const std::string& path) {
  const unsigned char* p = Bytes(bytes);
  ImageHeader header;
  const auto cut = [&] {
    return Error::InFile(path, "the " + header.format + " header is cut short");
  };
  if (bytes.size() >= 8 && std::memcmp(p, "\x89PNG\r\n\x1a\n", 8) == 0) {
    header.format = "png";
    if (bytes.size() < 24 || std::memcmp(p + 12, "IHDR", 4) != 0) throw cut();
    header.width = static_cast<int>(std::min(BigEndian32(p + 16), 0x7FFFFFFFul));
    header.height = static_cast<int>(std::min(BigEndian32(p + 20), 0x7FFFFFFFul));
  } else if (bytes.size() >= 2 && p[0] == 0xFF && p[1] == 0xD8) {
    header.format = "jpeg";
    if (!JpegSize(bytes, &header.width, &header.height)) throw cut();
  } else if (bytes.size() >= 2 && p[0] == 'B' && p[1] == 'M') {
    header.format = "bmp";
    if (bytes.size() < 26) throw cut();
    const auto le32 = [&](size_t at) {
      return static_cast<int32_t>(uint32_t{p[at]} | uint32_t{p[at + 1]} << 8 |
                                  uint32_t{p[at + 2]} << 16 | uint32_t{p[at + 3]} << 24);
    };
    if (le32(14) == 12) {  // OS/2 header: 16-bit sizes
      header.width = p[18] | p[19] << 8;
      header.height = p[20] | p[21] << 8;
    } else {
      header.width = le32(18);
      const int32_t height = le32(22);  // negative: stored top-down
      header.height = height == INT32_MIN ? INT32_MAX : (height < 0 ? -height : height);
    }
  } else if (bytes.size() >= 2 && p[0] == 'P' && p[1] >= '1' && p[1] <= '6') {
    header.format = "pnm";
    if (!PnmSize(bytes, &header.width, &header.height)) throw cut();
  } else if (TiffReader(p, bytes.size()).Valid()) {
    header.format = "tiff";
    const TiffReader tiff(p, bytes.size());
    const long width = tiff.Tag(256), height = tiff.Tag(257);
    if (width < 0 || height < 0) throw cut();
    header.width = static_cast<int>(std::min(width, 0x7FFFFFFFl));
    header.height = static_cast<int>(std::min(height, 0x7FFFFFFFl));
  } else {
    throw Error::InFile(path, "not an image (expected PNG, JPEG, BMP, TIFF or PNM data)");
  }
  return header;
}

cv::Mat ReadImage(const std::string& path, ImageColour colour) {
  const std::string bytes = ReadTextFile(path);
  const ImageHeader header = ReadImageHeader(bytes, path);
  if (header.width <= 0 || header.height <= 0)
    throw Error::InFile(path, "the " + header.format + " header declares an empty image");
  if (header.width > bounds::kImageSidePx || header.height > bounds::kImageSidePx ||
      static_cast<long>(header.width) * header.height > bounds::kImagePixels)
    throw Error::InFile(
        path, "the " + header.format + " header declares " + std::to_string(header.width) + "x" +
                  std::to_string(header.height) + " pixels, beyond the image bounds (at most " +
                  std::to_string(bounds::kImageSidePx) + " per side and " +
                  std::to_string(bounds::kImagePixels / 1000000) +
                  " million pixels; docs/formats.md, Bounds)");
  cv::Mat image;
  bool opencv = true;
  std::string error;
  if (header.format == "png" && !DecodePng(bytes, colour, &image, &opencv, &error))
    throw Error::InFile(path, error);
  if (header.format == "jpeg" && !DecodeJpeg(bytes, colour, &image, &opencv, &error))
    throw Error::InFile(path, error);
  if (opencv) {
    const std::vector<unsigned char> buffer(bytes.begin(), bytes.end());
    try {
      image = cv::imdecode(buffer,
                           colour == ImageColour::kBgr ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE);
    } catch (const cv::Exception&) {
      image.release();
    }
  }
  if (image.empty()) throw Error::InFile(path, "cannot decode the " + header.format + " data");
  if (static_cast<long>(image.cols) * image.rows > bounds::kImagePixels)
    throw Error::InFile(path, "decodes to more pixels than its header declares");
  return image;
}

void WriteImage(const std::string& path, const cv::Mat& image, const std::vector<int>& params,
                FileSync sync) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::vector<unsigned char> encoded;
  bool ok = false;
  try {
    ok = !image.empty() && cv::imencode(extension, image, encoded, params);
  } catch (const cv::Exception& e) {
    throw Error::InFile(path, "cannot encode the image: " + e.msg);
  }
  if (!ok || encoded.empty()) throw Error::InFile(path, "cannot encode the image");
  WriteFileAtomically(
      path, std::string_view(reinterpret_cast<const char*>(encoded.data()), encoded.size()), sync);
}

}  // namespace oslam
