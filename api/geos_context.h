// A GEOS context for one call, through GEOS's reentrant C API (nothing
// shared between threads), freed with it on every path; it keeps GEOS's
// last error text for the status a failure returns. For the code that
// calls GEOS (api/search_area.cc, client/sarenv/metrics.cc), which adds its
// own geometry builders by deriving from it.
//
//   const GeosContext geos;
//   GeosContext::Ptr point = geos.Own(GEOSGeom_createPointFromXY_r(geos.ctx(), x, y));
//   if (point == nullptr) return geos.Failure("point");
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <geos_c.h>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace oaipp::api {

class GeosContext {
 public:
  GeosContext() : ctx_(GEOS_init_r()) {
    GEOSContext_setErrorMessageHandler_r(ctx_, &GeosContext::OnError, this);
    GEOSContext_setNoticeMessageHandler_r(ctx_, &GeosContext::OnNotice, nullptr);
  }
  ~GeosContext() { GEOS_finish_r(ctx_); }
  GeosContext(const GeosContext&) = delete;
  GeosContext& operator=(const GeosContext&) = delete;

  struct Deleter {
    GEOSContextHandle_t ctx;
    void operator()(GEOSGeometry* g) const { GEOSGeom_destroy_r(ctx, g); }
  };
  using Ptr = std::unique_ptr<GEOSGeometry, Deleter>;
  struct PreparedDeleter {
    GEOSContextHandle_t ctx;
    void operator()(const GEOSPreparedGeometry* g) const { GEOSPreparedGeom_destroy_r(ctx, g); }
  };
  using PreparedPtr = std::unique_ptr<const GEOSPreparedGeometry, PreparedDeleter>;

  [[nodiscard]] GEOSContextHandle_t ctx() const { return ctx_; }
  // Owns `g` (null stays null).
  [[nodiscard]] Ptr Own(GEOSGeometry* g) const { return Ptr(g, Deleter{ctx_}); }
  // The union of `parts` (taken, freed on every path); they may overlap.
  [[nodiscard]] absl::StatusOr<Ptr> UnionOf(std::vector<Ptr> parts) const {
    std::vector<GEOSGeometry*> raw;
    raw.reserve(parts.size());
    for (Ptr& p : parts) raw.push_back(p.release());
    // A collection, not a multipolygon, which may not overlap.
    GEOSGeometry* collection = GEOSGeom_createCollection_r(
        ctx_, GEOS_GEOMETRYCOLLECTION, raw.data(), static_cast<unsigned>(raw.size()));
    if (collection == nullptr) {
      for (GEOSGeometry* g : raw) GEOSGeom_destroy_r(ctx_, g);
      return Failure("collection");
    }
    const Ptr all = Own(collection);  // owns the parts now
    Ptr united = Own(GEOSUnaryUnion_r(ctx_, all.get()));
    if (united == nullptr) return Failure("union");
    return united;
  }
  // `g` prepared for repeated predicates (null on failure); `g` must outlive it.
  [[nodiscard]] PreparedPtr Prepare(const GEOSGeometry* g) const {
    return PreparedPtr(GEOSPrepare_r(ctx_, g), PreparedDeleter{ctx_});
  }
  // Internal, naming `what` and GEOS's last error.
  [[nodiscard]] absl::Status Failure(absl::string_view what) const {
    return absl::InternalError(absl::StrCat("GEOS: ", what, ": ", last_error_));
  }

 private:
  static void OnError(const char* message, void* self) {
    static_cast<GeosContext*>(self)->last_error_ = message;
  }
  static void OnNotice(const char*, void*) {}

  GEOSContextHandle_t ctx_;
  std::string last_error_;
};

}  // namespace oaipp::api
