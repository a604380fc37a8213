#include "client/cli/export_files.h"

#include <filesystem>
#include <fstream>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace oaipp::client {

absl::Status WriteExportFiles(const std::string& dir, const v1::ExportPathResponse& exported) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) {
    return absl::InternalError(absl::StrCat("cannot create '", dir, "': ", error.message()));
  }
  std::ofstream plan(dir + "/mission.plan");
  plan << exported.qgc_plan_json() << "\n";
  std::ofstream items(dir + "/mission_items.csv");
  items << "seq,frame,command,current,autocontinue,param1,param2,param3,param4,x,y,z,"
           "mission_type\n";
  for (const v1::MissionItem& m : exported.mission_items()) {
    items << absl::StrCat(m.seq(), ",", m.frame(), ",", m.command(), ",", m.current(), ",",
                          m.autocontinue(), ",", m.param1(), ",", m.param2(), ",", m.param3(), ",",
                          m.param4(), ",", m.x(), ",", m.y(), ",", m.z(), ",", m.mission_type(),
                          "\n");
  }
  std::ofstream setpoints(dir + "/setpoints.csv");
  setpoints << "t_s,north_m,east_m,down_m,vn_m_s,ve_m_s,vd_m_s,an_m_s2,ae_m_s2,ad_m_s2,yaw_deg\n";
  for (const v1::Setpoint& p : exported.setpoints()) {
    const auto& x = p.position_ned_m();
    const auto& v = p.velocity_ned_m_s();
    const auto& a = p.acceleration_ned_m_s2();
    setpoints << absl::StrFormat("%.3f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.1f\n",
                                 p.t_s(), x.x(), x.y(), x.z(), v.x(), v.y(), v.z(), a.x(), a.y(),
                                 a.z(), p.yaw_deg());
  }
  plan.close();
  items.close();
  setpoints.close();
  if (!plan || !items || !setpoints) {
    return absl::InternalError(absl::StrCat("cannot write the export files in '", dir, "'"));
  }
  return absl::OkStatus();
}

}  // namespace oaipp::client
