#include "tracking/session_log.h"

#include <lcm/lcm-cpp.hpp>

#include <cstdio>
#include <filesystem>

#include "graspsim/dtrack_datagram_t.hpp"

namespace gs::tracking {

std::vector<uint8_t> EncodeDatagram(const Datagram& d) {
  graspsim::dtrack_datagram_t m;
  m.utime = d.utime;
  m.monotonic_utime = d.monotonic_ns / 1000;
  m.sequence = static_cast<int64_t>(d.sequence);
  m.source = d.source;
  m.size = static_cast<int32_t>(d.size);
  m.data.assign(reinterpret_cast<const uint8_t*>(d.data), reinterpret_cast<const uint8_t*>(d.data) + d.size);
  std::vector<uint8_t> buf(static_cast<size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

SessionWriter::SessionWriter() = default;
SessionWriter::~SessionWriter() { Close(); }

bool SessionWriter::Open(const std::string& path, std::string* error) {
  log_ = std::make_unique<lcm::LogFile>(path, "w");
  if (!log_->good()) {
    *error = "cannot write the LCM log '" + path + "'";
    log_.reset();
    return false;
  }
  return true;
}

bool SessionWriter::Write(const Datagram& d) {
  if (!log_) return false;
  std::vector<uint8_t> buf = EncodeDatagram(d);
  lcm::LogEvent ev;
  ev.eventnum = static_cast<int64_t>(written_);
  ev.timestamp = d.utime;
  ev.channel = kRawChannel;
  ev.datalen = static_cast<int32_t>(buf.size());
  ev.data = buf.data();
  if (log_->writeEvent(&ev) != 0) return false;
  ++written_;
  return true;
}

bool SessionWriter::Flush() { return log_ && std::fflush(log_->getFilePtr()) == 0; }

void SessionWriter::Close() { log_.reset(); }

SessionReader::SessionReader() = default;
SessionReader::~SessionReader() {
  if (file_) std::fclose(file_);
}

namespace {

constexpr uint32_t kLcmSyncWord = 0xEDA1DA01u;
constexpr uint32_t kMaxChannelBytes = 1000;  // LCM's own bound on channel names

uint64_t BigEndian(const uint8_t* p, int bytes) {
  uint64_t v = 0;
  for (int k = 0; k < bytes; ++k) v = (v << 8) | p[k];
  return v;
}

}  // namespace

// dtrack_datagram_t, after its 8-byte type hash: utime, monotonic_utime, sequence
// (int64), source (int32 length with its NUL, bytes), size (int32), data (size bytes)
bool DecodeDatagram(const uint8_t* p, size_t n, RecordedDatagram* out, std::string* why) {
  static const uint64_t kHash = static_cast<uint64_t>(graspsim::dtrack_datagram_t::getHash());
  if (n < 8 + 24 + 4 || BigEndian(p, 8) != kHash) {
    *why = "is not a graspsim.dtrack_datagram_t (another type or damaged)";
    return false;
  }
  size_t at = 8;
  out->utime = static_cast<int64_t>(BigEndian(p + at, 8));
  out->monotonic_utime = static_cast<int64_t>(BigEndian(p + at + 8, 8));
  out->sequence = static_cast<int64_t>(BigEndian(p + at + 16, 8));
  at += 24;
  const int64_t source_len = static_cast<int32_t>(BigEndian(p + at, 4));
  at += 4;
  if (source_len < 1 || static_cast<uint64_t>(source_len) > n - at || p[at + source_len - 1] != 0) {
    *why = "has a source address of a bad length";
    return false;
  }
  out->source.assign(reinterpret_cast<const char*>(p + at), static_cast<size_t>(source_len - 1));
  at += static_cast<size_t>(source_len);
  if (n - at < 4) {
    *why = "is cut short before its size";
    return false;
  }
  const int64_t size = static_cast<int32_t>(BigEndian(p + at, 4));
  at += 4;
  if (size < 0 || static_cast<uint64_t>(size) != n - at || static_cast<uint64_t>(size) > UdpReceiver::kBufferBytes) {
    *why = "has a datagram size (" + std::to_string(size) + ") that does not match its event";
    return false;
  }
  out->data.assign(reinterpret_cast<const char*>(p + at), static_cast<size_t>(size));
  return true;
}

bool SessionReader::Fail(const std::string& what) {
  error_ = path_ + ": " + what;
  return false;
}

bool SessionReader::Open(const std::string& path, std::string* error) {
  path_ = path;
  error_.clear();
  stats_ = SessionReadStats();
  last_ = INT64_MIN;
  offset_ = 0;
  if (file_) std::fclose(file_);
  file_ = nullptr;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    *error = error_ = path + ": no such session log";
    return false;
  }
  file_size_ = std::filesystem::file_size(path, ec);
  file_ = ec ? nullptr : std::fopen(path.c_str(), "rb");
  if (!file_) {
    *error = error_ = path + ": cannot open the LCM log";
    return false;
  }
  return true;
}

bool SessionReader::Next(RecordedDatagram* out) {
  if (!file_ || !error_.empty()) return false;
  for (;;) {
    // an event: sync word, event number, timestamp (int64), channel and data lengths (int32), channel, data
    uint8_t header[28];
    const size_t got = std::fread(header, 1, sizeof(header), file_);
    if (got == 0 && std::feof(file_)) return false;  // the end, after a whole event
    const std::string at = "byte " + std::to_string(offset_);
    if (got < sizeof(header) || BigEndian(header, 4) != kLcmSyncWord) {
      if (got >= 4 && BigEndian(header, 4) != kLcmSyncWord)
        return Fail(at + ": no LCM event starts here (not an LCM log, or damaged)");
      stats_.trailing_bytes = file_size_ - offset_;
      return false;
    }
    const int64_t channel_len = static_cast<int32_t>(BigEndian(header + 20, 4));
    const int64_t data_len = static_cast<int32_t>(BigEndian(header + 24, 4));
    if (channel_len <= 0 || channel_len > kMaxChannelBytes || data_len < 0)
      return Fail(at + ": event with a channel name of " + std::to_string(channel_len) + " bytes and " +
                  std::to_string(data_len) + " bytes of data (damaged log)");
    const uint64_t body = static_cast<uint64_t>(channel_len + data_len);
    if (body > file_size_ - offset_ - sizeof(header)) {
      stats_.trailing_bytes = file_size_ - offset_;  // cut short: the recording ended inside this event
      return false;
    }
    channel_.resize(static_cast<size_t>(channel_len));
    event_.resize(static_cast<size_t>(data_len));
    if (std::fread(channel_.data(), 1, channel_.size(), file_) != channel_.size() ||
        std::fread(event_.data(), 1, event_.size(), file_) != event_.size()) {
      stats_.trailing_bytes = file_size_ - offset_;
      return false;
    }
    offset_ += sizeof(header) + body;
    ++stats_.events;
    if (std::string(channel_.begin(), channel_.end()) != kRawChannel) {
      ++stats_.other_channels;
      continue;
    }
    std::string why;
    if (!DecodeDatagram(event_.data(), event_.size(), out, &why))
      return Fail("event " + std::to_string(stats_.events) + " on " + kRawChannel + " " + why);
    if (out->monotonic_utime < last_)
      return Fail("event " + std::to_string(stats_.events) + ": arrival time goes backwards");
    last_ = out->monotonic_utime;
    return true;
  }
}

bool ScanSession(const std::string& path, SessionSummary* out, std::string* error) {
  *out = SessionSummary();
  SessionReader r;
  if (!r.Open(path, error)) return false;
  RecordedDatagram d;
  while (r.Next(&d)) {
    if (out->datagrams == 0) out->first_monotonic_utime = d.monotonic_utime;
    out->last_monotonic_utime = d.monotonic_utime;
    ++out->datagrams;
  }
  out->stats = r.stats();
  if (!r.error().empty()) {
    *error = r.error();
    return false;
  }
  return true;
}

bool ReadSession(const std::string& path, std::vector<RecordedDatagram>* out, std::string* error,
                 SessionReadStats* stats) {
  out->clear();
  SessionReader r;
  if (!r.Open(path, error)) return false;
  RecordedDatagram d;
  while (r.Next(&d)) out->push_back(d);
  if (stats) *stats = r.stats();
  if (!r.error().empty()) {
    *error = r.error();
    return false;
  }
  return true;
}

}  // namespace gs::tracking
