#include "tracking/session_log.h"

#include <lcm/lcm-cpp.hpp>

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

void SessionWriter::Close() { log_.reset(); }

SessionReader::SessionReader() = default;
SessionReader::~SessionReader() = default;

bool SessionReader::Open(const std::string& path, std::string* error) {
  path_ = path;
  error_.clear();
  stats_ = SessionReadStats();
  last_ = INT64_MIN;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    *error = error_ = path + ": no such session log";
    return false;
  }
  log_ = std::make_unique<lcm::LogFile>(path, "r");
  if (!log_->good()) {
    *error = error_ = path + ": cannot open the LCM log";
    log_.reset();
    return false;
  }
  return true;
}

bool SessionReader::Next(RecordedDatagram* out) {
  if (!log_ || !error_.empty()) return false;
  while (const lcm::LogEvent* ev = log_->readNextEvent()) {
    ++stats_.events;
    if (ev->channel != kRawChannel) {
      ++stats_.other_channels;
      continue;
    }
    graspsim::dtrack_datagram_t m;
    if (ev->datalen < 0 || m.decode(ev->data, 0, ev->datalen) < 0 || m.size != static_cast<int32_t>(m.data.size()) ||
        m.size > static_cast<int32_t>(UdpReceiver::kBufferBytes)) {
      error_ = path_ + ": event " + std::to_string(stats_.events) + " on " + kRawChannel +
               " is not a graspsim.dtrack_datagram_t (damaged log or another type)";
      return false;
    }
    if (m.monotonic_utime < last_) {
      error_ = path_ + ": event " + std::to_string(stats_.events) + ": arrival time goes backwards";
      return false;
    }
    last_ = m.monotonic_utime;
    out->utime = m.utime;
    out->monotonic_utime = m.monotonic_utime;
    out->sequence = m.sequence;
    out->source = m.source;
    out->data.assign(m.data.begin(), m.data.end());
    return true;
  }
  return false;
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
