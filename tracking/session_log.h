// Recorded tracker sessions: LCM event logs of raw DTrack datagrams with their
// arrival times (graspsim_dtrack_datagram_t on channel DTRACK_RAW), readable by
// lcm-logplayer and lcm-logger; and the channels live publishes on.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "tracking/udp_receiver.h"

namespace lcm {
class LogFile;
}

namespace gs::tracking {

constexpr const char* kRawChannel = "DTRACK_RAW";             ///< graspsim.dtrack_datagram_t
constexpr const char* kPosesChannel = "GRASPSIM_POSES";       ///< graspsim.poses_t
constexpr const char* kContactsChannel = "GRASPSIM_CONTACTS"; ///< graspsim.contacts_t

struct RecordedDatagram {
  int64_t utime = 0;            ///< arrival, system clock (µs since the epoch)
  int64_t monotonic_utime = 0;  ///< arrival, receiver's steady clock (µs)
  int64_t sequence = 0;
  std::string source;
  std::string data;
};

/// Encodes a datagram as an LCM message (for logs and publishing).
std::vector<uint8_t> EncodeDatagram(const Datagram& d);

/// Decodes a graspsim.dtrack_datagram_t message (its 8-byte type hash first), checking
/// every length against the n bytes given. False with *why ("is not a ...") otherwise.
bool DecodeDatagram(const uint8_t* p, size_t n, RecordedDatagram* out, std::string* why);

class SessionWriter {
 public:
  SessionWriter();
  ~SessionWriter();
  bool Open(const std::string& path, std::string* error);
  bool Write(const Datagram& d);
  uint64_t written() const { return written_; }
  /// Hands what is buffered to the kernel, so that a crash or SIGKILL of this
  /// process loses nothing written before (the log stays readable up to its last whole event).
  bool Flush();
  void Close();

 private:
  std::unique_ptr<lcm::LogFile> log_;
  uint64_t written_ = 0;
};

struct SessionReadStats {
  uint64_t events = 0;            ///< events in the log
  uint64_t other_channels = 0;    ///< events on other channels (ignored)
  /// Bytes after the last whole event: a recording cut short (killed, disk full)
  /// ends with part of an event, which is ignored. Set once the end is reached.
  uint64_t trailing_bytes = 0;
};

/// Reads a session log one datagram at a time (sessions can be longer than memory).
/// Its own reader of the LCM log format (LCM's reader and lcm-gen's decoders trust
/// the lengths in the file): every length is checked against what the file holds,
/// so a damaged or hostile log gives an error naming the byte offset, never an
/// unbounded allocation or an out-of-bounds read.
class SessionReader {
 public:
  SessionReader();
  ~SessionReader();
  bool Open(const std::string& path, std::string* error);
  /// The next datagram; false at the end of the log or on an error (then error() is set).
  bool Next(RecordedDatagram* out);
  const std::string& error() const { return error_; }
  const SessionReadStats& stats() const { return stats_; }

 private:
  bool Fail(const std::string& what);
  std::FILE* file_ = nullptr;
  uint64_t file_size_ = 0, offset_ = 0;  // offset_: just past the last whole event
  std::string path_, error_;
  SessionReadStats stats_;
  int64_t last_ = INT64_MIN;
  std::vector<uint8_t> channel_, event_;
};

/// What a scan of a whole log finds, without keeping the datagrams.
struct SessionSummary {
  uint64_t datagrams = 0;
  int64_t first_monotonic_utime = 0, last_monotonic_utime = 0;
  SessionReadStats stats;
};
bool ScanSession(const std::string& path, SessionSummary* out, std::string* error);

/// Reads every datagram of a session log, in log order. False with a message
/// naming the file and event when the file is missing, damaged or holds a
/// message of another type on DTRACK_RAW, or when arrival times go backwards.
bool ReadSession(const std::string& path, std::vector<RecordedDatagram>* out, std::string* error,
                 SessionReadStats* stats = nullptr);

}  // namespace gs::tracking
