// libFuzzer target for recorded sessions (LCM event logs): any file reads to its
// end, to a torn last event, or to an error naming the byte offset or event;
// allocation stays bounded by the file's size.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "tracking/session_log.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = "/tmp/graspsim_lcmlog_fuzz_" + std::to_string(getpid()) + ".lcmlog";
  {
    std::ofstream f(path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  gs::tracking::SessionReader r;
  std::string error;
  if (!r.Open(path, &error)) std::abort();
  gs::tracking::RecordedDatagram d;
  uint64_t n = 0;
  while (r.Next(&d)) {
    if (d.data.size() > size) std::abort();
    ++n;
  }
  if (n > r.stats().events || r.stats().trailing_bytes > size) std::abort();
  if (!r.error().empty() && r.error().find(path) != 0) {
    std::fprintf(stderr, "lcmlog_fuzz: error without the file's name: %s\n", r.error().c_str());
    std::abort();
  }
  std::remove(path.c_str());
  return 0;
}
