// gtest entry point. Defined here so the test links whether or not the build adds gtest_main
// (catkin_add_gtest alone links gtest without main()); when gtest_main is linked as well, the
// linker takes this definition and does not pull gtest_main's.
#include <gtest/gtest.h>

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
