#include "common/lcm_log.h"

#include <sys/stat.h>

namespace objscan {
namespace {
constexpr uint32_t kMagic = 0xEDA1DA01u;
constexpr int kHeaderBytes = 4 + 8 + 8 + 4 + 4;
constexpr int32_t kMaxChannelBytes = 255;           // LCM's own limit is 63; be lenient, not absurd
constexpr int64_t kMaxDataBytes = 512LL * 1024 * 1024;

uint32_t U32(const uint8_t* p) { return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3]; }
int64_t I64(const uint8_t* p) { return static_cast<int64_t>((uint64_t{U32(p)} << 32) | U32(p + 4)); }
}  // namespace

std::string LcmLogDamage::Describe() const {
  if (!Any()) return "";
  std::string s;
  if (skipped_bytes > 0)
    s = std::to_string(skipped_bytes) + " bytes in " + std::to_string(skipped_regions) + " region" +
        (skipped_regions == 1 ? "" : "s") + " that were no events skipped, the first at byte " +
        std::to_string(first_offset);
  if (truncated_tail) s += std::string(s.empty() ? "" : "; ") + "the last event is cut short";
  return s;
}

LcmLogReader::~LcmLogReader() {
  if (file_) std::fclose(file_);
}

bool LcmLogReader::ReadAt(int64_t offset, void* out, size_t bytes) {
  if (offset < 0 || offset + static_cast<int64_t>(bytes) > size_) return false;
  if (fseeko(file_, offset, SEEK_SET) != 0) return false;
  return std::fread(out, 1, bytes, file_) == bytes;
}

bool LcmLogReader::Open(const std::string& path, std::string* error) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
    *error = "cannot open log " + path + ": no such file";
    return false;
  }
  file_ = std::fopen(path.c_str(), "rb");
  if (!file_) {
    *error = "cannot open log " + path;
    return false;
  }
  size_ = st.st_size;
  if (size_ == 0) {
    *error = path + " is empty: not an LCM log";
    return false;
  }
  uint8_t head[4];
  if (!ReadAt(0, head, 4) || U32(head) != kMagic) {
    *error = path + " is not an LCM log (it does not start with an event header)";
    return false;
  }
  return true;
}

bool LcmLogReader::CutTail() {
  damage_.truncated_tail = true;
  if (damage_.first_offset < 0) damage_.first_offset = offset_;
  offset_ = size_;
  return false;
}

bool LcmLogReader::Next(LcmLogEvent* event) {
  int64_t skip_start = -1;
  auto end_skip = [&](int64_t at) {
    if (skip_start < 0) return;
    damage_.skipped_bytes += at - skip_start;
    ++damage_.skipped_regions;
    if (damage_.first_offset < 0) damage_.first_offset = skip_start;
    skip_start = -1;
  };
  while (file_ && offset_ < size_) {
    uint8_t h[kHeaderBytes];
    const bool have_header = ReadAt(offset_, h, kHeaderBytes);
    if (have_header && U32(h) == kMagic) {
      const int32_t channel_bytes = static_cast<int32_t>(U32(h + 20));
      const int32_t data_bytes = static_cast<int32_t>(U32(h + 24));
      const int64_t end = offset_ + kHeaderBytes + int64_t{channel_bytes} + data_bytes;
      const bool lengths_ok = channel_bytes > 0 && channel_bytes <= kMaxChannelBytes && data_bytes >= 0 &&
                              data_bytes <= kMaxDataBytes;
      if (lengths_ok && end <= size_) {
        event->event_number = I64(h + 4);
        event->timestamp_us = I64(h + 12);
        event->channel.resize(static_cast<size_t>(channel_bytes));
        event->data.resize(static_cast<size_t>(data_bytes));
        if (ReadAt(offset_ + kHeaderBytes, event->channel.data(), event->channel.size()) &&
            (data_bytes == 0 || ReadAt(offset_ + kHeaderBytes + channel_bytes, event->data.data(), event->data.size()))) {
          end_skip(offset_);
          offset_ = end;
          ++events_;
          return true;
        }
      }
      if (lengths_ok && end > size_) {
        // Is there a later header? Then this one was garbage that happened to hold the magic; else the tail is cut.
        bool later = false;
        for (int64_t o = offset_ + 1; o + 4 <= size_ && !later; ++o) {
          uint8_t m[4];
          later = ReadAt(o, m, 4) && U32(m) == kMagic;
        }
        if (!later) {
          end_skip(offset_);
          return CutTail();
        }
      }
    } else if (!have_header && skip_start < 0) {
      // Fewer bytes left than a header: a cut tail if they start like one, else trailing garbage.
      uint8_t m[4];
      if (size_ - offset_ >= 4 && ReadAt(offset_, m, 4) && U32(m) == kMagic) return CutTail();
    }
    if (skip_start < 0) skip_start = offset_;
    ++offset_;  // resynchronise: the next byte that starts a header that parses
  }
  end_skip(offset_);
  return false;
}

LcmLogWriter::~LcmLogWriter() {
  if (file_) std::fclose(file_);
}

bool LcmLogWriter::Open(const std::string& path, std::string* error) {
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) {
    *error = "cannot create log " + path;
    return false;
  }
  path_ = path;
  events_ = 0;
  return true;
}

bool LcmLogWriter::Write(const LcmLogEvent& event, std::string* error) {
  if (!file_) {
    *error = "log not open";
    return false;
  }
  if (event.channel.empty() || event.channel.size() > static_cast<size_t>(kMaxChannelBytes) ||
      event.data.size() > static_cast<size_t>(kMaxDataBytes)) {
    *error = "event with channel '" + event.channel + "' and " + std::to_string(event.data.size()) +
             " bytes cannot be written to an LCM log";
    return false;
  }
  uint8_t h[kHeaderBytes];
  auto put32 = [](uint8_t* p, uint32_t v) {
    p[0] = static_cast<uint8_t>(v >> 24);
    p[1] = static_cast<uint8_t>(v >> 16);
    p[2] = static_cast<uint8_t>(v >> 8);
    p[3] = static_cast<uint8_t>(v);
  };
  auto put64 = [&](uint8_t* p, int64_t v) {
    put32(p, static_cast<uint32_t>(static_cast<uint64_t>(v) >> 32));
    put32(p + 4, static_cast<uint32_t>(static_cast<uint64_t>(v)));
  };
  put32(h, kMagic);
  put64(h + 4, events_);
  put64(h + 12, event.timestamp_us);
  put32(h + 20, static_cast<uint32_t>(event.channel.size()));
  put32(h + 24, static_cast<uint32_t>(event.data.size()));
  if (std::fwrite(h, 1, kHeaderBytes, file_) != static_cast<size_t>(kHeaderBytes) ||
      std::fwrite(event.channel.data(), 1, event.channel.size(), file_) != event.channel.size() ||
      (!event.data.empty() && std::fwrite(event.data.data(), 1, event.data.size(), file_) != event.data.size())) {
    *error = "cannot write to " + path_ + " (disk full?)";
    return false;
  }
  ++events_;
  return true;
}

bool LcmLogWriter::Close(std::string* error) {
  if (!file_) return true;
  const bool ok = std::fflush(file_) == 0 && std::ferror(file_) == 0;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok || !closed) {
    *error = "cannot write to " + path_ + " (disk full?)";
    return false;
  }
  return true;
}

}  // namespace objscan
