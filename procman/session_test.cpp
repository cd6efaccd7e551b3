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

}  // namespace
}  // namespace objscan
