// The message bus every objscan process talks through. LCM sits behind this one interface so that live runs
// (udpm://), in-process tests (memq://) and log replay (file://...?speed=0 in, file://...?mode=w or udpm:// out)
// run the very same node code.
#pragma once

#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/message_size_check.h"

namespace objscan {

// Default live URL: multicast on this host only (ttl=0) with a receive buffer large enough for 640x480 frames
// at 30 Hz (must be <= net.core.rmem_max to take full effect).
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";

// A received message as bytes. data is valid only during the handler call.
struct RawMessage {
  const std::string& channel;
  const void* data;
  int size;
  int64_t recv_utime;  // µs, when the bus received it (NOT the data time: use the message's own utime)
  std::string why = "";  // for on_malformed (SubscribeMessage): why it did not decode
};

using RawHandler = std::function<void(const RawMessage&)>;

// Every objscan message type starts with int64 utime (µs, data time) and most continue with int64 seq: after LCM's
// 8-byte type fingerprint they are big-endian at bytes 8..15 and 16..23. These read them without decoding the type
// (logs, monitors, drivers' lockstep). False when the message is too short.
bool RawMessageUtime(const void* data, int size, int64_t* utime);
bool RawMessageSeq(const void* data, int size, int64_t* seq);

// What a robot's drivers publish (camera, base, simulator): CAMERA_IMAGE, CAMERA_INFO, ROBOT_ODOMETRY,
// GROUND_TRUTH_POSE, and on OBJSCAN_CONTROL their end of stream only (the processes' own control messages, such as
// COMMAND_FINISHED, would end a new run's phases early). What a session log is replayed from, in one process
// (objscan replay) or into live processes (`objscan log filter --sensors`, then lcm-logplayer).
bool IsDriverMessage(const std::string& channel, const void* data, int size);

class Bus {
 public:
  virtual ~Bus() = default;

  // Publishes bytes on a channel. Returns false on failure (e.g. publishing on a read-mode log).
  virtual bool Publish(const std::string& channel, const void* data, int size) = 0;

  // Subscribes to a channel (an LCM regular expression). queue_capacity > 0 sets how many undelivered messages
  // the subscription keeps before dropping (slow handlers drop there otherwise). Handlers run inside Handle().
  virtual void Subscribe(const std::string& channel, RawHandler handler, int queue_capacity = 0) = 0;

  // Waits up to timeout_ms for a message and dispatches it to its handlers (0 = do not wait).
  // Returns 1 when something was handled, 0 on timeout, -1 at the end of a log or on a bus error.
  virtual int Handle(int timeout_ms) = 0;

  // Human-readable description (URLs) for start-up output.
  virtual std::string Describe() const = 0;

  // True when published messages go out on a network transport (udpm://, tcpq://, LCM's default), where slow
  // subscribers drop bursts; false for memq://, file:// and datalog:// outputs.
  virtual bool IsNetwork() const = 0;

  // Encodes and publishes an LCM message type. Returns false when encoding or publishing fails.
  template <class Msg>
  bool PublishMessage(const std::string& channel, const Msg& msg) {
    const int size = msg.getEncodedSize();
    std::vector<uint8_t> buffer(static_cast<size_t>(size > 0 ? size : 0));
    if (size < 0 || msg.encode(buffer.data(), 0, size) != size) return false;
    return Publish(channel, buffer.data(), size);
  }

  // Subscribes with decoding (DecodeMessage, common/message_size_check.h: declared array sizes are checked against
  // the bytes before anything is allocated). on_message gets the decoded message; on_malformed (may be empty) gets
  // messages that do not decode as Msg (wrong type, truncated, forged sizes) with RawMessage::why set, so the caller
  // can count and report them.
  template <class Msg>
  void SubscribeMessage(const std::string& channel, std::function<void(const Msg&, const RawMessage&)> on_message,
                        std::function<void(const RawMessage&)> on_malformed = {}, int queue_capacity = 0) {
    Subscribe(
        channel,
        [on_message, on_malformed](const RawMessage& raw) {
          Msg msg;
          std::string why;
          if (!DecodeMessage(raw.data, raw.size, &msg, &why)) {
            if (on_malformed) on_malformed(RawMessage{raw.channel, raw.data, raw.size, raw.recv_utime, why});
            return;
          }
          on_message(msg, raw);
        },
        queue_capacity);
  }
};

// Paces a burst of messages on a network bus. Every LCM subscription keeps a bounded queue of undelivered
// messages (30 unless set), and lcm-logger 1.3.1 receives every channel through one ".*" subscription with that
// default: measured here, 200 small messages published back to back left 31-93 in its log, paced 10 per 10 ms
// left all 200. Call After() once per published message of a burst (final poses, a late-posed window); on a
// network bus it sleeps pause_ms after every `every` messages (blocks the caller), elsewhere it does nothing, so
// log replay and memq tests run at full speed.
class BurstPacer {
 public:
  explicit BurstPacer(const Bus& bus, int every = 10, int pause_ms = 10)
      : active_(bus.IsNetwork()), every_(every > 0 ? every : 1), pause_ms_(pause_ms) {}
  void After();
  int pauses() const { return pauses_; }  // how many times After() slept

 private:
  bool active_;
  int every_;
  int pause_ms_;
  int count_ = 0;
  int pauses_ = 0;
};

// A bus on one LCM instance (any LCM URL). Throws std::runtime_error when LCM cannot start on the URL.
// Also accepts "datalog://PATH[?exclude=CH1,CH2]": a publish-only log writer whose event timestamps are the
// messages' own data time (the int64 utime every objscan type starts with), so that lcm-logplayer replays it at
// the data rate. Channels in exclude (default PROCESS_STATUS, whose utime is wall clock) are not written. Event
// times never decrease, and a message whose utime jumps more than an hour past the previous event (garbage, or a
// wall-clock field) keeps the previous event time.
// Subscriptions on a datalog bus never fire and Handle() returns 0.
std::unique_ptr<Bus> MakeLcmBus(const std::string& url);

// Input and output on separate LCM instances (needed to replay a file:// log and publish elsewhere).
// When output_url is empty or equal to input_url, returns a single-instance bus. Throws std::runtime_error.
std::unique_ptr<Bus> MakeBus(const std::string& input_url, const std::string& output_url = "");

}  // namespace objscan
