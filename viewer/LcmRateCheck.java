// Counts the messages per channel that LCM's Java receiver (lcm.lcm.LCM, the one lcm-spy uses) gets on a URL for a
// given time, then prints "CHANNEL COUNT" lines. The headless check of what lcm-spy sees (tests/spy_rate_test.sh).
// Usage: scripts/lcm-java --cp DIR LcmRateCheck URL SECONDS
import java.util.Map;
import java.util.TreeMap;

public class LcmRateCheck {
  public static void main(String[] args) throws Exception {
    if (args.length != 2) {
      System.err.println("usage: LcmRateCheck URL SECONDS");
      System.exit(2);
    }
    final Map<String, Integer> counts = new TreeMap<>();
    lcm.lcm.LCM lcm = new lcm.lcm.LCM(args[0]);
    lcm.subscribeAll(new lcm.lcm.LCMSubscriber() {
      public void messageReceived(lcm.lcm.LCM l, String channel, lcm.lcm.LCMDataInputStream ins) {
        synchronized (counts) {
          counts.merge(channel, 1, Integer::sum);
        }
      }
    });
    System.out.println("listening");
    System.out.flush();
    Thread.sleep((long) (Double.parseDouble(args[1]) * 1000));
    synchronized (counts) {
      for (Map.Entry<String, Integer> e : counts.entrySet()) System.out.println(e.getKey() + " " + e.getValue());
    }
    System.exit(0);
  }
}
