// tsf_fuzz_mutate: a mutation driver for the fuzz targets (fuzz_targets.h) that needs no clang or
// libFuzzer, so any build can run it (the GCC ASan + UBSan build of CI runs it as the fuzz smoke;
// docs/robustness.md, "Mutation campaigns"). Not coverage-guided: each case takes one seed and
// applies 1-8 random mutations (bit flips, interesting integers, block deletes, copies and
// inserts, splices with another seed, DICOM element lengths and values, YAML/text tokens), then
// runs the target. Every case is reproducible from its number and the run's --seed.
//
//   tsf_fuzz_mutate TARGET --cases N [--seed S] [--corpus DIR|FILE]... [--timeout SEC]
//                   [--memory] [--findings DIR] [--only CASE [--write-case FILE]]
//                   [--summary FILE] [--quiet]
//
// Findings: a crash or sanitizer report (the process ends; the input is saved first), a case
// running longer than --timeout (saved, then the process aborts), an exception other than
// tsf::Error, a wrong result the target's own checks catch (fuzz::WrongResult), and with
// --memory a peak resident memory above 2 × the output volume + 256 MiB. The exit status is 1
// when there was any.
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "fuzz_targets.h"
#include "tsf/common/error.h"
#ifdef TSF_FUZZ_IMPORT
#include "tsf/import/decoder_processes.h"
#endif

extern "C" void __sanitizer_set_death_callback(void (*callback)(void)) __attribute__((weak));

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

namespace {

// ---- what a crash handler needs (fixed storage: it runs in a signal or death callback) ----------
char g_finding_path[4096] = "";
const std::uint8_t* g_input = nullptr;
std::size_t g_input_size = 0;
char g_case_text[256] = "";

void write_text(const char* s) {
  [[maybe_unused]] const ssize_t n = ::write(2, s, std::strlen(s));
}

/// Saves the input of the current case and says which case it was (async-signal-safe).
void save_current_input(const char* what) {
  write_text("\ntsf_fuzz_mutate: ");
  write_text(what);
  write_text(" in ");
  write_text(g_case_text);
  if (g_finding_path[0] != '\0' && g_input) {
    const int fd = ::open(g_finding_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      [[maybe_unused]] const ssize_t n = ::write(fd, g_input, g_input_size);
      ::close(fd);
      write_text("; input saved as ");
      write_text(g_finding_path);
    }
  }
  write_text("\n");
}

extern "C" void on_death() {
  save_current_input("crash (sanitizer report above)");
}

extern "C" void on_fatal_signal(int sig) {
  save_current_input(sig == SIGALRM ? "timeout" : "crash (fatal signal)");
  std::signal(sig == SIGALRM ? SIGABRT : sig, SIG_DFL);
  if (sig == SIGALRM) std::abort();
  std::raise(sig);
}

// ---- mutations
// ------------------------------------------------------------------------------------
struct Rng {
  std::mt19937_64 engine;
  explicit Rng(std::uint64_t seed) : engine(seed) {}
  std::uint64_t below(std::uint64_t n) { return n == 0 ? 0 : engine() % n; }
  bool chance(int percent) { return below(100) < static_cast<std::uint64_t>(percent); }
};

/// Values that tend to sit on the edge of a check.
const std::int64_t kInteresting[] = {
    0,          1,          -1,         2,          7,     8,      16,         31,    32,
    63,         64,         100,        127,        128,   255,    256,        511,   512,
    1000,       1024,       4095,       4096,       32767, 32768,  65535,      65536, 100000,
    0x7FFFFFFF, 0x80000000, 0xFFFFFFFE, 0xFFFFFFFF, -128,  -32768, -2147483647};

const char* const kTokens[] = {"0",
                               "-1",
                               "1e308",
                               "-1e308",
                               "nan",
                               "NaN",
                               "inf",
                               "-inf",
                               "1e-320",
                               "",
                               " ",
                               "\\",
                               "\n",
                               ":",
                               "- ",
                               "[",
                               "]",
                               "{",
                               "}",
                               ",",
                               "&a",
                               "*a",
                               "<<",
                               "!!",
                               "'",
                               "\"",
                               "#",
                               "999999999999999999999",
                               "0x10",
                               "4294967296",
                               "-0",
                               "1.5",
                               "null",
                               "true",
                               "~",
                               "..",
                               "/",
                               "../../etc",
                               "\xef\xbb\xbf",
                               "\t",
                               "%",
                               "2147483648"};

/// Element positions of a DICOM file (explicit or implicit VR little endian), for mutations that
/// hit lengths and values rather than random bytes.
struct DicomElement {
  std::size_t length_at = 0, length_size = 0, value_at = 0, value_size = 0;
};

std::vector<DicomElement> dicom_elements(const Bytes& b) {
  std::vector<DicomElement> out;
  std::size_t at = b.size() >= 132 && std::memcmp(b.data() + 128, "DICM", 4) == 0 ? 132 : 0;
  auto u16 = [&](std::size_t p) { return static_cast<unsigned>(b[p] | (b[p + 1] << 8)); };
  auto u32 = [&](std::size_t p) {
    return static_cast<std::uint32_t>(b[p]) | (static_cast<std::uint32_t>(b[p + 1]) << 8) |
           (static_cast<std::uint32_t>(b[p + 2]) << 16) |
           (static_cast<std::uint32_t>(b[p + 3]) << 24);
  };
  while (at + 8 <= b.size() && out.size() < 4096) {
    const unsigned group = u16(at), element = u16(at + 2);
    DicomElement e;
    if (group == 0xFFFE) {  // item, item and sequence delimiters: tag + 4-byte length
      e.length_at = at + 4;
      e.length_size = 4;
      out.push_back(e);
      at += 8;
      continue;
    }
    (void)element;
    const char v0 = static_cast<char>(b[at + 4]), v1 = static_cast<char>(b[at + 5]);
    const bool explicit_vr = v0 >= 'A' && v0 <= 'Z' && v1 >= 'A' && v1 <= 'Z';
    std::uint64_t length = 0;
    if (explicit_vr) {
      const std::string vr{v0, v1};
      const bool long_form = vr == "OB" || vr == "OW" || vr == "OF" || vr == "SQ" || vr == "UT" ||
                             vr == "UN" || vr == "OD" || vr == "OL" || vr == "UC" || vr == "UR" ||
                             vr == "OV" || vr == "SV" || vr == "UV";
      if (long_form) {
        if (at + 12 > b.size()) break;
        e.length_at = at + 8;
        e.length_size = 4;
        length = u32(at + 8);
        e.value_at = at + 12;
      } else {
        e.length_at = at + 6;
        e.length_size = 2;
        length = u16(at + 6);
        e.value_at = at + 8;
      }
    } else {
      e.length_at = at + 4;
      e.length_size = 4;
      length = u32(at + 4);
      e.value_at = at + 8;
    }
    if (length == 0xFFFFFFFFu) {  // undefined length: walk into it
      out.push_back(e);
      at = e.value_at;
      continue;
    }
    e.value_size = static_cast<std::size_t>(std::min<std::uint64_t>(length, b.size() - e.value_at));
    out.push_back(e);
    if (e.value_at + length > b.size()) break;
    at = e.value_at + static_cast<std::size_t>(length);
  }
  return out;
}

void put_le(Bytes& b, std::size_t at, std::size_t size, std::uint64_t v) {
  for (std::size_t i = 0; i < size && at + i < b.size(); ++i)
    b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

void put_be(Bytes& b, std::size_t at, std::size_t size, std::uint64_t v) {
  for (std::size_t i = 0; i < size && at + i < b.size(); ++i)
    b[at + i] = static_cast<std::uint8_t>(v >> (8 * (size - 1 - i)));
}

/// One random mutation of `b` (`other`: another seed to splice with).
void mutate_once(Bytes& b, const Bytes& other, const std::string& target, Rng& r) {
  if (b.empty()) {
    b.push_back(static_cast<std::uint8_t>(r.below(256)));
    return;
  }
  const bool text = target == "yaml";
  const bool dicom = target == "dicom";
  if (dicom && r.chance(20)) {
    const std::vector<DicomElement> elements = dicom_elements(b);
    if (!elements.empty()) {
      const DicomElement& e = elements[r.below(elements.size())];
      if (r.chance(50) || e.value_size == 0) {
        const std::int64_t v = r.chance(50) ? kInteresting[r.below(std::size(kInteresting))]
                                            : static_cast<std::int64_t>(e.value_size) +
                                                  static_cast<std::int64_t>(r.below(9)) - 4;
        put_le(b, e.length_at, e.length_size, static_cast<std::uint64_t>(v));
      } else if (r.chance(50)) {  // a value's text
        const std::string t = kTokens[r.below(std::size(kTokens))];
        for (std::size_t i = 0; i < e.value_size; ++i)
          b[e.value_at + i] = i < t.size() ? static_cast<std::uint8_t>(t[i]) : ' ';
      } else {
        const std::size_t width = std::size_t{1} << r.below(3);
        if (e.value_size >= width)
          put_le(b, e.value_at + r.below(e.value_size - width + 1), width,
                 static_cast<std::uint64_t>(kInteresting[r.below(std::size(kInteresting))]));
      }
      return;
    }
  }
  const std::size_t n = b.size();
  switch (r.below(text ? 12 : 10)) {
    case 0:
      b[r.below(n)] ^= static_cast<std::uint8_t>(1u << r.below(8));
      break;
    case 1:
      b[r.below(n)] = static_cast<std::uint8_t>(r.below(256));
      break;
    case 2: {  // an interesting integer, 1/2/4/8 bytes, either byte order
      const std::size_t width = std::size_t{1} << r.below(4);
      if (n < width) break;
      const std::size_t at = r.below(n - width + 1);
      const auto v = static_cast<std::uint64_t>(kInteresting[r.below(std::size(kInteresting))]);
      if (r.chance(50))
        put_le(b, at, width, v);
      else
        put_be(b, at, width, v);
      break;
    }
    case 3: {  // add or subtract a little
      const std::size_t at = r.below(n);
      b[at] = static_cast<std::uint8_t>(b[at] + static_cast<std::uint8_t>(r.below(35)) - 17);
      break;
    }
    case 4: {  // delete a block
      const std::size_t len = 1 + r.below(std::min<std::size_t>(n, 1u << (1 + r.below(12))));
      const std::size_t at = r.below(n - len + 1);
      b.erase(b.begin() + static_cast<std::ptrdiff_t>(at),
              b.begin() + static_cast<std::ptrdiff_t>(at + len));
      break;
    }
    case 5: {  // duplicate a block
      const std::size_t len = 1 + r.below(std::min<std::size_t>(n, 1u << (1 + r.below(10))));
      const std::size_t from = r.below(n - len + 1), to = r.below(n + 1);
      const Bytes block(b.begin() + static_cast<std::ptrdiff_t>(from),
                        b.begin() + static_cast<std::ptrdiff_t>(from + len));
      b.insert(b.begin() + static_cast<std::ptrdiff_t>(to), block.begin(), block.end());
      break;
    }
    case 6: {  // insert random bytes
      const std::size_t len = 1 + r.below(64);
      Bytes block(len);
      for (auto& c : block) c = static_cast<std::uint8_t>(r.chance(50) ? r.below(256) : 0xFF);
      b.insert(b.begin() + static_cast<std::ptrdiff_t>(r.below(n + 1)), block.begin(), block.end());
      break;
    }
    case 7: {  // overwrite a block with another part of the input
      const std::size_t len = 1 + r.below(std::min<std::size_t>(n, 256));
      const std::size_t from = r.below(n - len + 1), to = r.below(n - len + 1);
      std::memmove(b.data() + to, b.data() + from, len);
      break;
    }
    case 8:  // truncate
      b.resize(r.below(n) + 1);
      break;
    case 9: {  // splice: our head, the other seed's tail
      if (other.empty()) break;
      const std::size_t keep = r.below(n + 1);
      const std::size_t from = r.below(other.size());
      b.resize(keep);
      b.insert(b.end(), other.begin() + static_cast<std::ptrdiff_t>(from), other.end());
      break;
    }
    case 10: {  // a token replaces a word
      const std::string t = kTokens[r.below(std::size(kTokens))];
      std::size_t at = r.below(n), end = at;
      while (end < n && b[end] != ' ' && b[end] != '\n' && b[end] != ':' && b[end] != ',' &&
             b[end] != ']')
        ++end;
      b.erase(b.begin() + static_cast<std::ptrdiff_t>(at),
              b.begin() + static_cast<std::ptrdiff_t>(end));
      b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), t.begin(), t.end());
      break;
    }
    default: {  // duplicate or drop a line
      std::vector<std::size_t> starts{0};
      for (std::size_t i = 0; i + 1 < n; ++i)
        if (b[i] == '\n') starts.push_back(i + 1);
      const std::size_t k = r.below(starts.size());
      const std::size_t begin = starts[k], end = k + 1 < starts.size() ? starts[k + 1] : n;
      const Bytes line(b.begin() + static_cast<std::ptrdiff_t>(begin),
                       b.begin() + static_cast<std::ptrdiff_t>(end));
      if (r.chance(50))
        b.erase(b.begin() + static_cast<std::ptrdiff_t>(begin),
                b.begin() + static_cast<std::ptrdiff_t>(end));
      else
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(r.below(n + 1)), line.begin(), line.end());
      break;
    }
  }
}

Bytes make_case(const std::vector<Bytes>& seeds, const std::string& target, std::uint64_t seed,
                std::uint64_t index, std::size_t& seed_index) {
  Rng r(seed * 0x9E3779B97F4A7C15ull + index * 0xBF58476D1CE4E5B9ull + 1);
  seed_index = static_cast<std::size_t>(index % seeds.size());  // every seed alike
  Bytes b = seeds[seed_index];
  const Bytes& other = seeds[r.below(seeds.size())];
  const int mutations = r.chance(50) ? 1 : 1 + static_cast<int>(r.below(r.chance(70) ? 3 : 8));
  for (int m = 0; m < mutations; ++m) mutate_once(b, other, target, r);
  if (b.size() > (std::size_t{1} << 22)) b.resize(std::size_t{1} << 22);
  return b;
}

// ---- memory -------------------------------------------------------------------------------------
/// VmRSS or VmHWM of this process, bytes (0 without the import library).
std::uint64_t status_bytes(const char* key) {
#ifdef TSF_FUZZ_IMPORT
  return tsf::import::process_status_bytes(key);
#else
  (void)key;
  return 0;
#endif
}

void reset_peak_memory() {
  std::ofstream("/proc/self/clear_refs") << "5";
}

std::vector<Bytes> load_seeds(const std::vector<std::string>& places,
                              std::vector<std::string>& names) {
  std::vector<fs::path> files;
  for (const std::string& p : places) {
    std::error_code ec;
    if (fs::is_directory(p, ec)) {
      for (const auto& e : fs::directory_iterator(p))
        if (e.is_regular_file() && e.path().filename().string()[0] != '.')
          files.push_back(e.path());
    } else if (fs::is_regular_file(p, ec)) {
      files.push_back(p);
    }
  }
  std::sort(files.begin(), files.end());
  std::vector<Bytes> seeds;
  for (const fs::path& f : files) {
    std::ifstream in(f, std::ios::binary);
    seeds.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    names.push_back(f.string());
  }
  return seeds;
}

int usage() {
  std::fprintf(stderr,
               "usage: tsf_fuzz_mutate TARGET --cases N [--seed S] [--corpus DIR|FILE]... "
               "[--timeout SEC] [--memory] [--findings DIR] [--only CASE [--write-case FILE]] "
               "[--summary FILE] [--quiet]\ntargets:");
  for (const std::string& t : tsf::fuzz::target_names()) std::fprintf(stderr, " %s", t.c_str());
  std::fprintf(stderr, "\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  const std::string target = argv[1];
  const tsf::fuzz::Target run = tsf::fuzz::find_target(target);
  if (!run) return usage();
  std::uint64_t cases = 1000, seed = 1;
  long long only = -1;
  unsigned timeout = 30;
  bool memory = false, quiet = false;
  std::vector<std::string> corpus;
  std::string findings = "fuzz-findings", summary, write_case;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "tsf_fuzz_mutate: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--cases")
      cases = std::stoull(next());
    else if (a == "--seed")
      seed = std::stoull(next());
    else if (a == "--corpus")
      corpus.push_back(next());
    else if (a == "--timeout")
      timeout = static_cast<unsigned>(std::stoul(next()));
    else if (a == "--memory")
      memory = true;
    else if (a == "--findings")
      findings = next();
    else if (a == "--only")
      only = std::stoll(next());
    else if (a == "--write-case")
      write_case = next();
    else if (a == "--summary")
      summary = next();
    else if (a == "--quiet")
      quiet = true;
    else
      return usage();
  }
  if (corpus.empty()) {
    const std::string seeds = target == "dicom_codec" ? "dicom" : target;
    corpus.push_back(std::string(TSF_SOURCE_DIR) + "/fuzz/corpus/" + seeds);
    corpus.push_back(std::string(TSF_SOURCE_DIR) + "/fuzz/regressions/" + seeds);
  }
  std::vector<std::string> seed_names;
  const std::vector<Bytes> seeds = load_seeds(corpus, seed_names);
  if (seeds.empty()) {
    std::fprintf(stderr, "tsf_fuzz_mutate: no seed files for %s\n", target.c_str());
    return 2;
  }
  fs::create_directories(findings);
  if (__sanitizer_set_death_callback) __sanitizer_set_death_callback(on_death);
  for (const int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGALRM})
    std::signal(sig, on_fatal_signal);

  std::uint64_t accepted = 0, refused = 0, wrong = 0, exceptions = 0, over_memory = 0, ran = 0;
  std::uint64_t worst_excess = 0, worst_peak = 0;
  std::string worst_case, slowest_case;
  double slowest = 0;
  std::map<std::string, std::uint64_t> reasons;
  const auto start = std::chrono::steady_clock::now();
  for (std::uint64_t c = 0; c < cases; ++c) {
    if (only >= 0 && c != static_cast<std::uint64_t>(only)) continue;
    std::size_t seed_index = 0;
    const Bytes input = make_case(seeds, target, seed, c, seed_index);
    std::snprintf(g_case_text, sizeof g_case_text, "%s case %llu (seed %llu, from %s)",
                  target.c_str(), static_cast<unsigned long long>(c),
                  static_cast<unsigned long long>(seed),
                  fs::path(seed_names[seed_index]).filename().string().c_str());
    std::snprintf(g_finding_path, sizeof g_finding_path, "%s/%s-seed%llu-case%llu",
                  findings.c_str(), target.c_str(), static_cast<unsigned long long>(seed),
                  static_cast<unsigned long long>(c));
    g_input = input.data();
    g_input_size = input.size();
    if (!write_case.empty())
      std::ofstream(write_case, std::ios::binary)
          .write(reinterpret_cast<const char*>(input.data()),
                 static_cast<std::streamsize>(input.size()));
    std::uint64_t baseline = 0;
    if (memory) {
      reset_peak_memory();
      baseline = status_bytes("VmRSS:");
    }
    const auto t0 = std::chrono::steady_clock::now();
    ::alarm(timeout);
    std::string finding;
    try {
      run(input.data(), input.size());  // a tsf::Error is the target's: last_refusal()
      const std::string& reason = tsf::fuzz::last_refusal();
      if (reason.empty()) {
        ++accepted;
      } else {
        ++refused;
        // Grouped by the start of the message, file names and numbers left out.
        std::string key;
        const std::size_t quote = reason.find("': ");
        for (char ch : reason.substr(quote == std::string::npos ? 0 : quote + 3, 70))
          key += (ch >= '0' && ch <= '9') ? '#' : ch;
        ++reasons[key];
      }
    } catch (const tsf::fuzz::WrongResult& e) {
      ++wrong;
      finding = std::string("wrong result: ") + e.what();
    } catch (const std::exception& e) {
      ++exceptions;
      finding = std::string("exception other than tsf::Error: ") + e.what();
    }
    ::alarm(0);
    ++ran;
    const double took =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (took > slowest) {
      slowest = took;
      slowest_case = g_case_text;
    }
    if (memory) {
      const std::uint64_t peak = status_bytes("VmHWM:");
      const std::uint64_t used =
          (peak > baseline ? peak - baseline : 0) + tsf::fuzz::last_decoder_peak_bytes();
      const std::uint64_t output = tsf::fuzz::last_output_bytes();
      const std::uint64_t excess = used > 2 * output ? used - 2 * output : 0;
      if (excess > worst_excess || worst_case.empty()) {
        worst_excess = excess;
        worst_peak = used;
        worst_case = g_case_text;
      }
      if (excess > (std::uint64_t{256} << 20)) {
        ++over_memory;
        finding = "peak memory " + std::to_string(used >> 20) + " MiB for an output of " +
                  std::to_string(output >> 20) + " MiB (bound: 2 × output + 256 MiB)";
      }
    }
    if (!finding.empty()) {
      std::ofstream(g_finding_path, std::ios::binary)
          .write(reinterpret_cast<const char*>(input.data()),
                 static_cast<std::streamsize>(input.size()));
      std::fprintf(stderr, "tsf_fuzz_mutate: %s: %s; input saved as %s\n", g_case_text,
                   finding.c_str(), g_finding_path);
    }
    if (!quiet && (ran % 1000 == 0))
      std::fprintf(stderr, "tsf_fuzz_mutate %s: %llu cases\n", target.c_str(),
                   static_cast<unsigned long long>(ran));
  }
  g_input = nullptr;
  std::error_code ec;  // the targets' scratch folder (fuzz_targets.cpp)
  fs::remove_all(fs::temp_directory_path() / ("tsf-fuzz-" + std::to_string(::getpid())), ec);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::uint64_t findings_count = wrong + exceptions + over_memory;
  std::printf(
      "fuzz-mutate %s: %llu cases (seed %llu, %zu seed files) in %.0f s: %llu accepted, %llu "
      "refused with a tsf::Error, 0 crashes, 0 hangs (slowest %.2f s: %s), %llu wrong results, "
      "%llu other exceptions",
      target.c_str(), static_cast<unsigned long long>(ran), static_cast<unsigned long long>(seed),
      seeds.size(), seconds, static_cast<unsigned long long>(accepted),
      static_cast<unsigned long long>(refused), slowest, slowest_case.c_str(),
      static_cast<unsigned long long>(wrong), static_cast<unsigned long long>(exceptions));
  if (memory)
    std::printf(
        ", %llu over the memory bound (worst: %llu MiB peak, %llu MiB above 2 × output, %s)",
        static_cast<unsigned long long>(over_memory),
        static_cast<unsigned long long>(worst_peak >> 20),
        static_cast<unsigned long long>(worst_excess >> 20), worst_case.c_str());
  std::printf("\n");
  if (!summary.empty()) {
    std::ofstream s(summary);
    s << "target " << target << "\ncases " << ran << "\nseed " << seed << "\naccepted " << accepted
      << "\nrefused " << refused << "\nwrong " << wrong << "\nexceptions " << exceptions
      << "\nover_memory " << over_memory << "\nworst_peak_mib " << (worst_peak >> 20)
      << "\nworst_excess_mib " << (worst_excess >> 20) << "\nslowest_s " << slowest
      << "\nslowest_case " << slowest_case << "\nseconds " << seconds << "\n";
    for (const auto& [k, v] : reasons) s << "reason " << v << " " << k << "\n";
  }
  return findings_count > 0 ? 1 : 0;
}
