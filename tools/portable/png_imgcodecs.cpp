/// PNG-only cv::imread / cv::imwrite / cv::imencode / cv::imdecode on libpng, for the portable
/// whole-system bundle (scripts/gpu_system.sh prepare): GPU machines have no OpenCV, and Debian's
/// libopencv_imgcodecs loads GDAL, poppler, HDF5 and more (about 180 MB with what they load),
/// while the runner and the generator read and write PNG only (TUM-layout colour, 16-bit depth,
/// masks). Linked in place of libopencv_imgcodecs; never part of the CMake build.
///
/// Same pixels as OpenCV 4.6's PNG codec for what this project reads and writes: 8- and 16-bit
/// grey, colour and colour+alpha, in BGR(A) order; IMREAD_COLOR keeps the high byte of 16-bit
/// samples; IMREAD_GRAYSCALE converts colour with OpenCV's weights. Written files use OpenCV's
/// default settings (filter SUB, zlib level 1, RLE strategy; with IMWRITE_PNG_COMPRESSION, that
/// level and zlib's default strategy): the same bytes as OpenCV's with the same libpng and zlib.
/// Any other format is refused with a message (imread: an empty image; imwrite, imencode: false).
#include <algorithm>
#include <cctype>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <png.h>
#include <zlib.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace {

bool hasPngExtension(const std::string& name) {
  const std::size_t dot = name.rfind('.');
  if (dot == std::string::npos) return false;
  std::string ext = name.substr(dot + 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == "png";
}

void quietWarning(png_structp, png_const_charp) {}

struct MemoryReader {
  const unsigned char* data;
  std::size_t size;
  std::size_t pos;
};

void readFromMemory(png_structp png, png_bytep out, png_size_t n) {
  auto* src = static_cast<MemoryReader*>(png_get_io_ptr(png));
  if (src->pos + n > src->size) png_error(png, "PNG data ends early");
  std::memcpy(out, src->data + src->pos, n);
  src->pos += n;
}

void writeToMemory(png_structp png, png_bytep data, png_size_t n) {
  auto* buf = static_cast<std::vector<uchar>*>(png_get_io_ptr(png));
  buf->insert(buf->end(), data, data + n);
}

void flushNothing(png_structp) {}

/// What the decoded rows hold once the transforms are set.
struct DecodedShape {
  png_uint_32 width = 0;
  png_uint_32 height = 0;
  int channels = 0;
  int bit_depth = 0;
};

/// libpng reports errors by longjmp: the two steps below hold no C++ objects with destructors.
bool readHeader(png_structp png, png_infop info, int flags, DecodedShape* shape) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  const int color_type = png_get_color_type(png, info);
  const int bit_depth = png_get_bit_depth(png, info);
  const bool has_trns = png_get_valid(png, info, PNG_INFO_tRNS) != 0;
  const bool unchanged = flags < 0;
  const bool keep_depth = unchanged || (flags & cv::IMREAD_ANYDEPTH) != 0;
  const bool source_colour = (color_type & PNG_COLOR_MASK_COLOR) != 0;
  const bool source_alpha = (color_type & PNG_COLOR_MASK_ALPHA) != 0 || has_trns;
  int channels = 1;
  if (unchanged) {
    channels = source_alpha ? 4 : (source_colour ? 3 : 1);
  } else if ((flags & cv::IMREAD_COLOR) != 0) {
    channels = 3;
  }
  if (bit_depth == 16 && !keep_depth) {
    png_set_strip_16(png);
  } else if (bit_depth == 16) {
    png_set_swap(png);  // PNG samples are big-endian
  }
  if (channels < 4) {
    png_set_strip_alpha(png);
  } else {
    png_set_tRNS_to_alpha(png);
  }
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (!source_colour && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (channels >= 3 && source_colour) {
    png_set_bgr(png);
  } else if (channels >= 3) {
    png_set_gray_to_rgb(png);
  } else if (source_colour) {
    png_set_rgb_to_gray(png, 1, 0.299, 0.587);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  shape->width = png_get_image_width(png, info);
  shape->height = png_get_image_height(png, info);
  shape->channels = png_get_channels(png, info);
  shape->bit_depth = png_get_bit_depth(png, info);
  return shape->channels == channels;
}

bool readRows(png_structp png, png_infop info, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_image(png, rows);
  png_read_end(png, info);
  return true;
}

/// Decodes from `file` or, when it is null, from `memory`.
cv::Mat decode(std::FILE* file, MemoryReader* memory, int flags, const std::string& what) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, quietWarning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  cv::Mat img;
  if (info != nullptr) {
    if (file != nullptr) {
      png_init_io(png, file);
    } else {
      png_set_read_fn(png, memory, readFromMemory);
    }
    DecodedShape shape;
    if (readHeader(png, info, flags, &shape) && (shape.bit_depth == 8 || shape.bit_depth == 16)) {
      img.create(static_cast<int>(shape.height), static_cast<int>(shape.width),
                 CV_MAKETYPE(shape.bit_depth == 16 ? CV_16U : CV_8U, shape.channels));
      std::vector<png_bytep> rows(shape.height);
      for (png_uint_32 y = 0; y < shape.height; ++y) rows[y] = img.ptr<png_byte>(static_cast<int>(y));
      if (!readRows(png, info, rows.data())) img.release();
    } else {
      std::fprintf(stderr, "imread(%s): not a PNG this build can read\n", what.c_str());
    }
  }
  png_destroy_read_struct(png ? &png : nullptr, info ? &info : nullptr, nullptr);
  return img;
}

bool writeImage(png_structp png, png_infop info, const cv::Mat& img, int level, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  if (level >= 0) {  // as OpenCV: a given level also means zlib's default strategy
    png_set_compression_level(png, level);
    png_set_compression_strategy(png, Z_DEFAULT_STRATEGY);
  } else {
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
    png_set_compression_level(png, Z_BEST_SPEED);
    png_set_compression_strategy(png, Z_RLE);
  }
  const int channels = img.channels();
  const int color_type = channels == 1   ? PNG_COLOR_TYPE_GRAY
                         : channels == 3 ? PNG_COLOR_TYPE_RGB
                                         : PNG_COLOR_TYPE_RGB_ALPHA;
  png_set_IHDR(png, info, static_cast<png_uint_32>(img.cols), static_cast<png_uint_32>(img.rows),
               img.depth() == CV_16U ? 16 : 8, color_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_BASE,
               PNG_FILTER_TYPE_BASE);
  png_write_info(png, info);
  png_set_bgr(png);
  if (img.depth() == CV_16U) png_set_swap(png);
  png_write_image(png, rows);
  png_write_end(png, info);
  return true;
}

/// Encodes to `file` or, when it is null, appends to `out`.
bool encode(std::FILE* file, std::vector<uchar>* out, const cv::Mat& img, const std::vector<int>& params,
            const std::string& what) {
  const int channels = img.channels();
  if (img.empty() || (img.depth() != CV_8U && img.depth() != CV_16U) ||
      (channels != 1 && channels != 3 && channels != 4)) {
    std::fprintf(stderr, "imwrite(%s): this build writes 8- or 16-bit PNG with 1, 3 or 4 channels\n", what.c_str());
    return false;
  }
  int level = -1;
  for (std::size_t i = 0; i + 1 < params.size(); i += 2) {
    if (params[i] == cv::IMWRITE_PNG_COMPRESSION) level = std::min(std::max(params[i + 1], 0), 9);
  }
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, quietWarning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  bool ok = false;
  if (info != nullptr) {
    if (file != nullptr) {
      png_init_io(png, file);
    } else {
      png_set_write_fn(png, out, writeToMemory, flushNothing);
    }
    std::vector<png_bytep> rows(static_cast<std::size_t>(img.rows));
    for (int y = 0; y < img.rows; ++y) rows[static_cast<std::size_t>(y)] = const_cast<png_bytep>(img.ptr<png_byte>(y));
    ok = writeImage(png, info, img, level, rows.data());
  }
  png_destroy_write_struct(png ? &png : nullptr, info ? &info : nullptr);
  return ok;
}

}  // namespace

namespace cv {

Mat imread(const String& filename, int flags) {
  std::FILE* f = std::fopen(filename.c_str(), "rb");
  if (f == nullptr) return Mat();
  unsigned char signature[8] = {};
  Mat img;
  if (std::fread(signature, 1, 8, f) == 8 && png_sig_cmp(signature, 0, 8) == 0) {
    std::rewind(f);
    img = decode(f, nullptr, flags, filename);
  } else {
    std::fprintf(stderr, "imread(%s): only PNG can be read by this build\n", filename.c_str());
  }
  std::fclose(f);
  return img;
}

Mat imdecode(InputArray buf, int flags) {
  const Mat data = buf.getMat();
  if (data.empty() || !data.isContinuous() || data.elemSize1() != 1) return Mat();
  MemoryReader reader{data.ptr<unsigned char>(), data.total() * data.elemSize(), 0};
  if (reader.size < 8 || png_sig_cmp(reader.data, 0, 8) != 0) {
    std::fprintf(stderr, "imdecode: only PNG can be read by this build\n");
    return Mat();
  }
  return decode(nullptr, &reader, flags, "memory");
}

bool imwrite(const String& filename, InputArray img, const std::vector<int>& params) {
  if (!hasPngExtension(filename)) {
    std::fprintf(stderr, "imwrite(%s): only .png can be written by this build\n", filename.c_str());
    return false;
  }
  std::FILE* f = std::fopen(filename.c_str(), "wb");
  if (f == nullptr) return false;
  const bool ok = encode(f, nullptr, img.getMat(), params, filename);
  return std::fclose(f) == 0 && ok;
}

bool imencode(const String& ext, InputArray img, std::vector<uchar>& buf, const std::vector<int>& params) {
  buf.clear();
  if (!hasPngExtension(ext)) {
    std::fprintf(stderr, "imencode(%s): only .png can be encoded by this build\n", ext.c_str());
    return false;
  }
  return encode(nullptr, &buf, img.getMat(), params, ext);
}

}  // namespace cv
