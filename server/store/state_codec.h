// A mission's state <-> the bytes of its snapshot (oaipp.store.MissionState):
// doubles are kept as their bytes and the covariance as its lower triangle
// (it is symmetric bit for bit), so a decoded state equals the encoded one
// exactly and takes half the room of the full matrix.
//
//   const std::string bytes = EncodeMissionState(mission->CaptureState());
//   OAIPP_ASSIGN_OR_RETURN(MissionState state, DecodeMissionState(bytes));
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "server/mission_state.h"

namespace oaipp::server {

[[nodiscard]] std::string EncodeMissionState(const MissionState& state);
// DataLoss when the bytes are not a state this server wrote (they do not
// parse, sizes disagree, a value is out of range).
[[nodiscard]] absl::StatusOr<MissionState> DecodeMissionState(const std::string& bytes);

}  // namespace oaipp::server
