// The header each compressed DICOM frame carries in its own codestream (JPEG SOF, JPEG-LS SOF55,
// JPEG 2000 SIZ, the RLE segment table), read and compared with the DICOM header before any
// decoder sees the frame: a disagreement is refused naming both values, because GDCM's decoders
// either write past their buffer or return the real image re-read at the header's size
// (import.md, "Limits and safety").
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace tsf::import {

struct DicomFileInfo;

/// What the DICOM header says a frame holds.
struct ExpectedFrame {
  int rows = 0, columns = 0, samples_per_pixel = 1, bits_allocated = 0, bits_stored = 0;
};

/// Whether frames of `transfer_syntax_uid` carry a header compare_frame_header reads.
bool has_checked_frame_header(const std::string& transfer_syntax_uid);

/// The most samples one byte of compressed data can hold in `transfer_syntax_uid`, so that a
/// header claiming more pixels than the file can encode is refused before the decoder allocates
/// for them: 8 for lossless JPEG (processes 14 and SV1: a Huffman code per sample, at least one
/// bit), 256 for sequential DCT JPEG (baseline, extended: at least a DC and an end-of-block code
/// per 8×8 block). 0 where no bound exists: JPEG-LS run mode, JPEG 2000 and progressive JPEG
/// compress a blank image without limit (the voxel limit bounds those); RLE is bounded per
/// segment by compare_frame_header.
double max_samples_per_compressed_byte(const std::string& transfer_syntax_uid);

/// Whether `transfer_syntax_uid` puts each frame in exactly one fragment (RLE, PS3.5 A.4.2).
bool one_fragment_per_frame(const std::string& transfer_syntax_uid);

/// Compares the codestream header at the start of one frame (`data`, the first `n` bytes of its
/// first fragment of `fragment_length` bytes) with `expected`. Returns "" when they agree, else
/// what disagrees, e.g. "the JPEG 2000 SIZ says 22000×22000 pixels, the header 512×512".
std::string compare_frame_header(const std::string& transfer_syntax_uid, const std::uint8_t* data,
                                 std::size_t n, std::uint64_t fragment_length,
                                 const ExpectedFrame& expected);

/// Walks the whole codestream of one frame (`data`: its fragments joined, `n` bytes) and
/// returns "" when its structure is whole, else what is damaged, for what a decoder would
/// otherwise turn silently into wrong pixels (robustness.md, "Damage inside compressed data"):
///   - JPEG 2000: SOC, SIZ, COD and QCD in the main header; every marker segment inside the
///     codestream; each tile-part's SOT (index, part number, count) and its length Psot landing
///     on the next SOT or on EOC; every tile present with all its parts; TLM and PLT lengths,
///     when the codestream has them, equal to what they describe; SOP sequence numbers; no
///     marker code (0xFF90 and above) inside coded data, where the format forbids one;
///   - JPEG and JPEG-LS: SOI, one frame header, marker segments inside the stream, restart
///     markers in sequence (and as many as the restart interval implies for one sequential or
///     lossless scan), EOI;
///   - RLE: each segment decodes to exactly Rows×Columns bytes.
/// At most one padding byte may follow EOC/EOI (PS3.5 A.4: fragments have even length).
std::string check_frame_codestream(const std::string& transfer_syntax_uid, const std::uint8_t* data,
                                   std::size_t n, const ExpectedFrame& expected);

/// The maximum ratio of decoded to compressed bytes tsf accepts for one file or series above
/// kRatioFreeDecodedBytes (robustness.md, "Allocation bounded by the file"): lossless CT
/// compresses about 3:1, lossy CT by guideline at most about 15:1; a header claiming more is
/// refused before anything is allocated for it.
constexpr double kMaxCompressionRatio = 100;
/// Below this many decoded bytes no ratio is asked for (a blank frame compresses ~3000:1).
constexpr std::uint64_t kRatioFreeDecodedBytes = std::uint64_t{64} << 20;

/// "" when `decoded_bytes` of pixels may come from `compressed_bytes` (at most
/// kMaxCompressionRatio, or any ratio below kRatioFreeDecodedBytes); else why not.
std::string compression_ratio_problem(std::uint64_t decoded_bytes, std::uint64_t compressed_bytes);

/// The codestream of each frame of the encapsulated pixel data of `path` (its fragments joined
/// in order), for `frames` frames. Throws tsf::Error naming the file when the fragments cannot
/// be assigned to frames or read.
std::vector<std::vector<std::uint8_t>> read_frame_codestreams(const DicomFileInfo& info);

}  // namespace tsf::import
