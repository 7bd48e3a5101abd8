// Bytes of crafted input files, shared by the tests and the fuzz seed maker (fuzz/make_seeds.cpp).
#pragma once

#include <zlib.h>

#include <cstdint>
#include <cstring>
#include <string>

namespace tsf::test {

/// `data` deflated with zlib's `window_bits`: -15 raw deflate (a Deflated Explicit VR Little
/// Endian data set), 15 + 16 a gzip member.
inline std::string deflated(const std::string& data, int window_bits) {
  std::string out(compressBound(static_cast<uLong>(data.size())) + 64, '\0');
  z_stream z{};
  deflateInit2(&z, 9, Z_DEFLATED, window_bits, 8, Z_DEFAULT_STRATEGY);
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = static_cast<uInt>(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

/// A NIfTI-1 header (348 bytes + 4 extension bytes, data at 352) of nx×ny×nz int16 voxels with
/// pixdim[1..3] = `pixdim`; a qform of identity rotation at `qoffset` when qform_code = 1, an
/// sform with row x = `srow_x` (rows y, z the unit axes) when sform_code = 1.
inline std::string nifti1_header(std::int16_t nx, std::int16_t ny, std::int16_t nz,
                                 const float pixdim[3], std::int16_t qform_code,
                                 const float qoffset[3], std::int16_t sform_code,
                                 const float srow_x[4]) {
  std::string h(352, '\0');
  auto put32 = [&](std::size_t at, std::int32_t v) { std::memcpy(&h[at], &v, 4); };
  auto put16 = [&](std::size_t at, std::int16_t v) { std::memcpy(&h[at], &v, 2); };
  auto putf = [&](std::size_t at, float v) { std::memcpy(&h[at], &v, 4); };
  put32(0, 348);
  const std::int16_t dim[8] = {3, nx, ny, nz, 1, 1, 1, 1};
  for (int i = 0; i < 8; ++i) put16(40 + 2 * i, dim[i]);
  put16(70, 4);   // int16
  put16(72, 16);  // bitpix
  for (int i = 0; i < 8; ++i) putf(76 + 4 * i, i >= 1 && i <= 3 ? pixdim[i - 1] : 1.0f);
  putf(108, 352.0f);  // vox_offset
  put16(252, qform_code);
  for (int i = 0; i < 3; ++i) putf(268 + 4 * i, qoffset[i]);
  put16(254, sform_code);
  for (int c = 0; c < 4; ++c) {
    putf(280 + 4 * c, srow_x[c]);
    putf(296 + 4 * c, c == 1 ? 1.0f : 0.0f);
    putf(312 + 4 * c, c == 2 ? 1.0f : 0.0f);
  }
  std::memcpy(&h[344], "n+1\0", 4);
  return h;
}

}  // namespace tsf::test
