// Message <-> struct adapters for the procman's bus messages (PROCMAN_ORDERS, PROCMAN_DEPUTY, PROCMAN_OUTPUT).
// Decoding (DecodeMessage) has checked the sizes; these check the values: names, states, counts.
#pragma once

#include <cstdint>
#include <string>

#include "objscan/procman_deputy_t.hpp"
#include "objscan/procman_orders_t.hpp"
#include "procman/deputy.h"

namespace objscan {

inline constexpr const char* kProcmanOrdersChannel = "PROCMAN_ORDERS";
inline constexpr const char* kProcmanDeputyChannel = "PROCMAN_DEPUTY";
inline constexpr const char* kProcmanOutputChannel = "PROCMAN_OUTPUT";

procman_orders_t OrdersToMessage(const DeputyOrders& orders, int64_t utime, int64_t seq);
// False with *why on an empty host or process name, or a count that disagrees with an array.
bool OrdersFromMessage(const procman_orders_t& msg, DeputyOrders* orders, std::string* why);

procman_deputy_t DeputyReportToMessage(const DeputyReport& report, int64_t utime, int64_t seq);
// False with *why on an empty host, an unknown state or a count that disagrees with an array.
bool DeputyReportFromMessage(const procman_deputy_t& msg, DeputyReport* report, std::string* why);

}  // namespace objscan
