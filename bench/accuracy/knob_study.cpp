// Registry and formatting of the knob studies (knob_study.h).
#include "knob_study.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace tsf::accuracy {
namespace {

std::vector<KnobStudy>& registry() {
  static std::vector<KnobStudy> studies;  // function-local: safe during static initialisation
  return studies;
}

}  // namespace

bool register_study(KnobStudy study) {
  registry().push_back(std::move(study));
  return true;
}

std::vector<KnobStudy> registered_studies() {
  std::vector<KnobStudy> s = registry();
  std::sort(s.begin(), s.end(), [](const KnobStudy& a, const KnobStudy& b) {
    return a.order != b.order ? a.order < b.order : a.id < b.id;
  });
  return s;
}

std::string format_number(double value, int significant) {
  if (!std::isfinite(value)) return std::isnan(value) ? "NaN" : (value > 0 ? "inf" : "-inf");
  if (value == 0.0) return "0";
  char buffer[64];
  const double magnitude = std::fabs(value);
  if (magnitude >= 1e-3 && magnitude < 1e6) {
    const int digits_before =
        magnitude >= 1.0 ? static_cast<int>(std::floor(std::log10(magnitude))) + 1 : 0;
    int decimals = std::max(0, significant - digits_before);
    if (magnitude < 1.0)
      decimals = significant - 1 - static_cast<int>(std::floor(std::log10(magnitude)));
    std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  } else {
    std::snprintf(buffer, sizeof buffer, "%.*e", std::max(0, significant - 1), value);
  }
  return buffer;
}

std::string format_percent(double fraction, int significant) {
  if (!std::isfinite(fraction)) return format_number(fraction);
  return format_number(100.0 * fraction, significant) + "%";
}

std::string format_seconds(double seconds) {
  if (!std::isfinite(seconds)) return format_number(seconds);
  if (seconds < 1e-6) return format_number(seconds * 1e9, 3) + " ns";
  if (seconds < 1e-3) return format_number(seconds * 1e6, 3) + " µs";
  if (seconds < 1.0) return format_number(seconds * 1e3, 3) + " ms";
  return format_number(seconds, 3) + " s";
}

}  // namespace tsf::accuracy
