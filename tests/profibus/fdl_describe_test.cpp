// The telegram describer (profibus_sim/fdl/fdl_describe.hpp) on the capture in
// docs/profibus.md "A real master's first telegrams" and the responses of the slave front end.
#include "profibus_sim/fdl/fdl_describe.hpp"

#include <gtest/gtest.h>

#include "fdl_capture.hpp"

namespace candp2::fdl::test {
namespace {

std::string line(Describer& d, const char* hex) {
  const auto r = decode(B(hex));
  EXPECT_EQ(r.error, Error::None) << hex;
  return d.describe(r.telegram.value_or(Telegram{})).text;
}

TEST(FdlDescribe, CaptureRequestsAndResponses) {
  Describer d;
  EXPECT_EQ(line(d, kCapFdlStatus), "SD1 2->3 FDL_Status.req");
  EXPECT_EQ(line(d, "10 02 03 00 05 16"), "SD1 3->2 OK FDL_Status.res");
  EXPECT_EQ(line(d, kCapSlaveDiag1), "SD2 2->3 [62->60] SRD_high FCB=1 FCV=0 Slave_Diag.req");
  EXPECT_EQ(line(d, "68 10 10 68 82 83 08 3E 3C 02 05 00 FF 04 A4 05 04 00 00 00 3E 16"),
            "SD2 3->2 [60->62] DL Slave_Diag.res: Station_Not_Ready Prm_Req, master none, "
            "ident 04A4, ext 05 04 00 00 00");
  EXPECT_EQ(line(d, kCapSetPrm),
            "SD2 2->3 [62->61] SRD_high FCB=0 FCV=1 Set_Prm.req: WD on 300 ms (30x1), Lock_Req, "
            "min_TSDR 0, ident 04A4, group 00, user 00 02 00 01 00 00 FF FF FF");
  EXPECT_EQ(line(d, "E5"), "SC Set_Prm.res 3->2");
  EXPECT_EQ(line(d, kCapChkCfg),
            "SD2 2->3 [62->62] SRD_high FCB=1 FCV=1 Chk_Cfg.req: slot0 in 6B cons [02 89 B8]; "
            "slot1 out 6B cons [03 09 B8]");
  EXPECT_EQ(line(d, kCapDataExch1),
            "SD2 2->3 SRD_high FCB=1 FCV=1 Data_Exchange.req: out 11 22 33 44 55 66");
  EXPECT_EQ(line(d, "68 09 09 68 02 03 0A 0A 0B 0C 0D 0E 0F 5A 16"),
            "SD2 3->2 DH Data_Exchange.res: in 0A 0B 0C 0D 0E 0F");
  EXPECT_EQ(line(d, "10 02 03 03 08 16"), "SD1 3->2 RS Data_Exchange.res");
  EXPECT_EQ(line(d, "DC 03 02"), "SD4 2->3 token");
}

TEST(FdlDescribe, ResponsesWithoutContextUseTheSsap) {
  Describer d;
  EXPECT_EQ(line(d, "68 06 06 68 82 83 08 3E 3B 13 99 16"),
            "SD2 3->2 [59->62] DL Get_Cfg.res: slot0 in 4B general");
  EXPECT_EQ(line(d, "E5"), "SC");
}

TEST(FdlDescribe, GlobalControlBroadcastAndDiagBits) {
  Describer d;
  EXPECT_EQ(line(d, "68 07 07 68 FF 82 46 3A 3E 08 00 47 16"),
            "SD2 2->127 [62->58] SDN_high broadcast Global_Control.req: Freeze, group 00");
  const std::vector<std::uint8_t> diag = B("48 0D 00 02 04 A4 05 04 3D 09 06");
  EXPECT_EQ(describe_diag(diag),
            "Ext_Diag Prm_Fault Prm_Req WD_On, master 2, ident 04A4, ext 05 04 3D 09 06");
}

}  // namespace
}  // namespace candp2::fdl::test
