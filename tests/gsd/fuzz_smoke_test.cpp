// Deterministic stand-in for the gsd_fuzz target in ordinary builds: every prefix of the
// shipped GSD and seeded byte mutations of it go through the fuzz entry point (parser, check,
// encoder, summary, config decoder). Bad input never crashes (run it with -DCANDP2_SANITIZE=ON).
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

std::string read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

int feed(const std::string& s) {
  return LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(s.data()), s.size());
}

TEST(GsdFuzzSmoke, EveryPrefixOfTheShippedGsd) {
  const std::string text = read(CANDP2_SOURCE_DIR "/gsd/CDPS04A4.GSD");
  ASSERT_GT(text.size(), 1000u);
  for (std::size_t n = 0; n <= text.size(); n += 7) EXPECT_EQ(feed(text.substr(0, n)), 0);
}

TEST(GsdFuzzSmoke, SeededMutations) {
  const std::string text = read(CANDP2_SOURCE_DIR "/gsd/CDPS04A4.GSD");
  ASSERT_FALSE(text.empty());
  std::mt19937 rng(0xC0FFEE);  // fixed seed: reproducible
  static constexpr char kInteresting[] = {'\\', '"', ';', '=', '(',  ')',    '-', ',', '\n',
                                          '\r', '0', 'x', '9', '\0', '\xFF', ' ', '#'};
  for (int round = 0; round < 300; ++round) {
    std::string s = text;
    const int edits = 1 + static_cast<int>(rng() % 8);
    for (int e = 0; e < edits; ++e) {
      const std::size_t at = rng() % s.size();
      switch (rng() % 3) {
        case 0:
          s[at] = kInteresting[rng() % sizeof kInteresting];
          break;
        case 1:
          s.erase(at, rng() % 40);
          break;
        default:
          s.insert(at, s.substr(rng() % s.size(), rng() % 60));
          break;
      }
      if (s.empty()) s = '#';  // a char: `= "#"` trips GCC 12's false -Wrestrict at -O3
    }
    EXPECT_EQ(feed(s), 0);
  }
}

TEST(GsdFuzzSmoke, Degenerate) {
  for (const std::string& s :
       {std::string(), std::string("\\"), std::string("\""), std::string(1, '\0'),
        std::string("=\n=\n"), std::string("(\n)"), std::string("Module\n"),
        std::string("Module = \"\n"), std::string("ExtUserPrmData = 1 \"x\" BitArea(7-0) 0 0-1"),
        std::string("Ext_User_Prm_Data_Ref(99999999999) = 1"),
        std::string("Ext_User_Prm_Data_Const(236) = 1,2,3"),
        std::string("ExtUserPrmData=1 \"a\"\nBit(200) 1 0-1\nEnd"
                    "ExtUserPrmData\nExt_User_Prm_Data_Ref(0)=1"),
        std::string(100000, '\\'), std::string(5000, '"')})
    EXPECT_EQ(feed(s), 0);
}

}  // namespace
