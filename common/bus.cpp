#include "common/bus.h"

#include <lcm/eventlog.h>
#include <lcm/lcm.h>

#include <set>
#include <sstream>
#include <thread>

#include <stdexcept>

#include "objscan/control_t.hpp"

namespace objscan {
namespace {

int64_t ReadBigEndian64(const uint8_t* p) {
  uint64_t value = 0;
  for (int i = 0; i < 8; ++i) value = (value << 8) | p[i];
  return static_cast<int64_t>(value);
}

class LcmBus final : public Bus {
 public:
  explicit LcmBus(const std::string& url) : url_(url) {
    lcm_ = lcm_create(url.empty() ? nullptr : url.c_str());
    if (lcm_ == nullptr) throw std::runtime_error("cannot start LCM on '" + url + "'");
  }
  ~LcmBus() override {
    for (auto& sub : subscriptions_) lcm_unsubscribe(lcm_, sub->subscription);
    lcm_destroy(lcm_);
  }

  bool Publish(const std::string& channel, const void* data, int size) override {
    return lcm_publish(lcm_, channel.c_str(), data, static_cast<unsigned int>(size)) == 0;
  }

  void Subscribe(const std::string& channel, RawHandler handler, int queue_capacity) override {
    auto sub = std::make_unique<Sub>();
    sub->handler = std::move(handler);
    sub->subscription = lcm_subscribe(lcm_, channel.c_str(), &LcmBus::Dispatch, sub.get());
    if (sub->subscription == nullptr) throw std::runtime_error("cannot subscribe to '" + channel + "'");
    if (queue_capacity > 0) lcm_subscription_set_queue_capacity(sub->subscription, queue_capacity);
    subscriptions_.push_back(std::move(sub));
  }

  int Handle(int timeout_ms) override {
    const int status = lcm_handle_timeout(lcm_, timeout_ms);
    if (status < 0) return -1;
    return status > 0 ? 1 : 0;
  }

  std::string Describe() const override { return url_.empty() ? std::string("(LCM default)") : url_; }
  bool IsNetwork() const override {
    return url_.empty() || url_.rfind("udpm://", 0) == 0 || url_.rfind("tcpq://", 0) == 0;
  }

 private:
  struct Sub {
    RawHandler handler;
    lcm_subscription_t* subscription = nullptr;
  };

  static void Dispatch(const lcm_recv_buf_t* rbuf, const char* channel, void* user) {
    auto* sub = static_cast<Sub*>(user);
    const std::string channel_name(channel);
    const RawMessage raw{channel_name, rbuf->data, static_cast<int>(rbuf->data_size), rbuf->recv_utime};
    sub->handler(raw);
  }

  std::string url_;
  lcm_t* lcm_ = nullptr;
  std::vector<std::unique_ptr<Sub>> subscriptions_;
};

class SplitBus final : public Bus {
 public:
  SplitBus(std::unique_ptr<Bus> input, std::unique_ptr<Bus> output)
      : input_(std::move(input)), output_(std::move(output)) {}
  bool Publish(const std::string& channel, const void* data, int size) override {
    return output_->Publish(channel, data, size);
  }
  void Subscribe(const std::string& channel, RawHandler handler, int queue_capacity) override {
    input_->Subscribe(channel, std::move(handler), queue_capacity);
  }
  int Handle(int timeout_ms) override { return input_->Handle(timeout_ms); }
  std::string Describe() const override { return "in " + input_->Describe() + ", out " + output_->Describe(); }
  bool IsNetwork() const override { return output_->IsNetwork(); }

 private:
  std::unique_ptr<Bus> input_;
  std::unique_ptr<Bus> output_;
};

class DataLogBus final : public Bus {
 public:
  explicit DataLogBus(const std::string& url) : url_(url) {
    std::string rest = url.substr(std::string("datalog://").size());
    std::string exclude = "PROCESS_STATUS";
    const auto q = rest.find('?');
    if (q != std::string::npos) {
      const std::string query = rest.substr(q + 1);
      rest.resize(q);
      if (query.rfind("exclude=", 0) == 0)
        exclude = query.substr(8);
      else
        throw std::runtime_error("datalog: unknown parameter in '" + url + "'");
    }
    std::stringstream ss(exclude);
    std::string channel;
    while (std::getline(ss, channel, ','))
      if (!channel.empty()) exclude_.insert(channel);
    log_ = lcm_eventlog_create(rest.c_str(), "w");
    if (log_ == nullptr) throw std::runtime_error("cannot write log '" + rest + "'");
  }
  ~DataLogBus() override { lcm_eventlog_destroy(log_); }

  bool Publish(const std::string& channel, const void* data, int size) override {
    if (exclude_.count(channel)) return true;
    int64_t utime = 0;
    if (!RawMessageUtime(data, size, &utime)) return false;
    // Keep event times non-decreasing (lcm-logplayer sleeps on the differences), and do not let one message with a
    // far-off utime (garbage, wall clock) push every later event into the future.
    constexpr int64_t kMaxJumpUs = 3600LL * 1000000LL;
    const auto data_time = static_cast<int64_t>(utime);
    if (next_event_ == 0)
      last_timestamp_ = std::max<int64_t>(0, data_time);
    else if (data_time > last_timestamp_ && data_time - last_timestamp_ <= kMaxJumpUs)
      last_timestamp_ = data_time;
    lcm_eventlog_event_t event{};
    event.eventnum = next_event_++;
    event.timestamp = last_timestamp_;
    event.channellen = static_cast<int32_t>(channel.size());
    event.channel = const_cast<char*>(channel.c_str());
    event.datalen = size;
    event.data = const_cast<void*>(data);
    return lcm_eventlog_write_event(log_, &event) == 0;
  }
  void Subscribe(const std::string&, RawHandler, int) override {}
  int Handle(int timeout_ms) override {
    if (timeout_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(timeout_ms));
    return 0;
  }
  std::string Describe() const override { return url_; }
  bool IsNetwork() const override { return false; }

 private:
  std::string url_;
  std::set<std::string> exclude_;
  lcm_eventlog_t* log_ = nullptr;
  int64_t next_event_ = 0;
  int64_t last_timestamp_ = 0;
};

}  // namespace

bool RawMessageUtime(const void* data, int size, int64_t* utime) {
  if (data == nullptr || size < 16) return false;
  *utime = ReadBigEndian64(static_cast<const uint8_t*>(data) + 8);
  return true;
}

bool RawMessageSeq(const void* data, int size, int64_t* seq) {
  if (data == nullptr || size < 24) return false;
  *seq = ReadBigEndian64(static_cast<const uint8_t*>(data) + 16);
  return true;
}

bool IsDriverMessage(const std::string& channel, const void* data, int size) {
  static const std::set<std::string> kDriverChannels = {"CAMERA_IMAGE", "CAMERA_INFO", "ROBOT_ODOMETRY",
                                                         "GROUND_TRUTH_POSE"};
  if (kDriverChannels.count(channel)) return true;
  if (channel != "OBJSCAN_CONTROL") return false;
  control_t msg;
  return DecodeMessage(data, size, &msg, nullptr) && msg.command == control_t::COMMAND_END_OF_STREAM;
}

void BurstPacer::After() {
  if (!active_ || ++count_ % every_ != 0) return;
  std::this_thread::sleep_for(std::chrono::milliseconds(pause_ms_));
  ++pauses_;
}

std::unique_ptr<Bus> MakeLcmBus(const std::string& url) {
  if (url.rfind("datalog://", 0) == 0) return std::make_unique<DataLogBus>(url);
  return std::make_unique<LcmBus>(url);
}

std::unique_ptr<Bus> MakeBus(const std::string& input_url, const std::string& output_url) {
  if (output_url.empty() || output_url == input_url) return MakeLcmBus(input_url);
  return std::make_unique<SplitBus>(MakeLcmBus(input_url), MakeLcmBus(output_url));
}

}  // namespace objscan
