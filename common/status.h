// Process status: counters, rejections by reason, sequence-gap drops and handler latency, published as a full
// process_status_t (stateless: every message is complete) at most once per period on PROCESS_STATUS.
// Not thread-safe: use it from the thread that runs the bus handlers.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "common/statistics.h"

namespace objscan {

class Bus;
class control_t;
struct RawMessage;

// What a sequence number says about the stream it came from:
//   kFirst, kNext, kGap (seqs missing before it: counted as dropped), kRepeatedOrOld (at most kSeqReorderWindow
//   behind the last one: a duplicate or late input), kImplausibleJump (more than kMaxSeqJump ahead or more than
//   kSeqReorderWindow behind: one forged or corrupted seq; the stream keeps its reference, the input should be
//   rejected), kNewRun (the kNewRunInputs-th consecutive input after such a jump: a restarted or replaced source;
//   the stream continues from it, nothing counted as dropped).
enum class SeqResult { kFirst, kNext, kGap, kRepeatedOrOld, kImplausibleJump, kNewRun };
inline constexpr int64_t kMaxSeqJump = 100000;     // inputs (~55 min at 30 Hz)
inline constexpr int64_t kSeqReorderWindow = 300;  // inputs (10 s at 30 Hz)
inline constexpr int kNewRunInputs = 3;

class StatusReporter {
 public:
  // bus may be null (then nothing is published; counters still work, e.g. in unit tests).
  StatusReporter(Bus* bus, std::string name, std::string channel = "PROCESS_STATUS", double period_s = 1.0);

  void CountIn() { ++messages_in_; }
  void CountOut() { ++messages_out_; }
  // Counts a rejected input under `reason` ("image: wrong size"); logs the first one of each reason with detail.
  void Reject(const std::string& reason, const std::string& detail = "");
  // The on_malformed handler of Bus::SubscribeMessage for input `what`: rejects as "<what>: malformed" with the
  // size and channel as detail. The reporter must outlive the subscription.
  std::function<void(const RawMessage&)> MalformedHandler(const std::string& what);
  // Tracks the sequence numbers of one input stream's usable inputs (SeqResult above); a gap adds the seqs neither
  // seen nor noted as rejected (NoteRejectedSeq) to dropped_inputs (saturating at INT64_MAX). Call it once an input
  // is otherwise usable: a rejected one (perhaps with a wild seq) must not move the stream on. A new run is logged.
  SeqResult ObserveSeq(const std::string& stream, int64_t seq);
  // ObserveSeq for an otherwise usable input of `what` ("image"): false after rejecting it as "<what>: out of order
  // or repeated" or "<what>: implausible seq jump".
  bool AcceptSeq(const std::string& stream, int64_t seq, const std::string& what);
  // An input of the stream that was received but rejected: its seq is not counted as dropped by the next gap, and it
  // does not move the stream on. At most 64 such seqs ahead of the stream are remembered (the nearest).
  void NoteRejectedSeq(const std::string& stream, int64_t seq);
  // Reject(reason, detail) of an input with sequence number seq on stream, which NoteRejectedSeq records as received.
  void Reject(const std::string& reason, const std::string& detail, const std::string& stream, int64_t seq);
  // Session isolation (issue 26): drivers stamp image_t, camera_info_t, odometry_t and their control_t with their
  // session's id, processes their control_t with the id they keep to (0 = unstamped, always taken). The first
  // non-zero id is this process's session for its life (a driver sets its own: SetSession); an input of `what`
  // ("image") with another non-zero id is rejected as "<what>: foreign session" (false), each new foreign id is
  // logged as an error at once, and value foreign_session_inputs counts them (the session supervisor fails a run
  // whose process reports any). A second session on one bus (another robot, a log replayed onto a live bus) then
  // never mixes its frames into this one's.
  bool AcceptSession(int64_t session_id, const std::string& what);
  int64_t session_id() const { return session_id_; }  // 0 until the first stamped input
  void SetSession(int64_t session_id) { session_id_ = session_id; }  // a driver's own session, before any input
  void RecordLatencyMs(double ms);
  void SetLastDataUtime(int64_t utime) { last_data_utime_ = utime; }
  void SetValue(const std::string& name, double value);
  // state is a process_status_t::STATE_* constant.
  void SetState(int8_t state, const std::string& detail = "");

  // Publishes when the period has passed since the last publication (or always with force). wall_utime in µs.
  void PublishIfDue(int64_t wall_utime, bool force = false);

  int64_t messages_in() const { return messages_in_; }
  int64_t messages_out() const { return messages_out_; }
  int64_t dropped_inputs() const { return dropped_inputs_; }
  int64_t rejected(const std::string& reason) const;
  int64_t rejected_total() const;
  int8_t state() const { return state_; }
  double value(const std::string& name) const;
  const std::string& name() const { return name_; }

 private:
  Bus* bus_;
  std::string name_;
  std::string channel_;
  std::string host_;
  int64_t period_us_;
  int64_t last_publish_us_ = 0;
  int64_t status_seq_ = 0;
  int8_t state_ = 0;
  std::string state_detail_;
  int64_t last_data_utime_ = 0;
  int64_t messages_in_ = 0;
  int64_t messages_out_ = 0;
  int64_t dropped_inputs_ = 0;
  std::map<std::string, int64_t> rejections_;
  int64_t session_id_ = 0;             // the session's id (0: none heard yet)
  std::set<int64_t> foreign_sessions_;  // foreign ids logged (at most kMaxLoggedSessions)
  int64_t foreign_session_inputs_ = 0;
  struct SeqStream {
    int64_t last = 0;                     // seq of the last usable input
    int64_t jump_last = 0;                // seq of the last input after an implausible jump
    int jump_run = 0;                     // consecutive inputs since that jump
    std::vector<int64_t> rejected_ahead;  // sorted seqs > last received but rejected (NoteRejectedSeq)
  };
  std::map<std::string, SeqStream> streams_;
  std::vector<std::pair<std::string, double>> values_;
  RecentValues latency_window_ms_;  // ms, the last 1000 handler latencies (kLatencyWindow)
};

// A driver's session id (--session-id, StatusReporter::AcceptSession): "" draws a random non-zero one; otherwise
// 1-16 hex digits (an optional 0x), not all zero. False with *error otherwise.
bool SessionIdFromText(const std::string& text, int64_t* id, std::string* error);
// The id as 16 hex digits (how logs, processes.txt and summary.json show it).
std::string SessionIdText(int64_t id);

// The answer of a processing node to end of stream: control_t COMMAND_FINISHED from sender to "*" with the data time
// and seq of its last input and a free-text argument, on channel; counted as an output on status, a failed
// publication logged.
void PublishFinished(Bus& bus, StatusReporter& status, const std::string& channel, const std::string& sender,
                     int64_t utime, int64_t last_seq, const std::string& argument = "");

// True for control_t COMMAND_FINALIZE addressed to `name`: the session asks a process to run its final phase on what
// it has now, as on its usual trigger (end of stream, an upstream FINISHED), e.g. because a process upstream died or
// the run was interrupted. argument says why. A process that has finished already ignores it.
bool IsFinalizeRequest(const control_t& msg, const std::string& name);

}  // namespace objscan
