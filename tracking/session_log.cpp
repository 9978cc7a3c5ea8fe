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

bool ReadSession(const std::string& path, std::vector<RecordedDatagram>* out, std::string* error,
                 SessionReadStats* stats) {
  out->clear();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    *error = path + ": no such session log";
    return false;
  }
  lcm::LogFile log(path, "r");
  if (!log.good()) {
    *error = path + ": cannot open the LCM log";
    return false;
  }
  SessionReadStats st;
  int64_t last = INT64_MIN;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    ++st.events;
    if (ev->channel != kRawChannel) {
      ++st.other_channels;
      continue;
    }
    graspsim::dtrack_datagram_t m;
    if (ev->datalen < 0 || m.decode(ev->data, 0, ev->datalen) < 0 || m.size != static_cast<int32_t>(m.data.size()) ||
        m.size > static_cast<int32_t>(UdpReceiver::kBufferBytes)) {
      *error = path + ": event " + std::to_string(st.events) + " on " + kRawChannel +
               " is not a graspsim.dtrack_datagram_t (damaged log or another type)";
      return false;
    }
    if (m.monotonic_utime < last) {
      *error = path + ": event " + std::to_string(st.events) + ": arrival time goes backwards";
      return false;
    }
    last = m.monotonic_utime;
    RecordedDatagram r;
    r.utime = m.utime;
    r.monotonic_utime = m.monotonic_utime;
    r.sequence = m.sequence;
    r.source = m.source;
    r.data.assign(m.data.begin(), m.data.end());
    out->push_back(std::move(r));
  }
  if (stats) *stats = st;
  return true;
}

}  // namespace gs::tracking
