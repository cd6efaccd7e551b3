#include "procman/session.h"

#include <gtest/gtest.h>

namespace objscan {
namespace {

TEST(SessionTest, ParsesProcessListWithQuotesAndComments) {
  std::vector<SessionProcess> p;
  std::string error;
  ASSERT_TRUE(ParseProcessList("# the pipeline\n"
                               "tracker processor /bin/tracker --lcm-url 'udpm://239.255.76.67:7667?ttl=0'\n"
                               "\n"
                               "robot_sim driver /bin/robot_sim --scene \"my scene.scene\"  # comment\n",
                               &p, &error))
      << error;
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0].name, "tracker");
  EXPECT_FALSE(p[0].is_driver);
  EXPECT_EQ(p[0].argv, (std::vector<std::string>{"/bin/tracker", "--lcm-url", "udpm://239.255.76.67:7667?ttl=0"}));
  EXPECT_TRUE(p[1].is_driver);
  EXPECT_EQ(p[1].argv.back(), "my scene.scene");
}

TEST(SessionTest, RejectsMalformedLines) {
  std::vector<SessionProcess> p;
  std::string error;
  EXPECT_FALSE(ParseProcessList("tracker worker /bin/tracker\n", &p, &error));
  EXPECT_NE(error.find("line 1"), std::string::npos);
  EXPECT_FALSE(ParseProcessList("tracker processor '/bin/tracker\n", &p, &error));
}

TEST(SessionTest, ParsesResultsList) {
  std::vector<std::pair<std::string, std::string>> r;
  std::string error;
  ASSERT_TRUE(ParseResultsList("plan=plan.json,simulation=ground_truth/sim_outcome.json", &r, &error)) << error;
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[1].first, "simulation");
  EXPECT_EQ(r[1].second, "ground_truth/sim_outcome.json");
  EXPECT_FALSE(ParseResultsList("plan.json", &r, &error));
  EXPECT_NE(error.find("name=path"), std::string::npos);
  EXPECT_FALSE(ParseResultsList("=plan.json", &r, &error));
  EXPECT_FALSE(ParseResultsList("plan=", &r, &error));
}

}  // namespace
}  // namespace objscan
