// oaipp-server's command line: one flag per ServerOptions field, declared
// once (server/flags/*.cc, a file per group, which --help lists apart).
// Programs that run a server take them by linking oaipp::server_flags.
//
//   oaipp::server::SetServerFlagsUsage("OA-IPP planning service");
//   absl::ParseCommandLine(argc, argv);
//   const oaipp::server::ServerOptions options = oaipp::server::ServerOptionsFromFlags();
#pragma once

#include "absl/strings/string_view.h"
#include "server/server_options.h"

namespace oaipp::server {

// Where every flag in server/flags/*.cc starts: ServerOptions' own defaults.
// One object for all the files (inline), defined before any flag that reads
// it, so it is initialised first.
inline const ServerOptions kFlagDefaults;

// The flags' values (their defaults where not given).
[[nodiscard]] ServerOptions ServerOptionsFromFlags();

// Sets the program's usage message, and makes --help (and --helpshort)
// list exactly the server's own flags, grouped by their file under
// server/flags/; --helpfull still lists gRPC's and Abseil's too. Call
// before absl::ParseCommandLine.
void SetServerFlagsUsage(absl::string_view usage);

}  // namespace oaipp::server
