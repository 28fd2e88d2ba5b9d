#pragma once
// Internal: GDAL's C API loaded at run time (dlopen) on first use.
//
// Why not link it: libgdal pulls in over a hundred shared libraries, and loading them took about
// 0.4 s per process here, which every `relief` run (and every test that starts one) would pay
// whether or not it reads a GeoTIFF. Only the functions below are used; their types come from
// GDAL's own headers, so a signature change is a compile error.
#if RELIEF_HAVE_GDAL
#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_vsi.h>
#include <gdal.h>

namespace relief::detail {

struct Gdal {
#define RELIEF_GDAL_FN(name) decltype(&::name) name = nullptr;
  RELIEF_GDAL_FN(GDALAllRegister)
  RELIEF_GDAL_FN(GDALOpenEx)
  RELIEF_GDAL_FN(GDALClose)
  RELIEF_GDAL_FN(GDALGetRasterXSize)
  RELIEF_GDAL_FN(GDALGetRasterYSize)
  RELIEF_GDAL_FN(GDALGetRasterCount)
  RELIEF_GDAL_FN(GDALGetRasterBand)
  RELIEF_GDAL_FN(GDALGetBlockSize)
  RELIEF_GDAL_FN(GDALGetRasterDataType)
  RELIEF_GDAL_FN(GDALGetDataTypeSizeBytes)
  RELIEF_GDAL_FN(GDALGetMetadataItem)
  RELIEF_GDAL_FN(GDALRasterIO)
  RELIEF_GDAL_FN(GDALGetRasterNoDataValue)
  RELIEF_GDAL_FN(GDALGetGeoTransform)
  RELIEF_GDAL_FN(GDALSetGeoTransform)
  RELIEF_GDAL_FN(GDALGetProjectionRef)
  RELIEF_GDAL_FN(GDALGetDatasetDriver)
  RELIEF_GDAL_FN(GDALGetDriverShortName)
  RELIEF_GDAL_FN(GDALGetDriverByName)
  RELIEF_GDAL_FN(GDALCreate)
  RELIEF_GDAL_FN(GDALSetMetadataItem)
  RELIEF_GDAL_FN(CPLPushErrorHandler)
  RELIEF_GDAL_FN(CPLPopErrorHandler)
  RELIEF_GDAL_FN(CPLQuietErrorHandler)
  RELIEF_GDAL_FN(CPLGetLastErrorMsg)
  RELIEF_GDAL_FN(CPLErrorReset)
  RELIEF_GDAL_FN(CPLSetConfigOption)
  RELIEF_GDAL_FN(VSIFileFromMemBuffer)
  RELIEF_GDAL_FN(VSIFCloseL)
  RELIEF_GDAL_FN(VSIUnlink)
  RELIEF_GDAL_FN(VSIGetMemFileBuffer)
#undef RELIEF_GDAL_FN
};

// GDAL, loaded and registered once (thread-safe); nullptr when the library cannot be loaded.
const Gdal* gdal();

// Quiet GDAL errors on this thread for the scope (GDAL prints to stderr by default).
class GdalQuiet {
 public:
  explicit GdalQuiet(const Gdal& g) : g_(g) {
    g_.CPLPushErrorHandler(g_.CPLQuietErrorHandler);
    g_.CPLErrorReset();
  }
  ~GdalQuiet() { g_.CPLPopErrorHandler(); }
  GdalQuiet(const GdalQuiet&) = delete;
  GdalQuiet& operator=(const GdalQuiet&) = delete;

 private:
  const Gdal& g_;
};

}  // namespace relief::detail
#endif
