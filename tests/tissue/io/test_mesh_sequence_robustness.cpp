// Hostile mesh sequence files: every truncation, every single-byte corruption and forged sizes
// must give a tsf::Error naming the file (and the field), never a crash, a hang or a huge
// allocation. Runs under ASan + UBSan in CI (the suite name contains "Robustness").
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>

#include "mesh_sequence_test_helpers.h"
#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/io/crc32.h"
#include "tsf/io/mesh_sequence.h"

namespace tsf::io {
namespace {
namespace fs = std::filesystem;
using test::read_bytes;
using test::write_bytes;

/// A tiny valid file: one tetrahedron at rest, one pose, one re-mesh.
std::string tiny_file(const fs::path& dir) {
  const MeshSequence s = test::tiny_sequence();
  const fs::path file = dir / "tiny.tsfmesh";
  write_mesh_sequence(file, s);
  return read_bytes(file);
}

/// Reads `bytes` as a file; returns the error message ("" when it read fine).
std::string read_error(const fs::path& file, const std::string& bytes) {
  write_bytes(file, bytes);
  try {
    (void)read_mesh_sequence(file);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

template <typename T>
void poke(std::string& bytes, std::size_t offset, T value) {
  std::memcpy(&bytes[offset], &value, sizeof(T));
}

/// Recomputes the CRC of the record whose header starts at `record` (after a deliberate edit).
void fix_crc(std::string& bytes, std::size_t record) {
  std::uint64_t size = 0;
  std::memcpy(&size, &bytes[record + 4], 8);
  poke(bytes, record + 12 + size, crc32(&bytes[record + 12], size));
}

TEST(MeshSequenceRobustness, EveryTruncationIsAnErrorNamingTheFile) {
  const fs::path dir = tsf::test::scratch_dir("robust");
  const std::string good = tiny_file(dir);
  const fs::path file = dir / "cut.tsfmesh";
  ASSERT_EQ(read_error(file, good), "");
  for (std::size_t n = 0; n < good.size(); ++n) {
    const std::string message = read_error(file, good.substr(0, n));
    ASSERT_NE(message, "") << "truncated to " << n << " of " << good.size()
                           << " bytes was accepted";
    ASSERT_NE(message.find(file.string()), std::string::npos) << message;
  }
}

TEST(MeshSequenceRobustness, EverySingleByteCorruptionIsDetected) {
  const fs::path dir = tsf::test::scratch_dir("robust");
  const std::string good = tiny_file(dir);
  const fs::path file = dir / "flipped.tsfmesh";
  for (std::size_t i = 0; i < good.size(); ++i) {
    for (unsigned char mask : {0x01, 0x80, 0xff}) {
      std::string bad = good;
      bad[i] = static_cast<char>(bad[i] ^ static_cast<char>(mask));
      const std::string message = read_error(file, bad);
      ASSERT_NE(message, "") << "byte " << i << " xor " << int(mask) << " went unnoticed";
      ASSERT_NE(message.find(file.string()), std::string::npos) << message;
    }
  }
}

TEST(MeshSequenceRobustness, ForgedSizesFailWithoutAllocating) {
  const fs::path dir = tsf::test::scratch_dir("robust");
  const std::string good = tiny_file(dir);
  const fs::path file = dir / "forged.tsfmesh";
  const std::size_t geom = 16, rest = geom + 12 + 132 + 4;

  std::string bad = good;  // a payload size of 2^62 bytes
  poke<std::uint64_t>(bad, rest + 4, std::uint64_t{1} << 62);
  std::string message = read_error(file, bad);
  EXPECT_NE(message.find("payload_bytes"), std::string::npos) << message;

  bad = good;  // V = 2^40 with a valid CRC: the sizes cannot add up
  poke<std::uint64_t>(bad, rest + 12 + 16, std::uint64_t{1} << 40);
  fix_crc(bad, rest);
  message = read_error(file, bad);
  EXPECT_NE(message.find("'V'"), std::string::npos) << message;
  EXPECT_NE(message.find("rest MESH"), std::string::npos) << message;

  bad = good;  // T one too many with a valid CRC
  poke<std::uint64_t>(bad, rest + 12 + 24, std::uint64_t{5});
  fix_crc(bad, rest);
  message = read_error(file, bad);
  EXPECT_NE(message.find("T = 5"), std::string::npos) << message;

  bad = good;  // a triangle index out of range with a valid CRC
  const std::size_t triangles = rest + 12 + 32 + 4 * 12 * 2 + 4;
  poke<std::uint32_t>(bad, triangles + 4, 99u);
  fix_crc(bad, rest);
  message = read_error(file, bad);
  EXPECT_NE(message.find("uses vertex 99"), std::string::npos) << message;

  bad = good;  // a NaN position with a valid CRC
  poke<float>(bad, rest + 12 + 32 + 4, std::nanf(""));
  fix_crc(bad, rest);
  message = read_error(file, bad);
  EXPECT_NE(message.find("non-finite"), std::string::npos) << message;
}

TEST(MeshSequenceRobustness, WrongOrderVersionAndTrailingBytesAreErrors) {
  const fs::path dir = tsf::test::scratch_dir("robust");
  const std::string good = tiny_file(dir);
  const fs::path file = dir / "order.tsfmesh";

  std::string bad = good;
  poke<std::uint32_t>(bad, 8, 2u);
  EXPECT_NE(read_error(file, bad).find("'version' = 2"), std::string::npos);

  EXPECT_NE(read_error(file, good + "x").find("follow the END record"), std::string::npos);

  bad = good;  // the rest MESH record tagged POSE (tags are not covered by the CRC)
  std::memcpy(&bad[16 + 12 + 132 + 4], "POSE", 4);
  EXPECT_NE(read_error(file, bad).find("expected 'MESH'"), std::string::npos);

  bad = good;  // the END record's frame count disagrees
  poke<std::uint64_t>(bad, bad.size() - 12, 7u);
  fix_crc(bad, bad.size() - 24);
  EXPECT_NE(read_error(file, bad).find("frame_count"), std::string::npos);
}

}  // namespace
}  // namespace tsf::io
