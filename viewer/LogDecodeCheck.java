// Reads an LCM log with lcm.jar's lcm.logging.Log and decodes every event with the objscan type classes found on the
// class path (matched by fingerprint). Exits 1 on any event it cannot decode, or when a required type was not seen.
// Usage: java -cp lcm.jar:objscan_lcmtypes.jar:. LogDecodeCheck LOG TYPES_JAR [--require-all]
import java.io.EOFException;
import java.io.IOException;
import java.lang.reflect.Constructor;
import java.util.Enumeration;
import java.util.HashMap;
import java.util.Map;
import java.util.TreeSet;
import java.util.jar.JarEntry;
import java.util.jar.JarFile;

public class LogDecodeCheck {
  public static void main(String[] args) throws Exception {
    if (args.length < 2) {
      System.err.println("usage: LogDecodeCheck LOG TYPES_JAR [--require-all]");
      System.exit(2);
    }
    boolean requireAll = args.length > 2 && args[2].equals("--require-all");
    Map<Long, Class<?>> byFingerprint = new HashMap<>();
    try (JarFile jar = new JarFile(args[1])) {
      for (Enumeration<JarEntry> e = jar.entries(); e.hasMoreElements();) {
        String name = e.nextElement().getName();
        if (!name.endsWith(".class") || name.contains("$")) continue;
        Class<?> cls = Class.forName(name.substring(0, name.length() - 6).replace('/', '.'));
        if (!lcm.lcm.LCMEncodable.class.isAssignableFrom(cls)) continue;
        byFingerprint.put(cls.getField("LCM_FINGERPRINT").getLong(null), cls);
      }
    }
    if (byFingerprint.isEmpty()) {
      System.err.println("no LCM types in " + args[1]);
      System.exit(1);
    }
    TreeSet<String> seen = new TreeSet<>();
    int events = 0, failures = 0;
    lcm.logging.Log log = new lcm.logging.Log(args[0], "r");
    while (true) {
      lcm.logging.Log.Event event;
      try {
        event = log.readNext();
      } catch (EOFException eof) {
        break;
      }
      ++events;
      if (event.data.length < 8) {
        System.err.println("event " + events + " on " + event.channel + ": too short");
        ++failures;
        continue;
      }
      long fingerprint = 0;
      for (int i = 0; i < 8; ++i) fingerprint = (fingerprint << 8) | (event.data[i] & 0xff);
      Class<?> cls = byFingerprint.get(fingerprint);
      if (cls == null) {
        System.err.printf("event %d on %s: unknown fingerprint %016x%n", events, event.channel, fingerprint);
        ++failures;
        continue;
      }
      try {
        Constructor<?> ctor = cls.getConstructor(byte[].class);
        ctor.newInstance((Object) event.data);
        seen.add(cls.getSimpleName());
      } catch (Exception ex) {
        Throwable cause = ex.getCause() != null ? ex.getCause() : ex;
        System.err.println("event " + events + " on " + event.channel + ": " + cls.getSimpleName() + " decode failed: " + cause);
        ++failures;
      }
    }
    log.close();
    System.out.println("events " + events + ", decoded types " + seen + ", failures " + failures);
    if (requireAll) {
      for (Class<?> cls : byFingerprint.values()) {
        if (!seen.contains(cls.getSimpleName())) {
          System.err.println("type never seen in the log: " + cls.getSimpleName());
          ++failures;
        }
      }
    }
    System.exit(failures == 0 && events > 0 ? 0 : 1);
  }
}
