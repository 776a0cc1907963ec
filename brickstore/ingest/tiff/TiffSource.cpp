// TIFF stack input through libtiff: the pages of one file, or single-page files in a given order, as z-slices.
// Every page is checked (size, one channel, sample type) when the source opens; pixels are read a page at a time.
#include <tiffio.h>
#include <unistd.h>

#include <cstdarg>
#include <cstdio>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "brickstore/format/Convert.h"
#include "brickstore/format/Errors.h"
#include "brickstore/ingest/tiff/TiffSource.h"

namespace voxbrick::store {
namespace {

/// An open TIFF file whose libtiff errors are kept (for our messages) rather than printed.
class TiffFile {
 public:
  explicit TiffFile(std::string path) : mPath(std::move(path)) {
    TIFFOpenOptions* options = TIFFOpenOptionsAlloc();
    TIFFOpenOptionsSetErrorHandlerExtR(options, &TiffFile::onError, this);
    TIFFOpenOptionsSetWarningHandlerExtR(options, &TiffFile::onWarning, this);
    mTiff = TIFFOpenExt(mPath.c_str(), "r", options);
    TIFFOpenOptionsFree(options);
    if (!mTiff) throw InputError(mPath + ": not a readable TIFF file" + detail());
    mPageOffsets.push_back(TIFFCurrentDirOffset(mTiff));
  }
  ~TiffFile() {
    if (mTiff) TIFFClose(mTiff);
  }
  TiffFile(const TiffFile&) = delete;
  TiffFile& operator=(const TiffFile&) = delete;

  TIFF* get() const { return mTiff; }
  const std::string& path() const { return mPath; }
  /// " (libtiff: LAST ERROR)", or "" when libtiff said nothing.
  std::string detail() const { return mError.empty() ? "" : " (libtiff: " + mError + ")"; }

  /// Moves to the next page: true if there is one, false at the last; throws InputError when the next page's
  /// directory is damaged (libtiff returns 0 for both, and tells them apart only by reporting an error) and when the
  /// page chain loops or repeats a page (libtiff only warns of a loop, then ends the chain early).
  bool nextPage(const std::string& where) {
    mError.clear();
    const uint64_t current = TIFFCurrentDirOffset(mTiff);
    if (TIFFReadDirectory(mTiff)) {
      const uint64_t offset = TIFFCurrentDirOffset(mTiff);
      refuseRepeat(where, offset);
      mPageOffsets.push_back(offset);
      return true;
    }
    if (!mError.empty()) throw InputError(where + ": cannot read the next page" + detail());
    const uint64_t next = statedNextOffset(current);
    if (next != 0) {
      refuseRepeat(where, next);
      throw InputError(where + ": its next-page (IFD) offset " + std::to_string(next) + " leads to no page");
    }
    return false;
  }

 private:
  /// Refuses a next-page offset `offset` of page `where` that is a page already read.
  void refuseRepeat(const std::string& where, uint64_t offset) const {
    for (size_t page = 0; page < mPageOffsets.size(); ++page)
      if (mPageOffsets[page] == offset)
        throw InputError(where + ": its next-page (IFD) offset " + std::to_string(offset) + " points back to page " +
                         std::to_string(page + 1) + "; the page chain loops");
  }

  /// The next-page offset that the directory at `dir` states (0: the last page), read from the file itself.
  uint64_t statedNextOffset(uint64_t dir) const {
    if (TIFFIsBigTIFF(mTiff)) return readAt<uint64_t>(dir + 8 + 20 * readAt<uint64_t>(dir));
    return readAt<uint32_t>(dir + 2 + 12 * uint64_t(readAt<uint16_t>(dir)));
  }

  /// The value of type T at `offset` in the file's byte order; 0 where the file ends first.
  template <typename T>
  T readAt(uint64_t offset) const {
    T v = 0;
    if (pread(TIFFFileno(mTiff), &v, sizeof v, off_t(offset)) != ssize_t(sizeof v)) return 0;
    if (!TIFFIsByteSwapped(mTiff)) return v;
    if constexpr (sizeof(T) == 2) TIFFSwabShort(&v);
    if constexpr (sizeof(T) == 4) TIFFSwabLong(&v);
    if constexpr (sizeof(T) == 8) TIFFSwabLong8(&v);
    return v;
  }

  static int onError(TIFF*, void* self, const char* module, const char* format, va_list args) {
    char text[512];
    std::vsnprintf(text, sizeof text, format, args);
    static_cast<TiffFile*>(self)->mError = std::string(module ? module : "") + (module ? ": " : "") + text;
    return 1;
  }
  static int onWarning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

  std::string mPath;
  std::string mError;
  TIFF* mTiff = nullptr;
  std::vector<uint64_t> mPageOffsets;  // the directory offset of each page read so far
};

/// The layout of one page, as the store needs it.
struct PageFormat {
  uint32_t width = 0, height = 0;
  ValueType type = ValueType::U8;

  bool operator==(const PageFormat&) const = default;
};

/// "a.tif" or "a.tif page 3" (pages counted from 1).
std::string pageName(const TiffFile& f, int page, bool multiPage) {
  return multiPage ? f.path() + " page " + std::to_string(page + 1) : f.path();
}

template <typename T>
T field(const TiffFile& f, uint32_t tag, T fallback) {
  T value = fallback;
  TIFFGetFieldDefaulted(f.get(), tag, &value);
  return value;
}

/// The current page's format; refuses colour, tiles and sample types other than u8, u16, i16 and f32, by name.
PageFormat readFormat(const TiffFile& f, const std::string& where) {
  PageFormat p;
  if (!TIFFGetField(f.get(), TIFFTAG_IMAGEWIDTH, &p.width) || !TIFFGetField(f.get(), TIFFTAG_IMAGELENGTH, &p.height) ||
      p.width == 0 || p.height == 0)
    throw InputError(where + ": no image size" + f.detail());
  const auto samples = field<uint16_t>(f, TIFFTAG_SAMPLESPERPIXEL, 1);
  const auto photometric = field<uint16_t>(f, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  if (samples != 1 || photometric == PHOTOMETRIC_PALETTE)
    throw InputError(where + ": colour pages are not supported (" + std::to_string(samples) + " samples per pixel" +
                     (photometric == PHOTOMETRIC_PALETTE ? ", palette" : "") +
                     "); convert the stack to one greyscale channel first");
  if (TIFFIsTiled(f.get())) throw InputError(where + ": tiled TIFF pages are not supported (only strips)");
  const auto bits = field<uint16_t>(f, TIFFTAG_BITSPERSAMPLE, 1);
  const auto format = field<uint16_t>(f, TIFFTAG_SAMPLEFORMAT, SAMPLEFORMAT_UINT);
  if (bits == 8 && format == SAMPLEFORMAT_UINT)
    p.type = ValueType::U8;
  else if (bits == 16 && format == SAMPLEFORMAT_UINT)
    p.type = ValueType::U16;
  else if (bits == 16 && format == SAMPLEFORMAT_INT)
    p.type = ValueType::I16;
  else if (bits == 32 && format == SAMPLEFORMAT_IEEEFP)
    p.type = ValueType::F32;
  else {
    const char* kind = format == SAMPLEFORMAT_INT      ? "signed integer"
                       : format == SAMPLEFORMAT_IEEEFP ? "float"
                                                       : "unsigned integer";
    throw InputError(where + ": " + std::to_string(bits) + "-bit " + kind +
                     " samples are not supported (8/16-bit unsigned, 16-bit signed or 32-bit float)");
  }
  return p;
}

/// Refuses a page whose format differs from the first page's.
void checkSame(const PageFormat& first, const PageFormat& p, const std::string& firstName, const std::string& where) {
  if (p.width != first.width || p.height != first.height)
    throw InputError(where + ": page size " + std::to_string(p.width) + "x" + std::to_string(p.height) +
                     " differs from " + std::to_string(first.width) + "x" + std::to_string(first.height) + " of " +
                     firstName);
  if (p.type != first.type)
    throw InputError(where + ": sample type " + std::string(valueTypeName(p.type)) + " differs from " +
                     std::string(valueTypeName(first.type)) + " of " + firstName);
}

/// Reads the current page, row by row, into dst (width * height values of the page's type).
void readPage(const TiffFile& f, const PageFormat& p, const std::string& where, unsigned char* dst) {
  const size_t rowBytes = size_t(p.width) * valueSize(p.type);
  if (size_t(TIFFScanlineSize64(f.get())) != rowBytes)
    throw InputError(where + ": unexpected scanline size " + std::to_string(TIFFScanlineSize64(f.get())) +
                     " bytes, expected " + std::to_string(rowBytes));
  for (uint32_t y = 0; y < p.height; ++y)
    if (TIFFReadScanline(f.get(), dst + y * rowBytes, y, 0) < 0)
      throw InputError(where + ": could not read row " + std::to_string(y) + f.detail());
}

class TiffSource final : public VolumeSource {
 public:
  TiffSource(VolumeInfo info, std::vector<std::string> files, PageFormat format)
      : mInfo(std::move(info)), mFiles(std::move(files)), mFormat(format) {}

  const VolumeInfo& info() const override { return mInfo; }

  void readSlices(int64_t count, void* dst) override {
    if (count < 0 || mNextZ + count > mInfo.dims.z) throw InputError(mFiles.front() + ": read past the last page");
    const int64_t plane = mInfo.dims.x * mInfo.dims.y * int64_t(valueSize(mInfo.type));
    for (int64_t k = 0; k < count; ++k, ++mNextZ) readNext(static_cast<unsigned char*>(dst) + k * plane);
  }

 private:
  /// Page mNextZ: the next page of the one file, or the next file's only page. Formats are checked again, since a
  /// file may change between open and read.
  void readNext(unsigned char* dst) {
    const bool multiPage = mFiles.size() == 1;
    if (!multiPage)
      mFile = std::make_unique<TiffFile>(mFiles[size_t(mNextZ)]);
    else if (!mFile)
      mFile = std::make_unique<TiffFile>(mFiles.front());
    else if (!mFile->nextPage(pageName(*mFile, int(mNextZ) - 1, true)))
      throw InputError(pageName(*mFile, int(mNextZ), true) + ": missing" + mFile->detail());
    const std::string where = pageName(*mFile, int(mNextZ), multiPage);
    checkSame(mFormat, readFormat(*mFile, where), "the first page", where);
    readPage(*mFile, mFormat, where, dst);
  }

  VolumeInfo mInfo;
  std::vector<std::string> mFiles;
  PageFormat mFormat;
  std::unique_ptr<TiffFile> mFile;
  int64_t mNextZ = 0;
};

/// Checks every page of one multi-page file; returns the format and the page count.
std::pair<PageFormat, int64_t> scanPages(const std::string& path) {
  TiffFile f(path);
  const PageFormat first = readFormat(f, pageName(f, 0, true));
  int64_t pages = 1;
  while (f.nextPage(pageName(f, int(pages) - 1, true))) {
    checkSame(first, readFormat(f, pageName(f, int(pages), true)), pageName(f, 0, true), pageName(f, int(pages), true));
    ++pages;
  }
  return {first, pages};
}

/// Checks a list of single-page files; returns the format of the first.
PageFormat scanFiles(const std::vector<std::string>& files) {
  PageFormat first;
  for (size_t i = 0; i < files.size(); ++i) {
    TiffFile f(files[i]);
    const PageFormat p = readFormat(f, f.path());
    if (f.nextPage(f.path()))
      throw InputError(f.path() +
                       ": has more than one page; a stack of files needs single-page files (or give one "
                       "multi-page file)");
    if (i == 0)
      first = p;
    else
      checkSame(first, p, files.front(), f.path());
  }
  return first;
}

}  // namespace

std::unique_ptr<VolumeSource> openTiffSource(const std::vector<std::string>& files, const SourceOptions& options) {
  if (files.empty()) throw InputError("no TIFF files");
  PageFormat format;
  int64_t pages = int64_t(files.size());
  if (files.size() == 1)
    std::tie(format, pages) = scanPages(files.front());
  else
    format = scanFiles(files);

  VolumeInfo info;
  info.dims = {int64_t(format.width), int64_t(format.height), pages};
  checkedVolumeBytes(info.dims, valueSize(format.type), files.front());
  checkSliceFitsMemory(info.dims.x, info.dims.y, valueSize(format.type), options, files.front(),
                       "ImageWidth x ImageLength");
  // Resolution tags are rarely the voxel size of a microscope stack, and carry no z spacing: --spacing or 1,1,1.
  info.spacing = options.spacingGiven ? options.spacing : Vec3d{1, 1, 1};
  checkSpacing(info.spacing, files.front());
  info.type = format.type;
  info.description = "TIFF " + std::string(valueTypeName(format.type)) + " " + dimsText(info.dims) + " (" +
                     (files.size() == 1 ? std::to_string(pages) + " pages of " + baseName(files.front())
                                        : std::to_string(files.size()) + " files from " + baseName(files.front())) +
                     (options.spacingGiven ? ")" : "; spacing 1,1,1: give --spacing)");
  return std::make_unique<TiffSource>(std::move(info), files, format);
}

}  // namespace voxbrick::store
