// Compressed DICOM pixel data are decoded in separate decoder processes, so that whatever a
// codec library does on damaged data (an assertion, a stray write, an endless loop, a
// runaway allocation) ends that process, not tsf, and becomes an error naming the file
// (robustness.md, "Containment of the decoders").
//
// Each decoder is a fork of this process with one thread, started before the first file and
// ended after the last; it decodes the files it is sent with decode_dicom_frames and sends the
// values back over a socket, frame by frame, straight into the volume's memory. Per file it runs
// under limits set before the file is opened:
//   memory (RLIMIT_DATA): what it holds already + 256 MiB + 8 × the file's decoded bytes + 2 × its
//                         compressed bytes; compressed bytes are themselves bounded by the ratio
//                         check of the header pass, so the limit follows what the file holds;
//   CPU (RLIMIT_CPU):     30 s + 1 s per 2^20 samples of the file (×5 under AddressSanitizer);
//   wall clock:           a decoder that sends nothing and uses no CPU for 120 s + 4 × that CPU
//                         budget is killed (waiting on something that will not come).
// A decoder that dies (signal, exit) or breaks a limit fails the import with the file, its
// transfer syntax and what happened; the other decoders are stopped.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "tsf/import/dicom_file_info.h"
#include "tsf/import/dicom_pixel_reader.h"

namespace tsf::import {

struct DecoderProcessOptions {
  int processes = 1;  ///< decoders running at once (each one thread)
  /// Polled about every 100 ms: true stops the decoders and throws tsf::Error ("interrupted").
  std::function<bool()> stop_requested;
  /// Overrides of the per-file limits above (0: the rule), for tests of the containment.
  double cpu_seconds = 0, stall_seconds = 0;
};

/// Where frame `frame` of file `file` goes (columns×rows floats); nullptr: not needed.
using FrameSink = std::function<float*(int file, int frame)>;

/// Decodes `files` (each encapsulated) in decoder processes; the values of each frame are
/// written where `sink` says, then `done(file, values)` is called (in this thread). Throws
/// tsf::Error naming the file on the first failure, after every decoder has ended.
void decode_in_processes(const std::vector<const DicomFileInfo*>& files,
                         const DecoderProcessOptions& options, const FrameSink& sink,
                         const std::function<void(int file, const DecodedFrameValues&)>& done);

/// The limits a decoder process runs a file under, in words (for reports and docs).
std::string decoder_process_limits_text();

/// Whether decoding runs in decoder processes: yes unless the environment variable
/// TSF_DECODE_IN_PROCESS is set to 1 (a debugging aid: a codec's crash then ends tsf).
bool decoders_isolated();

/// A size line of /proc/self/status ("VmData:", "VmRSS:", "VmHWM:"), in bytes; 0 when absent.
std::uint64_t process_status_bytes(const char* key);

/// For tests of the containment only: when the environment variable TSF_TEST_DECODER_FAULT is
/// "abort", "segfault", "spin", "sleep" or "allocate", a decoder process given a file whose name
/// contains TSF_TEST_DECODER_FAULT_FILE does that instead of decoding it.
void inject_test_fault(const DicomFileInfo& info);

}  // namespace tsf::import
