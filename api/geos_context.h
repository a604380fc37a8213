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

#include <geos_c.h>

#include "absl/status/status.h"
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
