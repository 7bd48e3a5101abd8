#include "tsf/import/decoder_processes.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <new>
#include <sstream>
#include <thread>

#include "tsf/common/error.h"
#include "tsf/common/text_format.h"

#if defined(__SANITIZE_ADDRESS__)
#define TSF_DECODER_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TSF_DECODER_UNDER_ASAN 1
#endif
#endif

namespace tsf::import {
namespace {

using Clock = std::chrono::steady_clock;

constexpr std::uint32_t kMagic = 0x54534644u;  // "TSFD"
constexpr std::uint64_t kFixedMemory = std::uint64_t{256} << 20;
constexpr double kMemoryPerDecodedByte = 8;
constexpr double kMemoryPerCompressedByte = 2;
constexpr double kFixedCpuSeconds = 30;
constexpr double kSamplesPerCpuSecond = 1048576;  // 2^20: a tenth of OpenJPEG's pace
#ifdef TSF_DECODER_UNDER_ASAN
constexpr double kSanitizerSlowdown = 5;  // AddressSanitizer's cost on the codecs
#else
constexpr double kSanitizerSlowdown = 1;
#endif
constexpr double kFixedStallSeconds = 120;
constexpr std::uint32_t kMaxText = 65536;

/// What a decoder sends back for one file; followed by `text_bytes` of text (the error, or the
/// Modality LUT type) and, when ok, `frames` frames of `frame_bytes` each.
struct ResultHeader {
  std::uint32_t magic = kMagic;
  std::int32_t file = -1;
  std::int32_t ok = 0;
  std::int32_t frames = 0;
  std::uint64_t frame_bytes = 0;
  std::uint32_t text_bytes = 0;
  std::int32_t frames_remapped = 0;
  std::int32_t modality_lut_applied = 0;
  std::int32_t padding = 0;
  double slope = 1, intercept = 0;
  std::uint64_t peak_bytes = 0;  ///< resident memory the decoder added while decoding the file
};

std::string where(const DicomFileInfo& info) {
  return "'" + info.path.string() + "' (" + dicom_uid_name(info.transfer_syntax_uid) + ")";
}

std::uint64_t samples_of(const DicomFileInfo& info) {
  return static_cast<std::uint64_t>(info.columns) * static_cast<std::uint64_t>(info.rows) *
         static_cast<std::uint64_t>(info.number_of_frames);
}

double cpu_budget_seconds(const DicomFileInfo& info, const DecoderProcessOptions& options) {
  if (options.cpu_seconds > 0) return options.cpu_seconds;
  return kSanitizerSlowdown *
         (kFixedCpuSeconds + static_cast<double>(samples_of(info)) / kSamplesPerCpuSecond);
}

std::uint64_t memory_allowance(const DicomFileInfo& info) {
  return kFixedMemory +
         static_cast<std::uint64_t>(kMemoryPerDecodedByte *
                                    static_cast<double>(info.decoded_bytes())) +
         static_cast<std::uint64_t>(kMemoryPerCompressedByte *
                                    static_cast<double>(info.pixel_data_bytes));
}

std::string mib(std::uint64_t bytes) {
  return std::to_string((bytes + (std::uint64_t{1} << 20) - 1) >> 20) + " MiB";
}

bool send_all(int fd, const void* data, std::size_t n) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::send(fd, p, n, MSG_NOSIGNAL);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

bool receive_all(int fd, void* data, std::size_t n) {
  char* p = static_cast<char*>(data);
  while (n > 0) {
    const ssize_t r = ::recv(fd, p, n, 0);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return false;
    p += r;
    n -= static_cast<std::size_t>(r);
  }
  return true;
}

/// The limits of one file, set in the decoder before it opens the file.
void set_limits(const DicomFileInfo& info, const DecoderProcessOptions& options) {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const double used = static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                      1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
  rlimit cpu{};
  getrlimit(RLIMIT_CPU, &cpu);
  const auto soft = static_cast<rlim_t>(std::ceil(used + cpu_budget_seconds(info, options)));
  cpu.rlim_cur = cpu.rlim_max == RLIM_INFINITY ? soft : std::min(soft, cpu.rlim_max);
  setrlimit(RLIMIT_CPU, &cpu);
#ifndef TSF_DECODER_UNDER_ASAN
  // Under AddressSanitizer the shadow memory and quarantine make VmData meaningless; ASan's
  // own allocation limit (max_allocation_size_mb in CI) stands in.
  rlimit data{};
  getrlimit(RLIMIT_DATA, &data);
  const auto limit = static_cast<rlim_t>(process_status_bytes("VmData:") + memory_allowance(info));
  data.rlim_cur = data.rlim_max == RLIM_INFINITY ? limit : std::min(limit, data.rlim_max);
  setrlimit(RLIMIT_DATA, &data);
#endif
}

/// One decoder process: decodes the files it is sent until told to stop; never returns.
[[noreturn]] void decoder_main(int socket, pid_t parent,
                               const std::vector<const DicomFileInfo*>& files,
                               const DecoderProcessOptions& options) {
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) _exit(1);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  std::vector<float> values;
  try {
    while (true) {
      std::int32_t job = -1;
      if (!receive_all(socket, &job, sizeof job) || job < 0 ||
          job >= static_cast<std::int32_t>(files.size()))
        _exit(0);
      const DicomFileInfo& info = *files[static_cast<std::size_t>(job)];
      set_limits(info, options);
      std::ofstream("/proc/self/clear_refs") << "5";  // the peak from here on
      const std::uint64_t resident = process_status_bytes("VmRSS:");
      ResultHeader header;
      header.file = job;
      std::string text;
      try {
        inject_test_fault(info);
        values.resize(static_cast<std::size_t>(samples_of(info)));
        const DecodedFrameValues v = decode_dicom_frames(info, values.data());
        header.ok = 1;
        header.frames = info.number_of_frames;
        header.frame_bytes =
            static_cast<std::uint64_t>(info.columns) * static_cast<std::uint64_t>(info.rows) * 4;
        header.slope = v.slope;
        header.intercept = v.intercept;
        header.frames_remapped = v.frames_remapped;
        header.modality_lut_applied = v.modality_lut_applied ? 1 : 0;
        text = v.modality_lut_type;
      } catch (const std::bad_alloc&) {
        text = "decoding " + where(info) + " needed more than its memory limit (" +
               mib(memory_allowance(info)) + " beyond what the decoder held)";
      } catch (const std::exception& e) {
        text = e.what();
      }
      if (text.size() > kMaxText) text.resize(kMaxText);
      const std::uint64_t peak = process_status_bytes("VmHWM:");
      header.peak_bytes = peak > resident ? peak - resident : 0;
      header.text_bytes = static_cast<std::uint32_t>(text.size());
      if (!send_all(socket, &header, sizeof header) || !send_all(socket, text.data(), text.size()))
        _exit(1);
      if (header.ok && !send_all(socket, values.data(), values.size() * sizeof(float))) _exit(1);
    }
  } catch (...) {
    _exit(2);
  }
}

std::string signal_name(int sig) {
  const char* name = strsignal(sig);
  return "signal " + std::to_string(sig) + (name ? std::string(" (") + name + ")" : std::string());
}

/// The parent's view of one decoder.
struct Decoder {
  pid_t pid = -1;
  int socket = -1;
  int job = -1;  ///< file being decoded, -1 when idle
  bool alive = false;
  Clock::time_point last_activity;
  // Receiving the current result.
  ResultHeader header;
  std::size_t header_got = 0;
  std::string text;
  std::size_t text_got = 0;
  int frame = 0;
  std::size_t frame_got = 0;
  float* destination = nullptr;
  unsigned long long cpu_ticks = 0;  ///< CPU time used at the last stall check
};

/// CPU time (clock ticks, user + system) process `pid` has used; 0 when unknown.
unsigned long long cpu_ticks_of(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  std::getline(in, text);
  const std::size_t close = text.rfind(')');  // the command name may hold spaces
  if (close == std::string::npos) return 0;
  std::istringstream fields(text.substr(close + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && fields >> field; ++i) {
    if (i == 14) utime = std::strtoull(field.c_str(), nullptr, 10);
    if (i == 15) stime = std::strtoull(field.c_str(), nullptr, 10);
  }
  return utime + stime;
}

class DecoderPool {
 public:
  DecoderPool(const std::vector<const DicomFileInfo*>& files, const DecoderProcessOptions& options,
              const FrameSink& sink,
              const std::function<void(int, const DecodedFrameValues&)>& done)
      : files_(files), options_(options), sink_(sink), done_(done) {}

  ~DecoderPool() { end_all(true); }

  void run() {
    const int count =
        std::max(1, std::min<int>(options_.processes, static_cast<int>(files_.size())));
    for (int i = 0; i < count; ++i) start_decoder();
    for (Decoder& d : decoders_) dispatch(d);
    while (failure_.empty() && busy()) {
      std::vector<pollfd> fds;
      std::vector<Decoder*> owners;
      for (Decoder& d : decoders_)
        if (d.alive && d.job >= 0) {
          fds.push_back({d.socket, POLLIN, 0});
          owners.push_back(&d);
        }
      const int ready = ::poll(fds.data(), fds.size(), 100);
      if (ready < 0 && errno != EINTR)
        fail("cannot wait for the decoder processes: " + std::string(std::strerror(errno)));
      for (std::size_t i = 0; i < fds.size() && failure_.empty(); ++i)
        if (fds[i].revents != 0) pump(*owners[i]);
      if (options_.stop_requested && options_.stop_requested()) fail("interrupted");
      check_stalls();
    }
    end_all(!failure_.empty());
    if (!failure_.empty()) throw Error(failure_);
  }

 private:
  bool busy() const {
    if (next_ < files_.size()) return true;
    for (const Decoder& d : decoders_)
      if (d.alive && d.job >= 0) return true;
    return false;
  }

  void start_decoder() {
    int pair[2];
    if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, pair) != 0)
      throw Error(
          "cannot start a decoder process (socketpair: " + std::string(std::strerror(errno)) + ")");
    const pid_t parent = getpid();
    const pid_t pid = ::fork();
    if (pid < 0) {
      const int e = errno;
      ::close(pair[0]);
      ::close(pair[1]);
      throw Error("cannot start a decoder process (fork: " + std::string(std::strerror(e)) +
                  "); TSF_DECODE_IN_PROCESS=1 decodes inside tsf, without containment");
    }
    if (pid == 0) {
      // The decoder keeps only its own end: a sibling's end held here would hide that sibling's
      // exit from the parent.
      ::close(pair[0]);
      for (const Decoder& d : decoders_) ::close(d.socket);
      decoder_main(pair[1], parent, files_, options_);
    }
    ::close(pair[1]);
    ::fcntl(pair[0], F_SETFL, ::fcntl(pair[0], F_GETFL) | O_NONBLOCK);
    Decoder d;
    d.pid = pid;
    d.socket = pair[0];
    d.alive = true;
    decoders_.push_back(d);
  }

  void dispatch(Decoder& d) {
    if (!d.alive || !failure_.empty()) return;
    if (next_ >= files_.size()) {
      const std::int32_t quit = -1;
      ::send(d.socket, &quit, sizeof quit, MSG_NOSIGNAL);
      d.job = -1;
      return;
    }
    d.job = static_cast<int>(next_++);
    d.header_got = d.text_got = d.frame_got = 0;
    d.frame = 0;
    d.text.clear();
    d.destination = nullptr;
    d.last_activity = Clock::now();
    const std::int32_t job = d.job;
    if (::send(d.socket, &job, sizeof job, MSG_NOSIGNAL) != static_cast<ssize_t>(sizeof job))
      died(d);
  }

  /// Reads what `d` has sent; returns when it would block.
  void pump(Decoder& d) {
    const DicomFileInfo& info = *files_[static_cast<std::size_t>(d.job)];
    while (failure_.empty() && d.alive && d.job >= 0) {
      char* target = nullptr;
      std::size_t want = 0;
      if (d.header_got < sizeof d.header) {
        target = reinterpret_cast<char*>(&d.header) + d.header_got;
        want = sizeof d.header - d.header_got;
      } else if (d.text_got < d.header.text_bytes) {
        target = &d.text[d.text_got];
        want = d.header.text_bytes - d.text_got;
      } else {
        if (d.frame_got == 0) d.destination = frame_destination(d, info);
        target = reinterpret_cast<char*>(d.destination) + d.frame_got;
        want = static_cast<std::size_t>(d.header.frame_bytes) - d.frame_got;
      }
      const ssize_t r = ::recv(d.socket, target, want, 0);
      if (r < 0 && errno == EINTR) continue;
      if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
      if (r <= 0) {
        died(d);
        return;
      }
      d.last_activity = Clock::now();
      const auto got = static_cast<std::size_t>(r);
      if (d.header_got < sizeof d.header) {
        d.header_got += got;
        if (d.header_got == sizeof d.header && !accept_header(d, info)) return;
        if (d.header_got == sizeof d.header && d.header.text_bytes == 0 && finish_if_complete(d))
          return;
      } else if (d.text_got < d.header.text_bytes) {
        d.text_got += got;
        if (d.text_got == d.header.text_bytes && finish_if_complete(d)) return;
      } else {
        d.frame_got += got;
        if (d.frame_got == d.header.frame_bytes) {
          d.frame_got = 0;
          ++d.frame;
          if (finish_if_complete(d)) return;
        }
      }
    }
  }

  bool accept_header(Decoder& d, const DicomFileInfo& info) {
    const ResultHeader& h = d.header;
    const std::uint64_t frame_bytes =
        static_cast<std::uint64_t>(info.columns) * static_cast<std::uint64_t>(info.rows) * 4;
    if (h.magic != kMagic || h.file != d.job || h.text_bytes > kMaxText ||
        (h.ok && (h.frames != info.number_of_frames || h.frame_bytes != frame_bytes))) {
      fail("the decoder process for " + where(info) + " sent a malformed result");
      return false;
    }
    d.text.assign(h.text_bytes, '\0');
    return true;
  }

  float* frame_destination(Decoder& d, const DicomFileInfo&) {
    float* p = sink_ ? sink_(d.job, d.frame) : nullptr;
    if (p) return p;
    scratch_.resize(static_cast<std::size_t>(d.header.frame_bytes / sizeof(float)));
    return scratch_.data();
  }

  /// When the whole result of `d` is in: hands it over and gives `d` its next file.
  bool finish_if_complete(Decoder& d) {
    const ResultHeader& h = d.header;
    if (h.ok && d.frame < h.frames) return false;
    const int file = d.job;
    if (!h.ok) {
      fail(d.text.empty() ? "decoding " + where(*files_[static_cast<std::size_t>(file)]) + " failed"
                          : d.text);
      d.job = -1;
      return true;
    }
    DecodedFrameValues v;
    v.slope = h.slope;
    v.intercept = h.intercept;
    v.frames_remapped = h.frames_remapped;
    v.modality_lut_applied = h.modality_lut_applied != 0;
    v.modality_lut_type = d.text;
    v.decoder_peak_bytes = h.peak_bytes;
    done_(file, v);
    dispatch(d);
    return true;
  }

  /// `d` closed its socket: it ended. While it held a file, that is the file's failure.
  void died(Decoder& d) {
    int status = 0;
    pid_t r;
    do r = ::waitpid(d.pid, &status, 0);
    while (r < 0 && errno == EINTR);
    d.alive = false;
    ::close(d.socket);
    d.socket = -1;
    if (d.job < 0) return;
    const DicomFileInfo& info = *files_[static_cast<std::size_t>(d.job)];
    d.job = -1;
    if (options_.stop_requested && options_.stop_requested()) {
      fail("interrupted");
      return;
    }
    std::string what;
    if (r > 0 && WIFSIGNALED(status) && WTERMSIG(status) == SIGXCPU)
      what = "used more than its CPU limit of " +
             format_text("%.0f", cpu_budget_seconds(info, options_)) +
             " s (an endless loop on damaged data?) and was stopped";
    else if (r > 0 && WIFSIGNALED(status))
      what = "crashed with " + signal_name(WTERMSIG(status)) +
             ": the image library failed on this file's data";
    else if (r > 0 && WIFEXITED(status))
      what = "exited with status " + std::to_string(WEXITSTATUS(status));
    else
      what = "ended unexpectedly";
    fail("decoding " + where(info) + ": the decoder process " + what +
         ". The file is refused; tsf itself was not affected (robustness.md, \"Containment of "
         "the decoders\")");
  }

  void check_stalls() {
    const auto now = Clock::now();
    for (Decoder& d : decoders_) {
      if (!d.alive || d.job < 0 || !failure_.empty()) continue;
      // A decoder using CPU is working (its CPU limit bounds it); one sending nothing and
      // using no CPU waits on something that will not come.
      const unsigned long long ticks = cpu_ticks_of(d.pid);
      if (ticks > d.cpu_ticks) {
        d.cpu_ticks = ticks;
        d.last_activity = now;
        continue;
      }
      const DicomFileInfo& info = *files_[static_cast<std::size_t>(d.job)];
      const double limit = options_.stall_seconds > 0
                               ? options_.stall_seconds
                               : kFixedStallSeconds + 4 * cpu_budget_seconds(info, options_);
      if (std::chrono::duration<double>(now - d.last_activity).count() > limit) {
        ::kill(d.pid, SIGKILL);
        fail("decoding " + where(info) + ": the decoder process sent nothing and used no CPU for " +
             format_text("%.0f", limit) + " s and was stopped");
      }
    }
  }

  void fail(const std::string& message) {
    if (failure_.empty()) failure_ = message;
  }

  /// Ends every decoder: told to quit when idle and healthy, killed otherwise; all reaped.
  void end_all(bool kill_busy) {
    for (Decoder& d : decoders_) {
      if (!d.alive) continue;
      if (d.job >= 0 || kill_busy) ::kill(d.pid, SIGKILL);
      const std::int32_t quit = -1;
      ::send(d.socket, &quit, sizeof quit, MSG_NOSIGNAL);
      ::close(d.socket);
      int status = 0;
      while (::waitpid(d.pid, &status, 0) < 0 && errno == EINTR) {
      }
      d.alive = false;
    }
  }

  const std::vector<const DicomFileInfo*>& files_;
  const DecoderProcessOptions& options_;
  const FrameSink& sink_;
  const std::function<void(int, const DecodedFrameValues&)>& done_;
  std::vector<Decoder> decoders_;
  std::size_t next_ = 0;
  std::string failure_;
  std::vector<float> scratch_;
};

}  // namespace

std::uint64_t process_status_bytes(const char* wanted) {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == wanted) {
      std::uint64_t kib = 0;
      status >> kib;
      return kib << 10;
    }
    std::string rest;
    std::getline(status, rest);
  }
  return 0;
}

void decode_in_processes(const std::vector<const DicomFileInfo*>& files,
                         const DecoderProcessOptions& options, const FrameSink& sink,
                         const std::function<void(int, const DecodedFrameValues&)>& done) {
  if (files.empty()) return;
  DecoderPool pool(files, options, sink, done);
  pool.run();
}

std::string decoder_process_limits_text() {
  return "per file: " + std::to_string(kFixedMemory >> 20) + " MiB + " +
         format_text("%.0f", kMemoryPerDecodedByte) + "× its decoded bytes + " +
         format_text("%.0f", kMemoryPerCompressedByte) + "× its compressed bytes of memory" +
#ifdef TSF_DECODER_UNDER_ASAN
         " (not enforced under AddressSanitizer)" +
#endif
         ", " + format_text("%.0f", kFixedCpuSeconds) + " s + 1 s per " +
         format_text("%.0f", kSamplesPerCpuSecond / 1048576) + " M samples of CPU" +
#ifdef TSF_DECODER_UNDER_ASAN
         " (× 5 under AddressSanitizer)" +
#endif
         "";
}

bool decoders_isolated() {
  const char* v = std::getenv("TSF_DECODE_IN_PROCESS");
  return !(v && std::string(v) == "1");
}

void inject_test_fault(const DicomFileInfo& info) {
  const char* fault = std::getenv("TSF_TEST_DECODER_FAULT");
  const char* file = std::getenv("TSF_TEST_DECODER_FAULT_FILE");
  if (!fault || !file || info.path.filename().string().find(file) == std::string::npos) return;
  const std::string f = fault;
  if (f == "abort") std::abort();
  if (f == "segfault") ::raise(SIGSEGV);
  if (f == "spin")
    for (volatile unsigned long i = 0;; i = i + 1) {
    }
  if (f == "sleep") std::this_thread::sleep_for(std::chrono::hours(1));
  if (f == "allocate") {
    std::vector<std::vector<char>> hog;
    while (true) hog.emplace_back(std::size_t{64} << 20, '\1');
  }
}

}  // namespace tsf::import
