// DP service names (profibus_sim/dp/dp_service.hpp): the one place they become text, and the FDL
// describer's services that are DP services named through it.
#include "profibus_sim/dp/dp_service.hpp"

#include <gtest/gtest.h>

#include "profibus_sim/fdl/fdl_describe.hpp"

namespace candp2 {
namespace {

TEST(DpService, NamesAsTheStandardSpellsThem) {
  EXPECT_EQ(dp::to_string(dp::Service::SlaveDiag), "Slave_Diag");
  EXPECT_EQ(dp::to_string(dp::Service::SetPrm), "Set_Prm");
  EXPECT_EQ(dp::to_string(dp::Service::ChkCfg), "Chk_Cfg");
  EXPECT_EQ(dp::to_string(dp::Service::GetCfg), "Get_Cfg");
  EXPECT_EQ(dp::to_string(dp::Service::DataExchange), "Data_Exchange");
  EXPECT_EQ(dp::to_string(dp::Service::GlobalControl), "Global_Control");
  EXPECT_EQ(dp::to_string(dp::Service::SetSlaveAdd), "Set_Slave_Add");
  EXPECT_EQ(dp::to_string(dp::Service::RdInp), "Rd_Inp");
  EXPECT_EQ(dp::to_string(dp::Service::RdOutp), "Rd_Outp");
  EXPECT_EQ(dp::to_string(static_cast<dp::Service>(200)), "?");
}

TEST(DpService, FdlServicesThatAreDpServicesUseTheirNames) {
  using fdl::Service;
  for (Service s : {Service::DataExchange, Service::SetSlaveAdd, Service::RdInp, Service::RdOutp,
                    Service::GlobalControl, Service::GetCfg, Service::SlaveDiag, Service::SetPrm,
                    Service::ChkCfg}) {
    const auto dp = fdl::dp_service(s);
    ASSERT_TRUE(dp) << static_cast<int>(s);
    EXPECT_EQ(fdl::to_string(s), dp::to_string(*dp));
  }
  EXPECT_EQ(fdl::dp_service(Service::ChkCfg), dp::Service::ChkCfg);
  for (Service s :
       {Service::Unknown, Service::FdlStatus, Service::OtherSap, Service::Token, Service::Ack})
    EXPECT_FALSE(fdl::dp_service(s)) << fdl::to_string(s);
  EXPECT_EQ(fdl::to_string(Service::Unknown), "?");
  EXPECT_EQ(fdl::to_string(Service::FdlStatus), "FDL_Status");
  EXPECT_EQ(fdl::to_string(Service::OtherSap), "SAP");
  EXPECT_EQ(fdl::to_string(Service::Token), "Token");
  EXPECT_EQ(fdl::to_string(Service::Ack), "Ack");
}

}  // namespace
}  // namespace candp2
