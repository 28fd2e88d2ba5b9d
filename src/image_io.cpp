// Raster readers for the `image` stage (PNG, OpenEXR, r16 + sidecar, GDAL), the raster cache,
// recipe-relative input paths and the GeoTIFF encoder. Contracts: include/relief/image.hpp.
//
// Every reader reads the header first and checks the dimensions against kMaxRasterPixels and the
// machine's memory before it allocates anything sized by them (no decompression bombs).
#include "relief/image.hpp"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <dlfcn.h>
#include <spng.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <list>
#include <map>
#include <mutex>
#include <sstream>
#include <system_error>

#include "gdal_dl.hpp"
#include "relief/error.hpp"
#include "relief/pipeline.hpp"

namespace relief {

#if RELIEF_HAVE_GDAL
namespace detail {
const Gdal* gdal() {
  static const Gdal* loaded = [] () -> const Gdal* {
    void* h = dlopen(RELIEF_GDAL_SONAME, RTLD_NOW | RTLD_LOCAL);
    if (!h) h = dlopen("libgdal.so", RTLD_NOW | RTLD_LOCAL);
    if (!h) return nullptr;
    static Gdal g;
    bool ok = true;
#define RELIEF_GDAL_LOAD(name)                                                  \
  g.name = reinterpret_cast<decltype(g.name)>(dlsym(h, #name));                 \
  ok = ok && g.name != nullptr;
    RELIEF_GDAL_LOAD(GDALAllRegister)
    RELIEF_GDAL_LOAD(GDALOpenEx)
    RELIEF_GDAL_LOAD(GDALClose)
    RELIEF_GDAL_LOAD(GDALGetRasterXSize)
    RELIEF_GDAL_LOAD(GDALGetRasterYSize)
    RELIEF_GDAL_LOAD(GDALGetRasterCount)
    RELIEF_GDAL_LOAD(GDALGetRasterBand)
    RELIEF_GDAL_LOAD(GDALGetBlockSize)
    RELIEF_GDAL_LOAD(GDALGetRasterDataType)
    RELIEF_GDAL_LOAD(GDALGetDataTypeSizeBytes)
    RELIEF_GDAL_LOAD(GDALGetMetadataItem)
    RELIEF_GDAL_LOAD(GDALRasterIO)
    RELIEF_GDAL_LOAD(GDALGetRasterNoDataValue)
    RELIEF_GDAL_LOAD(GDALGetGeoTransform)
    RELIEF_GDAL_LOAD(GDALSetGeoTransform)
    RELIEF_GDAL_LOAD(GDALGetProjectionRef)
    RELIEF_GDAL_LOAD(GDALGetDatasetDriver)
    RELIEF_GDAL_LOAD(GDALGetDriverShortName)
    RELIEF_GDAL_LOAD(GDALGetDriverByName)
    RELIEF_GDAL_LOAD(GDALCreate)
    RELIEF_GDAL_LOAD(GDALSetMetadataItem)
    RELIEF_GDAL_LOAD(CPLPushErrorHandler)
    RELIEF_GDAL_LOAD(CPLPopErrorHandler)
    RELIEF_GDAL_LOAD(CPLQuietErrorHandler)
    RELIEF_GDAL_LOAD(CPLGetLastErrorMsg)
    RELIEF_GDAL_LOAD(CPLErrorReset)
    RELIEF_GDAL_LOAD(CPLSetConfigOption)
    RELIEF_GDAL_LOAD(VSIFileFromMemBuffer)
    RELIEF_GDAL_LOAD(VSIFCloseL)
    RELIEF_GDAL_LOAD(VSIUnlink)
    RELIEF_GDAL_LOAD(VSIGetMemFileBuffer)
#undef RELIEF_GDAL_LOAD
    if (!ok) return nullptr;
    // No .aux.xml files written beside what we read; no network.
    g.CPLSetConfigOption("GDAL_PAM_ENABLED", "NO");
    g.CPLSetConfigOption("GDAL_DISABLE_READDIR_ON_OPEN", "EMPTY_DIR");
    g.GDALAllRegister();
    return &g;
  }();
  return loaded;
}
}  // namespace detail
bool gdal_available() { return detail::gdal() != nullptr; }
#else
bool gdal_available() { return false; }
#endif

namespace {

constexpr std::uint32_t kMaxSide = 1u << 20;            // per axis, before the pixel-count check
constexpr std::uintmax_t kMaxFileBytes = std::uintmax_t(2) << 30;

// Refuses dimensions that would not fit: kMaxRasterPixels, and a quarter of the machine's memory
// as floats (the decoded raster plus its decode buffer).
void check_dimensions(std::uint64_t w, std::uint64_t h, const std::string& what, const std::string& field_path) {
  if (w == 0 || h == 0) throw Error(field_path, what + " has no pixels (" + std::to_string(w) + "x" + std::to_string(h) + ")");
  if (w > kMaxSide || h > kMaxSide || w * h > kMaxRasterPixels)
    throw Error(field_path, what + " is " + std::to_string(w) + "x" + std::to_string(h) +
                                " pixels; at most " + std::to_string(kMaxRasterPixels) + " pixels are read");
  const std::uint64_t mem = physical_memory_bytes();
  if (mem > 0 && w * h * 8 > mem / 4)
    throw Error(field_path, what + " is " + std::to_string(w) + "x" + std::to_string(h) +
                                " pixels, more than a quarter of this machine's memory can hold");
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

RasterFormat guess(std::string_view bytes, const std::string& name) {
  static const unsigned char png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() >= 8 && std::memcmp(bytes.data(), png_sig, 8) == 0) return RasterFormat::Png;
  if (bytes.size() >= 4 && static_cast<unsigned char>(bytes[0]) == 0x76 && static_cast<unsigned char>(bytes[1]) == 0x2f &&
      static_cast<unsigned char>(bytes[2]) == 0x31 && static_cast<unsigned char>(bytes[3]) == 0x01)
    return RasterFormat::Exr;
  const std::string ext = lower(std::filesystem::path(name).extension().string());
  if (ext == ".r16" || ext == ".raw") return RasterFormat::R16;
  if (ext == ".png") return RasterFormat::Png;
  if (ext == ".exr") return RasterFormat::Exr;
  return RasterFormat::Gdal;
}

// ---- Relief sidecar (height.json) -------------------------------------------------------------

struct Sidecar {
  bool present = false;
  int width = 0, height = 0;
  bool has_range = false;
  double min_m = 0, max_m = 0, metres_per_pixel = 0;
};

// NAME.json beside NAME.png / NAME.r16, when it is a Relief sidecar; `required` makes a missing or
// malformed one an error (r16 that is not square).
Sidecar read_sidecar(const std::string& file, const std::string& field_path, bool required) {
  Sidecar s;
  std::filesystem::path p(file);
  p.replace_extension(".json");
  std::error_code ec;
  if (!std::filesystem::is_regular_file(p, ec) || std::filesystem::file_size(p, ec) > (1u << 20)) {
    if (required) throw Error(field_path, "cannot read the sidecar '" + p.string() + "' that gives the size of '" + file + "'");
    return s;
  }
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  try {
    const json j = parse_json(ss.str(), "'" + p.string() + "'", field_path);
    auto num = [&](const char* k) -> const json* {
      auto it = j.find(k);
      return it != j.end() && it->is_number() ? &*it : nullptr;
    };
    const json* w = num("width");
    const json* h = num("height");
    if (!j.is_object() || !w || !h || !w->is_number_integer() || !h->is_number_integer() || w->get<std::int64_t>() < 1 ||
        h->get<std::int64_t>() < 1 || w->get<std::int64_t>() > kMaxSide || h->get<std::int64_t>() > kMaxSide)
      throw Error(field_path, "'" + p.string() + "' is not a Relief heightmap sidecar (integer width and height)");
    s.width = int(w->get<std::int64_t>());
    s.height = int(h->get<std::int64_t>());
    const json* lo = num("min_m");
    const json* hi = num("max_m");
    if (lo && hi && std::isfinite(lo->get<double>()) && std::isfinite(hi->get<double>())) {
      s.has_range = true;
      s.min_m = lo->get<double>();
      s.max_m = hi->get<double>();
    }
    if (const json* mpp = num("metres_per_pixel"); mpp && mpp->get<double>() > 0 && std::isfinite(mpp->get<double>()))
      s.metres_per_pixel = mpp->get<double>();
    s.present = true;
  } catch (const Error&) {
    if (required) throw;
  }
  return s;
}

void apply_sidecar(Raster& r, const Sidecar& s) {
  if (!s.present || s.width != r.width || s.height != r.height) return;
  if (s.has_range) {
    r.has_range_m = true;
    r.min_m = s.min_m;
    r.max_m = s.max_m;
  }
  if (s.metres_per_pixel > 0) {
    r.has_geo = true;
    r.pixel_x_m = r.pixel_z_m = s.metres_per_pixel;
  }
}

// ---- PNG ------------------------------------------------------------------------------------------

Raster decode_png(std::string_view bytes, const std::string& name, const std::string& field_path, bool header_only) {
  std::unique_ptr<spng_ctx, void (*)(spng_ctx*)> ctx(spng_ctx_new(0), spng_ctx_free);
  if (!ctx) throw Error(field_path, "cannot decode '" + name + "': out of memory");
  auto fail = [&](int rc) -> void {
    throw Error(field_path, "'" + name + "' is not a PNG image that can be decoded: " + spng_strerror(rc));
  };
  spng_set_crc_action(ctx.get(), SPNG_CRC_USE, SPNG_CRC_USE);
  spng_set_image_limits(ctx.get(), kMaxSide, kMaxSide);
  spng_set_chunk_limits(ctx.get(), 1u << 24, 1u << 26);
  if (int rc = spng_set_png_buffer(ctx.get(), bytes.data(), bytes.size())) fail(rc);
  spng_ihdr ihdr{};
  if (int rc = spng_get_ihdr(ctx.get(), &ihdr)) fail(rc);
  if ((ihdr.bit_depth != 8 && ihdr.bit_depth != 16) || ihdr.color_type == SPNG_COLOR_TYPE_INDEXED)
    throw Error(field_path, "'" + name + "' has an unsupported pixel format (" + std::to_string(ihdr.bit_depth) + "-bit " +
                                (ihdr.color_type == SPNG_COLOR_TYPE_INDEXED ? "palette" : "samples") +
                                "); expected an 8- or 16-bit greyscale (or RGB) PNG");
  check_dimensions(ihdr.width, ihdr.height, "'" + name + "'", field_path);
  Raster r;
  r.width = int(ihdr.width);
  r.height = int(ihdr.height);
  r.format = "png";
  const bool grey = ihdr.color_type == SPNG_COLOR_TYPE_GRAYSCALE;
  r.code_max = grey && ihdr.bit_depth == 8 ? 255 : 65535;
  if (header_only) return r;
  const std::size_t n = std::size_t(r.width) * std::size_t(r.height);
  const int fmt = grey ? SPNG_FMT_PNG : SPNG_FMT_RGBA16;
  std::size_t size = 0;
  if (int rc = spng_decoded_image_size(ctx.get(), fmt, &size)) fail(rc);
  const std::size_t expect = grey ? n * (ihdr.bit_depth / 8) : n * 8;
  if (size != expect) throw Error(field_path, "'" + name + "': unexpected decoded size");
  std::vector<unsigned char> px(size);
  if (int rc = spng_decode_image(ctx.get(), px.data(), px.size(), fmt, 0)) fail(rc);
  r.values.resize(n);
  if (grey && ihdr.bit_depth == 8) {
    for (std::size_t k = 0; k < n; ++k) r.values[k] = float(px[k]);
  } else if (grey) {
    for (std::size_t k = 0; k < n; ++k) {
      std::uint16_t v;
      std::memcpy(&v, px.data() + 2 * k, 2);  // SPNG_FMT_PNG: 16-bit samples in host byte order
      r.values[k] = float(v);
    }
  } else {
    for (std::size_t k = 0; k < n; ++k) {
      std::uint16_t c[4];
      std::memcpy(c, px.data() + 8 * k, 8);  // host-endian RGBA16
      r.values[k] = float((double(c[0]) + double(c[1]) + double(c[2])) / 3.0);
    }
  }
  return r;
}

// ---- OpenEXR ----------------------------------------------------------------------------------

class MemoryIStream final : public Imf::IStream {
 public:
  explicit MemoryIStream(std::string_view b) : Imf::IStream("memory"), b_(b) {}
  bool read(char c[], int n) override {
    if (n < 0 || pos_ + std::uint64_t(n) > b_.size()) throw std::runtime_error("unexpected end of file");
    std::memcpy(c, b_.data() + pos_, std::size_t(n));
    pos_ += std::uint64_t(n);
    return pos_ < b_.size();
  }
  uint64_t tellg() override { return pos_; }
  void seekg(uint64_t pos) override { pos_ = pos; }

 private:
  std::string_view b_;
  std::uint64_t pos_ = 0;
};

Raster decode_exr(std::string_view bytes, const std::string& name, const std::string& field_path, bool header_only) {
  static std::once_flag limits;
  std::call_once(limits, [] { Imf::Header::setMaxImageSize(int(kMaxSide), int(kMaxSide)); });
  try {
    MemoryIStream in(bytes);
    Imf::InputFile file(in, 1);
    const Imath::Box2i dw = file.header().dataWindow();
    const std::int64_t w = std::int64_t(dw.max.x) - dw.min.x + 1, h = std::int64_t(dw.max.y) - dw.min.y + 1;
    if (w < 1 || h < 1) throw Error(field_path, "'" + name + "' has an empty data window");
    check_dimensions(std::uint64_t(w), std::uint64_t(h), "'" + name + "'", field_path);
    const Imf::ChannelList& ch = file.header().channels();
    const char* pick = nullptr;
    if (ch.findChannel("Y")) pick = "Y";
    else if (ch.findChannel("R")) pick = "R";
    else if (ch.begin() != ch.end()) pick = ch.begin().name();
    if (!pick) throw Error(field_path, "'" + name + "' has no channel");
    const Imf::Channel* c = ch.findChannel(pick);
    if (c->xSampling != 1 || c->ySampling != 1) throw Error(field_path, "'" + name + "': subsampled channels are not supported");
    Raster r;
    r.width = int(w);
    r.height = int(h);
    r.format = "exr";
    if (header_only) return r;
    r.values.assign(std::size_t(w) * std::size_t(h), 0.0f);
    Imf::FrameBuffer fb;
    char* base = reinterpret_cast<char*>(r.values.data()) -
                 (std::ptrdiff_t(dw.min.x) + std::ptrdiff_t(dw.min.y) * std::ptrdiff_t(w)) * std::ptrdiff_t(sizeof(float));
    fb.insert(pick, Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * std::size_t(w)));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return r;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(field_path, "'" + name + "' is not an OpenEXR image that can be read: " + printable_text(e.what()));
  }
}

// ---- r16 --------------------------------------------------------------------------------------

// `file_bytes`: the file's size (the bytes may be only its start when header_only).
Raster decode_r16(std::string_view bytes, std::uint64_t file_bytes, const std::string& name, const Sidecar& s,
                  const std::string& field_path, bool header_only) {
  std::uint64_t w = 0, h = 0;
  if (s.present) {
    w = std::uint64_t(s.width);
    h = std::uint64_t(s.height);
  } else {
    const std::uint64_t n = file_bytes / 2;
    w = h = std::uint64_t(std::llround(std::sqrt(double(n))));
    if (file_bytes % 2 != 0 || w * h != n || n == 0)
      throw Error(field_path, "'" + name + "' is " + std::to_string(file_bytes) +
                                  " bytes: without a sidecar (NAME.json) an r16 file must be square 16-bit samples");
  }
  check_dimensions(w, h, "'" + name + "'", field_path);
  if (file_bytes != w * h * 2)
    throw Error(field_path, "'" + name + "' is " + std::to_string(file_bytes) + " bytes; its sidecar says " + std::to_string(w) +
                                "x" + std::to_string(h) + " samples (" + std::to_string(w * h * 2) + " bytes)");
  Raster r;
  r.width = int(w);
  r.height = int(h);
  r.format = "r16";
  r.code_max = 65535;
  if (header_only) return r;
  r.values.resize(std::size_t(w * h));
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  for (std::size_t k = 0; k < r.values.size(); ++k) r.values[k] = float(unsigned(p[2 * k]) | (unsigned(p[2 * k + 1]) << 8));
  return r;
}

// ---- GDAL -------------------------------------------------------------------------------------

#if RELIEF_HAVE_GDAL
// The most a GDAL block of the file may take to decode (its width × height × data type × the bands
// stored interleaved with band 1): real elevation rasters use blocks of a few MiB at most.
constexpr std::uint64_t kMaxGdalBlockBytes = 256ull << 20;

Raster read_gdal(const std::string& open_name, const std::string& name, const std::string& field_path, bool header_only) {
  const detail::Gdal* g = detail::gdal();
  if (!g) throw Error(field_path, "'" + name + "' needs GDAL, which cannot be loaded on this machine (install libgdal32)");
  detail::GdalQuiet quiet(*g);
  GDALDatasetH ds = g->GDALOpenEx(open_name.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr);
  if (!ds) {
    const std::string why = printable_text(g->CPLGetLastErrorMsg());
    throw Error(field_path, "'" + name + "' is not a raster GDAL can read" + (why.empty() ? std::string() : ": " + why));
  }
  std::unique_ptr<void, void (*)(void*)> guard(ds, [](void* d) { detail::gdal()->GDALClose(d); });
  const int w = g->GDALGetRasterXSize(ds), h = g->GDALGetRasterYSize(ds);
  if (w < 1 || h < 1 || g->GDALGetRasterCount(ds) < 1) throw Error(field_path, "'" + name + "' has no raster band");
  check_dimensions(std::uint64_t(w), std::uint64_t(h), "'" + name + "'", field_path);
  // Reading band 1 makes GDAL decode whole blocks, and a block of a pixel-interleaved file holds
  // every band: a 9×9 TIFF that declares 256×256 tiles of 20 830 UInt32 bands asks for 5.5 GB per
  // tile (found by fuzz_image). Refused from the header, as the pixel count is.
  {
    GDALRasterBandH b1 = g->GDALGetRasterBand(ds, 1);
    int bx = 0, by = 0;
    if (b1) g->GDALGetBlockSize(b1, &bx, &by);
    const int type_bytes = b1 ? g->GDALGetDataTypeSizeBytes(g->GDALGetRasterDataType(b1)) : 0;
    const char* il = g->GDALGetMetadataItem(ds, "INTERLEAVE", "IMAGE_STRUCTURE");
    const std::uint64_t bands = il && std::string(il) == "PIXEL" ? std::uint64_t(g->GDALGetRasterCount(ds)) : 1;
    const std::uint64_t block = std::uint64_t(std::max(bx, 1)) * std::uint64_t(std::max(by, 1)) *
                                std::uint64_t(std::max(type_bytes, 1)) * bands;
    if (!b1 || bx < 1 || by < 1 || type_bytes < 1 || block > kMaxGdalBlockBytes)
      throw Error(field_path, "'" + name + "' stores its pixels in blocks of " + std::to_string(bx) + "x" + std::to_string(by) +
                                  " pixels of " + std::to_string(bands) + " interleaved band(s), " + std::to_string(block >> 20) +
                                  " MiB to read one; at most " + std::to_string(kMaxGdalBlockBytes >> 20) + " MiB are read per block");
  }
  Raster r;
  r.width = w;
  r.height = h;
  GDALDriverH drv = g->GDALGetDatasetDriver(ds);
  r.format = drv ? printable_text(g->GDALGetDriverShortName(drv)) : "gdal";
  double gt[6] = {0, 1, 0, 0, 0, 1};
  if (g->GDALGetGeoTransform(ds, gt) == CE_None) {
    if (gt[2] != 0 || gt[4] != 0) throw Error(field_path, "'" + name + "' has a rotated georeference, which is not supported");
    if (!(gt[1] > 0) || !(gt[5] < 0) || !std::isfinite(gt[0]) || !std::isfinite(gt[3]))
      throw Error(field_path, "'" + name + "' is not north-up (pixel size " + std::to_string(gt[1]) + " x " + std::to_string(gt[5]) + ")");
    double sx = gt[1], sz = -gt[5];
    const std::string wkt = g->GDALGetProjectionRef(ds) ? g->GDALGetProjectionRef(ds) : "";
    if (wkt.rfind("GEOGCS", 0) == 0 || wkt.rfind("GEOGCRS", 0) == 0) {
      const double lat = (gt[3] + gt[5] * h * 0.5) * M_PI / 180.0;
      sx *= 111320.0 * std::cos(lat);
      sz *= 110574.0;
    }
    r.has_geo = true;
    r.pixel_x_m = sx;
    r.pixel_z_m = sz;
    r.geo_x0 = gt[0] + 0.5 * gt[1];
    r.geo_z0 = -(gt[3] + 0.5 * gt[5]);
  }
  if (header_only) return r;
  GDALRasterBandH band = g->GDALGetRasterBand(ds, 1);
  r.values.assign(std::size_t(w) * std::size_t(h), 0.0f);
  if (!band || g->GDALRasterIO(band, GF_Read, 0, 0, w, h, r.values.data(), w, h, GDT_Float32, 0, 0) != CE_None) {
    const std::string why = printable_text(g->CPLGetLastErrorMsg());
    throw Error(field_path, "cannot read the pixels of '" + name + "'" + (why.empty() ? std::string() : ": " + why));
  }
  int has_nodata = 0;
  const double nodata = g->GDALGetRasterNoDataValue(band, &has_nodata);
  const float nd = float(nodata);
  float lowest = std::numeric_limits<float>::infinity();
  auto invalid = [&](float v) { return !std::isfinite(v) || (has_nodata && (v == nd || (std::isnan(nodata) && std::isnan(v)))); };
  for (float v : r.values)
    if (!invalid(v)) lowest = std::min(lowest, v);
  if (!std::isfinite(lowest)) throw Error(field_path, "'" + name + "' has no valid sample (all nodata)");
  for (float& v : r.values)
    if (invalid(v)) v = lowest;
  return r;
}
#endif

Raster decode_any(std::string_view bytes, std::uint64_t file_bytes, const std::string& name, RasterFormat format,
                  const std::string& field_path, const std::string* file, bool header_only) {
  if (format == RasterFormat::Auto) format = guess(bytes, name);
  switch (format) {
    case RasterFormat::Png: {
      Raster r = decode_png(bytes, name, field_path, header_only);
      if (file) apply_sidecar(r, read_sidecar(*file, field_path, false));
      return r;
    }
    case RasterFormat::Exr: return decode_exr(bytes, name, field_path, header_only);
    case RasterFormat::R16: {
      const Sidecar s = file ? read_sidecar(*file, field_path, false) : Sidecar{};
      Raster r = decode_r16(bytes, file_bytes, name, s, field_path, header_only);
      apply_sidecar(r, s);
      return r;
    }
    case RasterFormat::Gdal:
    default: {
#if RELIEF_HAVE_GDAL
      if (file) return read_gdal(*file, name, field_path, header_only);
      const detail::Gdal* g = detail::gdal();
      if (!g) throw Error(field_path, "'" + name + "' needs GDAL, which cannot be loaded on this machine");
      static std::atomic<std::uint64_t> counter{0};
      const std::string mem = "/vsimem/relief-decode-" + std::to_string(counter++);
      VSILFILE* f = g->VSIFileFromMemBuffer(mem.c_str(), reinterpret_cast<GByte*>(const_cast<char*>(bytes.data())),
                                            vsi_l_offset(bytes.size()), FALSE);
      if (!f) throw Error(field_path, "cannot decode '" + name + "'");
      g->VSIFCloseL(f);
      struct Unlink {
        const detail::Gdal* g;
        std::string n;
        ~Unlink() { g->VSIUnlink(n.c_str()); }
      } unlink{g, mem};
      return read_gdal(mem, name, field_path, header_only);
#else
      throw Error(field_path, "'" + name + "' is not a PNG, OpenEXR or r16 file, and this build has no GDAL");
#endif
    }
  }
}

std::string read_file_bytes(const std::string& file, const std::string& field_path, std::size_t limit) {
  std::error_code ec;
  const auto st = std::filesystem::status(file, ec);
  if (ec || !std::filesystem::exists(st)) throw Error(field_path, "cannot read '" + file + "': No such file or directory");
  if (!std::filesystem::is_regular_file(st)) throw Error(field_path, "cannot read '" + file + "': not a regular file");
  const auto size = std::filesystem::file_size(file, ec);
  if (ec || size > kMaxFileBytes) throw Error(field_path, "cannot read '" + file + "': " + (ec ? ec.message() : "larger than 2 GiB"));
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    const int e = errno;
    throw Error(field_path, "cannot read '" + file + "': " + std::error_code(e, std::generic_category()).message());
  }
  std::string bytes(std::min<std::size_t>(size, limit), '\0');
  in.read(bytes.data(), std::streamsize(bytes.size()));
  bytes.resize(std::size_t(in.gcount()));
  return bytes;
}

// ---- rasters in memory ------------------------------------------------------------------------

std::mutex memory_m;
std::map<std::string, std::weak_ptr<const Raster>, std::less<>> memory_rasters;

bool is_memory_path(const std::string& p) { return std::string_view(p).starts_with(kMemoryRasterPrefix); }

std::shared_ptr<const Raster> memory_raster(const std::string& path, const std::string& field_path) {
  std::lock_guard lock(memory_m);
  const auto it = memory_rasters.find(path);
  std::shared_ptr<const Raster> r = it == memory_rasters.end() ? nullptr : it->second.lock();
  if (!r) throw Error(field_path, "'" + path + "' is not held in memory (any more)");
  return r;
}

Raster read_or_probe(const std::string& file, RasterFormat format, const std::string& field_path, bool header_only) {
  if (file.empty()) throw Error(field_path, "expected a file name, got \"\"");
  if (is_memory_path(file)) {
    const std::shared_ptr<const Raster> m = memory_raster(file, field_path);
    if (!header_only) return *m;
    Raster r;  // the header: everything but the values
    r.width = m->width, r.height = m->height, r.code_max = m->code_max, r.format = m->format;
    r.has_range_m = m->has_range_m, r.min_m = m->min_m, r.max_m = m->max_m;
    r.has_geo = m->has_geo, r.geo_x0 = m->geo_x0, r.geo_z0 = m->geo_z0, r.pixel_x_m = m->pixel_x_m, r.pixel_z_m = m->pixel_z_m;
    return r;
  }
  if (file.rfind("/vsi", 0) == 0) throw Error(field_path, "GDAL virtual file systems (/vsi…) are not read: name a file");
  // The first bytes decide the format; GDAL reads its files itself (sidecars, overviews).
  std::string head = read_file_bytes(file, field_path, 16);
  RasterFormat f = format == RasterFormat::Auto ? guess(head, file) : format;
  if (f == RasterFormat::Gdal) return decode_any({}, 0, file, f, field_path, &file, header_only);
  std::error_code ec;
  const std::uint64_t size = std::filesystem::file_size(file, ec);
  // A header needs the start of the file (PNG: 33 bytes; an EXR header rarely 1 KiB; r16: nothing).
  const std::size_t want = !header_only ? kMaxFileBytes : f == RasterFormat::R16 ? 0 : std::size_t(16) << 20;
  const std::string bytes = read_file_bytes(file, field_path, want);
  return decode_any(bytes, size, file, f, field_path, &file, header_only);
}

}  // namespace

Raster read_raster(const std::string& file, RasterFormat format, const std::string& field_path) {
  return read_or_probe(file, format, field_path, false);
}
Raster probe_raster(const std::string& file, RasterFormat format, const std::string& field_path) {
  return read_or_probe(file, format, field_path, true);
}
Raster decode_raster(std::string_view bytes, const std::string& name, RasterFormat format, const std::string& field_path) {
  return decode_any(bytes, bytes.size(), name, format, field_path, nullptr, false);
}
Raster probe_raster_bytes(std::string_view bytes, const std::string& name, RasterFormat format, const std::string& field_path) {
  return decode_any(bytes, bytes.size(), name, format, field_path, nullptr, true);
}

void register_memory_raster(const std::string& path, std::shared_ptr<const Raster> raster) {
  std::lock_guard lock(memory_m);
  for (auto it = memory_rasters.begin(); it != memory_rasters.end();)
    it = it->second.expired() ? memory_rasters.erase(it) : std::next(it);
  memory_rasters[path] = std::move(raster);
}

std::shared_ptr<const Raster> cached_raster(const std::string& file, RasterFormat format, const std::string& field_path) {
  if (is_memory_path(file)) return memory_raster(file, field_path);
  std::error_code ec;
  const std::string abs = std::filesystem::absolute(file, ec).lexically_normal().string();
  const auto size = std::filesystem::file_size(file, ec);
  const auto mtime = std::filesystem::last_write_time(file, ec).time_since_epoch().count();
  const std::string key = abs + '\n' + std::to_string(int(format)) + '\n' + std::to_string(ec ? 0 : size) + '\n' +
                          std::to_string(ec ? 0 : mtime);
  static std::mutex m;
  static std::list<std::pair<std::string, std::shared_ptr<const Raster>>> lru;
  {
    std::lock_guard<std::mutex> lock(m);
    for (auto it = lru.begin(); it != lru.end(); ++it)
      if (it->first == key && !ec) {
        lru.splice(lru.begin(), lru, it);
        return lru.front().second;
      }
  }
  auto r = std::make_shared<const Raster>(read_raster(file, format, field_path));
  std::lock_guard<std::mutex> lock(m);
  lru.emplace_front(key, r);
  while (lru.size() > 4) lru.pop_back();
  return r;
}

// ---- GeoTIFF ----------------------------------------------------------------------------------

std::string encode_geotiff_height(const Terrain& t) {
  const Frame& f = t.frame;
  const Layer& h = t.get("height");
  if (h.channels != 1 || h.data.size() != f.count()) throw Error("height", "layer size does not match the frame");
#if RELIEF_HAVE_GDAL
  const detail::Gdal* g = detail::gdal();
  if (!g) throw Error("formats", "geotiff needs GDAL, which cannot be loaded on this machine (install libgdal32)");
  detail::GdalQuiet quiet(*g);
  GDALDriverH drv = g->GDALGetDriverByName("GTiff");
  if (!drv) throw Error("formats", "geotiff: GDAL has no GTiff driver");
  static std::atomic<std::uint64_t> counter{0};
  const std::string mem = "/vsimem/relief-geotiff-" + std::to_string(counter++) + ".tif";
  char opt0[] = "COMPRESS=DEFLATE", opt1[] = "PREDICTOR=3", opt2[] = "TILED=YES";
  char* options[] = {opt0, opt1, opt2, nullptr};
  GDALDatasetH ds = g->GDALCreate(drv, mem.c_str(), f.nx, f.nz, 1, GDT_Float32, options);
  if (!ds) throw Error("formats", "geotiff: " + printable_text(g->CPLGetLastErrorMsg()));
  const double cell = f.cell_m();
  double gt[6] = {f.x0_m() - cell / 2, cell, 0, -(f.z0_m() - cell / 2), 0, -cell};
  g->GDALSetGeoTransform(ds, gt);
  g->GDALSetMetadataItem(ds, "AREA_OR_POINT", "Area", nullptr);
  std::vector<float> m(f.count());
  for (std::size_t k = 0; k < m.size(); ++k) m[k] = float(f.y_m(double(h.data[k])));
  GDALRasterBandH band = g->GDALGetRasterBand(ds, 1);
  const CPLErr err = g->GDALRasterIO(band, GF_Write, 0, 0, f.nx, f.nz, m.data(), f.nx, f.nz, GDT_Float32, 0, 0);
  g->GDALClose(ds);
  vsi_l_offset len = 0;
  GByte* buf = g->VSIGetMemFileBuffer(mem.c_str(), &len, FALSE);
  std::string out;
  if (buf && err == CE_None) out.assign(reinterpret_cast<const char*>(buf), std::size_t(len));
  g->VSIUnlink(mem.c_str());
  if (out.empty()) throw Error("formats", "geotiff: GDAL could not write the file");
  return out;
#else
  throw Error("formats", "geotiff needs GDAL, and this build has none");
#endif
}

}  // namespace relief
