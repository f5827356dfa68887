// The Java half of tests/java/java_test.sh: reads LCM logs with lcm.jar's lcm.logging.Log and
// decodes their events with the classes lcm-gen -j made of proto/*.lcm (every top-level class
// of package trioct in TYPES_JAR, told apart by fingerprint). No bus, no display.
//   TrioctLogCheck check TYPES_JAR LOG...     every event whose fingerprint is a type's is
//       decoded and encoded again, and must give the very bytes back; a line per log (events,
//       decoded, failed, by type) and one per failure
//   TrioctLogCheck dump TYPES_JAR CHANNEL LOG every event on CHANNEL (* for all) decoded: an
//       "event N TYPE on CHANNEL" line, then "path = value" for every field, nested structs and
//       arrays spelled out; strings quoted, with \n, \", \\ and \\uXXXX beyond ASCII
// Exits 1 when an event failed to decode or to round-trip, or a dumped event's fingerprint is
// none of the jar's types; 2 on bad arguments.
import java.io.EOFException;
import java.lang.reflect.Array;
import java.lang.reflect.Field;
import java.lang.reflect.Modifier;
import java.util.Arrays;
import java.util.Enumeration;
import java.util.LinkedHashMap;
import java.util.Map;
import java.util.TreeMap;
import java.util.zip.ZipEntry;
import java.util.zip.ZipFile;

import lcm.lcm.LCMDataOutputStream;
import lcm.lcm.LCMEncodable;
import lcm.logging.Log;

public final class TrioctLogCheck {
    private static final Map<Long, Class<?>> byFingerprint = new LinkedHashMap<>();

    // Every trioct/NAME.class of the jar, loaded, by its LCM_FINGERPRINT.
    private static void loadTypes(String jarPath) throws Exception {
        try (ZipFile jar = new ZipFile(jarPath)) {
            for (Enumeration<? extends ZipEntry> en = jar.entries(); en.hasMoreElements();) {
                String n = en.nextElement().getName();
                if (!n.matches("trioct/[A-Za-z0-9_]+\\.class")) {
                    continue;
                }
                Class<?> c = Class.forName(n.substring(0, n.length() - 6).replace('/', '.'));
                if (!LCMEncodable.class.isAssignableFrom(c)) {
                    throw new IllegalStateException(c.getName() + " is not an LCMEncodable");
                }
                byFingerprint.put(c.getField("LCM_FINGERPRINT").getLong(null), c);
            }
        }
    }

    private static Class<?> typeOf(byte[] data) {
        if (data.length < 8) {
            return null;
        }
        long f = 0;
        for (int i = 0; i < 8; i++) {
            f = (f << 8) | (data[i] & 0xff);
        }
        return byFingerprint.get(f);
    }

    private static LCMEncodable decode(Class<?> c, byte[] data) throws Exception {
        return (LCMEncodable) c.getConstructor(byte[].class).newInstance((Object) data);
    }

    private static Log.Event next(Log log) throws Exception {
        try {
            return log.readNext();
        } catch (EOFException eof) {
            return null;
        }
    }

    private static int check(String[] args) throws Exception {
        int failures = 0;
        for (int a = 2; a < args.length; a++) {
            Log log = new Log(args[a], "r");
            int events = 0;
            int decoded = 0;
            int failed = 0;
            Map<String, Integer> byType = new TreeMap<>();
            for (Log.Event e; (e = next(log)) != null;) {
                events++;
                Class<?> c = typeOf(e.data);
                if (c == null) {
                    continue; // not a trioct message: a self-test token, a mark, foreign bytes
                }
                String why = null;
                try {
                    LCMDataOutputStream out = new LCMDataOutputStream(e.data.length);
                    decode(c, e.data).encode(out);
                    byte[] again = Arrays.copyOf(out.getBuffer(), out.size());
                    if (again.length != e.data.length) {
                        why = "encoded again in " + again.length + " bytes, not " + e.data.length;
                    } else if (!Arrays.equals(again, e.data)) {
                        why = "encoded again to other bytes";
                    }
                } catch (Exception ex) {
                    why = (ex.getCause() != null ? ex.getCause() : ex).toString();
                }
                if (why == null) {
                    decoded++;
                    byType.merge(c.getSimpleName(), 1, Integer::sum);
                } else {
                    failed++;
                    System.out.println("FAILED: " + args[a] + " event " + e.eventNumber + " on " + e.channel + " as "
                            + c.getSimpleName() + ": " + why);
                }
            }
            log.close();
            failures += failed;
            System.out.println(args[a] + ": " + events + " events, " + decoded + " decoded and encoded again to the same bytes, "
                    + failed + " failed " + byType);
        }
        return failures == 0 ? 0 : 1;
    }

    private static String quote(String s) {
        StringBuilder b = new StringBuilder("\"");
        for (char ch : s.toCharArray()) {
            if (ch == '"' || ch == '\\') {
                b.append('\\').append(ch);
            } else if (ch == '\n') {
                b.append("\\n");
            } else if (ch < 0x20 || ch > 0x7e) {
                b.append(String.format("\\u%04x", (int) ch));
            } else {
                b.append(ch);
            }
        }
        return b.append('"').toString();
    }

    private static void print(String path, Object v) throws IllegalAccessException {
        if (v == null) {
            System.out.println(path + " = null");
        } else if (v.getClass().isArray()) {
            int n = Array.getLength(v);
            System.out.println(path + ".length = " + n);
            for (int i = 0; i < n; i++) {
                print(path + "[" + i + "]", Array.get(v, i));
            }
        } else if (v instanceof LCMEncodable) {
            for (Field f : v.getClass().getFields()) {
                if (!Modifier.isStatic(f.getModifiers())) {
                    print(path.isEmpty() ? f.getName() : path + "." + f.getName(), f.get(v));
                }
            }
        } else if (v instanceof String) {
            System.out.println(path + " = " + quote((String) v));
        } else {
            System.out.println(path + " = " + v);
        }
    }

    private static int dump(String[] args) throws Exception {
        Log log = new Log(args[3], "r");
        int status = 0;
        for (Log.Event e; (e = next(log)) != null;) {
            if (!args[2].equals("*") && !e.channel.equals(args[2])) {
                continue;
            }
            Class<?> c = typeOf(e.data);
            if (c == null) {
                System.out.println("event " + e.eventNumber + " on " + e.channel + ": no type of the jar has its fingerprint");
                status = 1;
                continue;
            }
            System.out.println("event " + e.eventNumber + " " + c.getSimpleName() + " on " + e.channel);
            print("", decode(c, e.data));
        }
        log.close();
        return status;
    }

    public static void main(String[] args) throws Exception {
        boolean isCheck = args.length >= 3 && args[0].equals("check");
        boolean isDump = args.length == 4 && args[0].equals("dump");
        if (!isCheck && !isDump) {
            System.err.println("usage: TrioctLogCheck check TYPES_JAR LOG... | dump TYPES_JAR CHANNEL LOG");
            System.exit(2);
        }
        loadTypes(args[1]);
        System.exit(isCheck ? check(args) : dump(args));
    }
}
