// Where tests find data.
//   samples_dir()      data-samples/ in the source tree (always present)
//   shared_data_dir()  the wider corpus: $TSF_SHARED_DATA, else <source>/../shared/data;
//                      std::nullopt when absent (a fresh clone) -> tests skip and say so
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <optional>

namespace tsf::test {

std::filesystem::path source_dir();
std::filesystem::path samples_dir();
std::optional<std::filesystem::path> shared_data_dir();
/// A fresh, empty directory under the build's temp area, removed at process exit.
std::filesystem::path scratch_dir(const std::string& name);

}  // namespace tsf::test

/// Declares `var` = the shared data path, or skips the test with a reason.
#define TSF_SHARED_DATA_OR_SKIP(var)                                                         \
  const auto var##_opt = ::tsf::test::shared_data_dir();                                     \
  if (!var##_opt)                                                                            \
    GTEST_SKIP() << "not run: the wider corpus ../shared/data (or $TSF_SHARED_DATA) is not " \
                    "present on this machine";                                               \
  const std::filesystem::path var = *var##_opt
