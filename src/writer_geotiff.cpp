// The `geotiff` writer: height.tif, the height in metres as one Float32 band with the world's
// extent as its GeoTransform (encode_geotiff_height, relief/image.hpp), the format QGIS, Houdini,
// Gaea and World Machine import. GDAL writes it into memory (/vsimem/) and the bytes go through
// the Output like every other file.
#include "relief/image.hpp"
#include "writer_defs.hpp"

namespace relief::detail {

WriterDef geotiff_writer() {
  WriterDef d{"geotiff", "GeoTIFF of the height in metres (Float32, sea = 0) with the world's extent as its transform (GDAL)",
              {"height.tif"}, false, [](const Terrain& t, const WriteContext& ctx, Output& out) {
                if (!t.has("height")) throw Error("formats", "geotiff needs a 'height' layer (no elevation stage in the recipe?)");
                out.put("height.tif", encode_geotiff_height(t));
                if (ctx.progress) ctx.progress("geotiff", 1.0);
              }};
  return d;
}

}  // namespace relief::detail
