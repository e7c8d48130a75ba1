// The object that compiles tests/precompiled.hpp for every test program (CMakeLists.txt
// candp2_test_pch): no code of its own.
