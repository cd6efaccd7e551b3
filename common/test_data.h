// Where the tests find the real image sets (../shared/data: Middlebury rings, Oxford dinosaur; each set's SOURCE.txt
// says where it comes from). Header-only, for tests and benchmarks.
#pragma once

#include <cstdlib>
#include <string>

namespace objscan {

// The folder of the real image sets: $OBJSCAN_DATA_DIR (CTest sets it, cmake/ObjscanTest.cmake), else
// $OBJSCAN_SOURCE_DIR/../shared/data (CTest sets both), else ../shared/data from the working directory. The folder may
// not exist: callers skip then and say so.
inline std::string SharedDataDir() {
  const char* data = std::getenv("OBJSCAN_DATA_DIR");
  if (data && *data) return data;
  const char* source = std::getenv("OBJSCAN_SOURCE_DIR");
  return source && *source ? std::string(source) + "/../shared/data" : std::string("../shared/data");
}

// SharedDataDir() + "/" + relative.
inline std::string SharedDataPath(const std::string& relative) { return SharedDataDir() + "/" + relative; }

}  // namespace objscan
