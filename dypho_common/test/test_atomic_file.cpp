/// Files are written atomically: a process killed (SIGKILL) while it saves leaves the previous
/// complete file, never a prefix (what a crash during save_map / save_trajectory would leave).

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "dypho/common/atomic_file.h"

namespace DYPHO_UNITY_ID {

constexpr std::size_t kBytes = 8u << 20;  // 8 MB: a save takes long enough to be interrupted

/// Version `k` of the file: a size line, then kBytes bytes of value k % 251.
void writeVersion(const std::string& path, int k) {
  dypho::writeFileAtomically(
      path,
      [&](std::ostream& os) {
        os << "version " << k << " bytes " << kBytes << "\n";
        const std::string block(1 << 16, static_cast<char>(k % 251));
        for (std::size_t n = 0; n < kBytes; n += block.size())
          os.write(block.data(), static_cast<std::streamsize>(block.size()));
      },
      true);
}

/// True when `path` holds one complete version.
bool completeVersion(const std::string& path, int* version) {
  std::ifstream in(path, std::ios::binary);
  std::string word, bytes_word;
  std::size_t bytes = 0;
  if (!(in >> word >> *version >> bytes_word >> bytes) || word != "version" || bytes != kBytes) return false;
  in.get();  // newline
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (data.size() != kBytes) return false;
  const char expected = static_cast<char>(*version % 251);
  return data.find_first_not_of(expected) == std::string::npos;
}

TEST(AtomicFile, SigkillDuringSaveLeavesACompleteFile) {
  const std::string dir = "/tmp/dypho_atomic_test_" + std::to_string(::getpid());
  ASSERT_EQ(::system(("rm -rf '" + dir + "' && mkdir -p '" + dir + "'").c_str()), 0);
  const std::string path = dir + "/map.ply";
  writeVersion(path, 0);
  std::mt19937 rng(7);
  int last_seen = 0;
  for (int round = 0; round < 12; ++round) {
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      for (int k = 1;; ++k) writeVersion(path, 1000 * (round + 1) + k);  // saves until killed
    }
    ::usleep(std::uniform_int_distribution<int>(2000, 60000)(rng));  // 2-60 ms into the saves
    ASSERT_EQ(::kill(child, SIGKILL), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status));
    int version = -1;
    ASSERT_TRUE(completeVersion(path, &version)) << "round " << round << ": a partial file was left";
    EXPECT_TRUE(version == last_seen || version > 1000 * (round + 1)) << "round " << round;
    last_seen = version;
  }
  ::system(("rm -rf '" + dir + "'").c_str());
}

}  // namespace DYPHO_UNITY_ID
