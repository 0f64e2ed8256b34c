// Image files: the same pixels as cv::imread, the size checked from the
// header before decoding, and corrupt data an oslam::Error naming the file
// with nothing printed by libpng or libjpeg.
#include "core/image_file.h"

#include <chrono>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

std::string ReadAll(const std::string& path) {
  std::stringstream text;
  text << std::ifstream(path, std::ios::binary).rdbuf();
  return text.str();
}

void WriteAll(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// A test pattern with every channel varying, so that a swapped or dropped
// channel shows.
cv::Mat Pattern(int type) {
  cv::Mat image(37, 53, type);
  cv::randu(image, 0, CV_MAT_DEPTH(type) == CV_16U ? 65535 : 255);
  return image;
}

// The error message of `read`, or "" when it succeeds; stderr must stay empty.
std::string ErrorOf(const std::function<void()>& read) {
  ::testing::internal::CaptureStderr();
  std::string message;
  try {
    read();
  } catch (const Error& e) {
    message = e.what();
  }
  const std::string printed = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(printed, "") << "a library printed to the terminal";
  return message;
}

void ExpectSameAsOpenCv(const std::string& path) {
  for (const ImageColour colour : {ImageColour::kBgr, ImageColour::kGray}) {
    const int flag = colour == ImageColour::kBgr ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE;
    const cv::Mat expected = cv::imread(path, flag);
    ASSERT_FALSE(expected.empty()) << path;
    const cv::Mat read = ReadImage(path, colour);
    ASSERT_EQ(read.type(), expected.type()) << path;
    ASSERT_EQ(read.size(), expected.size()) << path;
    EXPECT_EQ(cv::norm(read, expected, cv::NORM_INF), 0.0) << path << " colour " << int(colour);
  }
}

TEST(ImageFile, PngOfEveryLayoutDecodesAsOpenCvDoes) {
  testing::TempDir dir;
  int n = 0;
  for (const int type : {CV_8UC3, CV_8UC4, CV_8UC1, CV_16UC3, CV_16UC1, CV_16UC4}) {
    const std::string path = dir.Path("image" + std::to_string(n++) + ".png");
    ASSERT_TRUE(cv::imwrite(path, Pattern(type)));
    ExpectSameAsOpenCv(path);
  }
  // Interlaced and 1-bit files are not written by OpenCV; a 1-bit gray
  // image is: a binary mask written with bilevel compression.
  const std::string bilevel = dir.Path("bilevel.png");
  cv::Mat mask = Pattern(CV_8UC1) > 128;
  ASSERT_TRUE(cv::imwrite(bilevel, mask, {cv::IMWRITE_PNG_BILEVEL, 1}));
  ExpectSameAsOpenCv(bilevel);
}

TEST(ImageFile, JpegDecodesAsOpenCvDoes) {
  testing::TempDir dir;
  for (const int type : {CV_8UC3, CV_8UC1}) {
    const std::string path = dir.Path("image" + std::to_string(type) + ".jpg");
    ASSERT_TRUE(cv::imwrite(path, Pattern(type)));
    ExpectSameAsOpenCv(path);
  }
  const std::string progressive = dir.Path("progressive.jpg");
  ASSERT_TRUE(cv::imwrite(progressive, Pattern(CV_8UC3), {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
  ExpectSameAsOpenCv(progressive);
}

// An APP1 EXIF block (little-endian TIFF) whose first directory holds one
// entry: Orientation (0x0112, SHORT) = value.
std::string ExifSegment(int orientation) {
  const unsigned char tiff[] = {'I',
                                'I',
                                42,
                                0,
                                8,
                                0,
                                0,
                                0,  // header, directory at 8
                                1,
                                0,  // one entry
                                0x12,
                                0x01,
                                3,
                                0,
                                1,
                                0,
                                0,
                                0,  // Orientation, SHORT, count 1
                                static_cast<unsigned char>(orientation),
                                0,
                                0,
                                0,
                                0,
                                0,
                                0,
                                0};  // no next directory
  std::string payload =
      std::string("Exif\0\0", 6) + std::string(reinterpret_cast<const char*>(tiff), sizeof(tiff));
  const size_t length = payload.size() + 2;
  return std::string("\xFF\xE1", 2) + static_cast<char>(length >> 8) +
         static_cast<char>(length & 0xFF) + payload;
}

TEST(ImageFile, JpegExifOrientationIsAppliedAsOpenCvDoes) {
  testing::TempDir dir;
  const std::string plain = dir.Path("plain.jpg");
  ASSERT_TRUE(cv::imwrite(plain, Pattern(CV_8UC3)));
  const std::string bytes = ReadAll(plain);
  for (const int orientation : {1, 3, 6, 8}) {
    const std::string path = dir.Path("oriented" + std::to_string(orientation) + ".jpg");
    WriteAll(path, bytes.substr(0, 2) + ExifSegment(orientation) + bytes.substr(2));
    ExpectSameAsOpenCv(path);
  }
  // A rotation changes the shape: 53x37 becomes 37x53.
  EXPECT_EQ(ReadImage(dir.Path("oriented6.jpg")).cols, 37);
}

TEST(ImageFile, TruncatedOrCorruptDataIsAnErrorNamingTheFileAndPrintsNothing) {
  testing::TempDir dir;
  const std::string png = dir.Path("frame.png"), jpg = dir.Path("frame.jpg");
  ASSERT_TRUE(cv::imwrite(png, Pattern(CV_8UC3)));
  ASSERT_TRUE(cv::imwrite(jpg, Pattern(CV_8UC3)));
  for (const std::string& path : {png, jpg}) {
    const std::string bytes = ReadAll(path);
    WriteAll(path, bytes.substr(0, bytes.size() / 2));
    EXPECT_EQ(ErrorOf([&] { ReadImage(path); }).rfind(path + ": corrupt ", 0), 0u)
        << ErrorOf([&] { ReadImage(path); });
    std::string flipped = bytes;
    for (size_t i = bytes.size() / 2; i < bytes.size() / 2 + 40; ++i) flipped[i] ^= 0x5A;
    WriteAll(path, flipped);
    EXPECT_EQ(ErrorOf([&] { ReadImage(path); }).rfind(path + ": corrupt ", 0), 0u);
  }
  WriteAll(png, "not an image at all");
  EXPECT_EQ(ErrorOf([&] { ReadImage(png); }),
            png + ": not an image (expected PNG, JPEG, BMP, TIFF or PNM data)");
  WriteAll(png, std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(ErrorOf([&] { ReadImage(png); }), png + ": the png header is cut short");
  EXPECT_EQ(ErrorOf([&] { ReadImage(dir.Path("absent.png")); }),
            dir.Path("absent.png") + ": file not found");
}

// A real PNG with its IHDR size replaced (CRC left stale: the size must be
// refused before libpng ever looks at the chunk).
std::string PngDeclaring(const std::string& png, unsigned width, unsigned height) {
  std::string bytes = png;
  for (int k = 0; k < 4; ++k) {
    bytes[16 + k] = static_cast<char>((width >> (24 - 8 * k)) & 0xFF);
    bytes[20 + k] = static_cast<char>((height >> (24 - 8 * k)) & 0xFF);
  }
  return bytes;
}

TEST(ImageFile, HugeDeclaredSizesAreRefusedFromTheHeaderBeforeDecoding) {
  testing::TempDir dir;
  const std::string png = dir.Path("small.png"), jpg = dir.Path("small.jpg");
  ASSERT_TRUE(cv::imwrite(png, Pattern(CV_8UC3)));
  ASSERT_TRUE(cv::imwrite(jpg, Pattern(CV_8UC3)));
  const std::string huge_png = dir.Path("huge.png");
  WriteAll(huge_png, PngDeclaring(ReadAll(png), 30000, 30000));
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(ErrorOf([&] {
              ReadImage(huge_png);
            }).rfind(huge_png + ": the png header declares 30000x30000 pixels, beyond", 0),
            0u);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
  // A JPEG's frame header (SOF0): height then width, big-endian, after the
  // marker, length and precision.
  std::string bytes = ReadAll(jpg);
  const size_t sof = bytes.find("\xFF\xC0");
  ASSERT_NE(sof, std::string::npos);
  bytes[sof + 5] = bytes[sof + 7] = static_cast<char>(0xEA);  // 0xEA60 = 60000
  bytes[sof + 6] = bytes[sof + 8] = static_cast<char>(0x60);
  const std::string huge_jpg = dir.Path("huge.jpg");
  WriteAll(huge_jpg, bytes);
  EXPECT_NE(ErrorOf([&] { ReadImage(huge_jpg); }).find("declares 60000x60000 pixels"),
            std::string::npos);
  // Within each side's bound but beyond the pixel count.
  WriteAll(huge_png, PngDeclaring(ReadAll(png), 16000, 16000));
  EXPECT_NE(ErrorOf([&] { ReadImage(huge_png); }).find("declares 16000x16000 pixels"),
            std::string::npos);
}

TEST(ImageFile, HeadersOfEveryFormatGiveTheSize) {
  testing::TempDir dir;
  for (const char* extension : {".png", ".jpg", ".bmp", ".tif", ".pgm", ".ppm"}) {
    const std::string path = dir.Path(std::string("image") + extension);
    ASSERT_TRUE(cv::imwrite(path, Pattern(std::string(extension) == ".pgm" ? CV_8UC1 : CV_8UC3)));
    const ImageHeader header = ReadImageHeader(ReadAll(path), path);
    EXPECT_EQ(header.width, 53) << extension;
    EXPECT_EQ(header.height, 37) << extension;
    ExpectSameAsOpenCv(path);
  }
}

TEST(ImageFile, WriteImageEncodesInMemoryAndReplacesTheFileWhole) {
  testing::TempDir dir;
  const std::string path = dir.Path("out.png");
  WriteAll(path, "old");
  const cv::Mat image = Pattern(CV_8UC3);
  WriteImage(path, image);
  EXPECT_EQ(cv::norm(ReadImage(path), image, cv::NORM_INF), 0.0);
  EXPECT_THROW(WriteImage(dir.Path("out.unknown"), image), Error);
  EXPECT_FALSE(std::filesystem::exists(dir.Path("out.unknown")));
  EXPECT_THROW(WriteImage(path, cv::Mat()), Error);
  EXPECT_EQ(cv::norm(ReadImage(path), image, cv::NORM_INF), 0.0);  // untouched
}

}  // namespace
}  // namespace oslam
